"""``contactrig sessions``'s run index: ``--where`` search, ``--tag``/``--remark``, ``--diff`` (thin layer over
:mod:`daq.run_index`, :mod:`daq.session_diff`; the plain listing is :func:`contactrig.cli.live.sessions_command`)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def add_index_options(parser: argparse.ArgumentParser) -> None:
    """``--where``, ``--tag``, ``--remark`` and ``--diff`` on ``contactrig sessions``."""
    from daq.run_index import FIELD_HELP, WHERE_KEYS

    keys = "; ".join(f"{k}: {what}" for k, (_, what) in WHERE_KEYS.items()) + f"; or {FIELD_HELP}"
    parser.add_argument(
        "--where", action="append", default=None, metavar="COND",
        help=f"only sessions meeting COND (repeat: all must hold): KEY=VALUE, KEY~TEXT, start>=DATE, start<=DATE; "
        f"{keys}",
    )  # fmt: skip
    parser.add_argument(
        "--tag", default=None, metavar="TAG",
        help="add TAG to the session file given as DIR (in the folder's .contactrig-notes.jsonl, on a network share "
        ".contactrig-notes.HOST.jsonl, with who and when; the session file is not touched)",
    )  # fmt: skip
    parser.add_argument("--remark", default=None, metavar="TEXT", help="add a remark (one line) like --tag")
    parser.add_argument(
        "files", nargs="*", default=[], metavar="A.h5 B.h5",
        help="with DIR given as `diff`: `contactrig sessions diff A.h5 B.h5` compares two session files (as --diff)",
    )  # fmt: skip
    parser.add_argument(
        "--diff", default=None, metavar="B.h5",
        help="compare the session file given as DIR with B.h5: scene, overrides, instrument identities and settings, "
        "software versions",
    )  # fmt: skip


def _file(args: argparse.Namespace, option: str) -> Path:
    from contactrig.core.validation import SettingError

    path = Path(args.folder)
    if not path.is_file():
        raise SettingError("FILE", str(path), f"a session file for {option} (give the file in place of DIR)")
    return path


def _diff_form(args: argparse.Namespace) -> None:
    """``contactrig sessions diff A.h5 B.h5``: taken as ``contactrig sessions A.h5 --diff B.h5``."""
    from contactrig.core.validation import SettingError

    if args.files:
        if args.folder != "diff" or len(args.files) != 2 or args.diff is not None:
            shown = " ".join([args.folder, *args.files])
            raise SettingError("sessions", shown, "DIR alone, or `diff A.h5 B.h5` (two session files)")
        args.folder, args.diff = args.files


def index_command(args: argparse.Namespace) -> int | None:
    """Run ``--diff``/``--tag``/``--remark`` or the ``--where`` search; None when the plain listing applies."""
    from contactrig.core.text import escape_terminal as safe

    _diff_form(args)
    if args.diff is not None:
        from daq.session_diff import format_diff, session_diff

        if args.tag or args.remark or args.where:
            raise ValueError("--diff compares two files: give it without --tag, --remark or --where")
        diff = session_diff(_file(args, "--diff"), args.diff)
        if args.json:
            from contactrig.cli.options import json_units

            print(json.dumps({"units": json_units(), **diff}, indent=2))
        else:
            print(format_diff(diff))
        return 0
    if args.tag is not None or args.remark is not None:
        from daq.run_index import add_mark

        if args.where:
            raise ValueError("--tag and --remark mark one file: give them without --where")
        path = _file(args, "--tag" if args.tag is not None else "--remark")
        for kind, text in (("tag", args.tag), ("remark", args.remark)):
            if text is not None:
                mark = add_mark(path, kind, text)
                print(f"{safe(str(path))}: {kind} {safe(mark['text'])!r} by {safe(mark['who'])} at {mark['at']}",
                      file=sys.stderr)  # fmt: skip
        return 0
    if not Path(args.folder).is_dir():
        if args.where:
            from contactrig.core.validation import SettingError

            raise SettingError("DIR", args.folder, "an existing folder for --where")
        return None
    return _search(args)


def _search(args: argparse.Namespace) -> int:
    from contactrig.core.text import escape_terminal as safe
    from daq.index import format_table
    from daq.run_index import entry_of, parse_where, query

    where = [parse_where(w) for w in args.where or []]
    if args.sample is not None:
        where.append(parse_where(f"sample~{args.sample}"))
    rows, refreshed = query(args.folder, where, sort=args.sort, include_other=args.all, detail=args.json)
    for note in refreshed.notes:
        print(f"note: {safe(note)}", file=sys.stderr)
    if args.json:
        print(json.dumps(rows, indent=2))  # JSON escapes control characters itself
        return 0
    fits = [_fit_cell(r["fit"]) for r in rows] if any(r["fit"] for r in rows) else None  # a column once fitted
    print(format_table([entry_of(r) for r in rows], base=args.folder, fits=fits))
    marked = [r for r in rows if r["tags"] or r["remarks"]]
    for r in marked:
        print(f"{safe(Path(r['path']).name)}:")
        for kind in ("tags", "remarks"):
            for m in r[kind]:
                print(f"    {kind[:-1]}: {safe(m['text'])}  ({safe(m['who'])}, {m['at']})")
    if not rows:
        print("(no session files)" if not where else "(no session meets the conditions)", file=sys.stderr)
    return 0


def _fit_cell(fit: dict | None) -> str:
    """The last fit's verdict and best model for the table ("" never fitted; "(stale)": another analysis version)."""
    if not fit:
        return ""
    return f"{fit['verdict']} {fit['best']}" + (f" (stale: {fit['analysis_version']})" if fit["stale"] else "")
