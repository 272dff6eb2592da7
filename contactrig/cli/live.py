"""``contactrig watch``, ``export`` and ``sessions``: a session while it runs, out of contactrig, and the index.

Thin layers over :func:`analysis.watch.watch`, :mod:`daq.export` and :func:`daq.index.index_sessions`; nothing
heavy is imported at module level.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path


def _seconds(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--every = {text!r}: expected seconds > 0") from None
    if not (x > 0) or math.isinf(x):
        raise argparse.ArgumentTypeError(f"--every = {text!r}: expected seconds > 0")
    return x


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``watch``, ``export`` and ``sessions``."""
    from contactrig.cli.options import add_models_option

    w = subparsers.add_parser(
        "watch",
        help="live view of a session file while it is acquired (or of a finished one): figure and status line",
        description=(
            "Follow SESSION (being written by `contactrig acquire` in another terminal, or finished): R against "
            "weight with every repeat and mean ± SD, the last block's readings against time, and a status line "
            "(weight, block, ETA, invalid readings, blocks in compliance) printed whenever it changes. In a window "
            "that stays open on the finished session until closed; with --png, headless: the snapshot PATH is "
            "rewritten every --every seconds and the command returns when nobody writes the file any more. Without a "
            "display and without --png: the status text only, on stdout."
        ),
    )
    w.add_argument("session", help="session file (HDF5)")
    w.add_argument(
        "--png", default=None, metavar="PATH", help="headless: rewrite this PNG snapshot instead of a window"
    )
    w.add_argument("--every", type=_seconds, default=2.0, metavar="S", help="seconds between reads (default 2)")
    w.add_argument("--once", action="store_true", help="draw the file as it is now and return")
    w.add_argument(
        "--force", action="store_true",
        help="overwrite an existing --png file that is not a snapshot (a snapshot of watch or acquire --live, marked "
        "in its PNG metadata, is rewritten without it; a symbolic link is never followed)",
    )  # fmt: skip
    w.set_defaults(handler=watch_command)

    e = subparsers.add_parser(
        "export",
        help="a session (Tab. 1-style summary and raw readings) or a fit, as CSV or Excel; a session as netCDF",
        description=(
            "SESSION.h5: a Tab. 1-style summary (weight × repeat block means, units in the headers: `contactrig "
            "import` reads it back to the same numbers) and every reading. A fit: give a saved `contactrig fit … "
            "--json` output (FIT.json), or SESSION.h5 with --fit (fitted now, like `contactrig fit`, against --sim "
            "or the rig simulated now). CSV writes one file per table (PATH and PATH-<table>.csv beside it); xlsx "
            "one workbook (openpyxl, in the base install). netcdf: the session as one netCDF-4 file (SESSION.nc; an "
            "xarray Dataset with dimensions block and reading, CF units, flagged readings with their flags, the "
            "session's metadata as attributes; needs the netcdf extra)."
        ),
    )
    e.add_argument("source", help="session file (HDF5), or a fit saved from `contactrig fit … --json`")
    e.add_argument("--to", choices=("csv", "xlsx", "netcdf"), default="csv", help="output format (default csv)")
    e.add_argument("-o", "--output", default=None, metavar="PATH", help="output file (default: beside SOURCE)")
    e.add_argument("--fit", action="store_true", help="export the fit of SESSION against the models")
    e.add_argument("--sim", default=None, metavar="SIM.h5", help="--fit: simulation sweep file (default: simulate now)")
    e.add_argument("--bootstrap", type=int, default=2000, metavar="N", help="--fit: bootstrap resamples (0: none)")
    e.add_argument(
        "--conversion", choices=("bulk", "holm", "physical"), default="bulk", help="--fit: as for `contactrig fit`"
    )
    add_models_option(e, default="--fit: all in the sweep")
    e.add_argument("--force", action="store_true", help="overwrite existing output files")
    e.set_defaults(handler=export_command)

    s = subparsers.add_parser(
        "sessions",
        help="index of the session files under a folder: start, sample, operator, status, blocks, simulated or real",
        description=(
            "List every session file (.h5, .hdf5, .nxs) under DIR (default: the current folder), sorted by start "
            "time. A file that cannot be read is listed as CORRUPT with the reason; nothing stops the listing. The "
            "listing is kept in DIR/.contactrig-index.sqlite (a cache: only new or changed files are read again; "
            "deleting it loses nothing; for a folder on a network share, or with CONTACTRIG_INDEX_DIR set, in a "
            "cache on this computer); tags and remarks in .contactrig-notes.jsonl beside the sessions "
            "(.contactrig-notes.HOST.jsonl on a share)."
        ),
    )
    s.add_argument("folder", nargs="?", default=".", metavar="DIR", help="folder to search (recursively)")
    s.add_argument("--sample", default=None, help="only sessions whose sample contains this text (case-insensitive)")
    s.add_argument(
        "--sort", choices=("start", "sample", "operator", "status", "path"), default="start", help="sort key"
    )
    s.add_argument("--all", action="store_true", help="also list HDF5 files that are not sessions")
    s.add_argument("--json", action="store_true", help="print the index as JSON")
    from contactrig.cli.session_index import add_index_options

    add_index_options(s)  # the run index (issue 29): --where, --tag, --remark, --diff
    s.set_defaults(handler=sessions_command)


def watch_command(args: argparse.Namespace) -> int:
    from analysis.watch import watch

    watch(args.session, png=args.png, every=args.every, force=args.force, once=args.once)
    if args.png is not None:
        from contactrig.core.text import escape_terminal as safe

        print(f"snapshot: {safe(args.png)}", file=sys.stderr)
    return 0


def _fit_json(args: argparse.Namespace) -> dict:
    """The fit of ``args.source``: a saved ``fit --json`` file, or the session fitted now (``--fit``)."""
    if not args.fit:
        text = Path(args.source).read_text(encoding="utf-8")
        try:
            return json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"{args.source}: not the JSON of `contactrig fit … --json` ({exc})") from None
    from analysis.pipeline import analyse_session

    a = analyse_session(args.source, args.sim, models=args.models, n_boot=args.bootstrap, conversion=args.conversion)
    if a.comparison is None:
        raise ValueError("; ".join(n for n in a.left_out if n.startswith("no fit")) or "no fit possible")
    d = a.comparison.as_dict()
    d["measured"] = {k: v for k, v in a.measured_info.items() if k in ("path", "kind", "complete", "status")}
    d["simulation"] = a.sim_info.get("source")
    return dict(d)


def export_command(args: argparse.Namespace) -> int:
    from contactrig.core.text import escape_terminal as safe
    from daq.export import default_output, export_fit, export_session

    is_json = Path(args.source).suffix.lower() == ".json"
    if args.fit and is_json:
        raise ValueError("--fit fits a session file; a saved fit (.json) is exported without --fit")
    if (args.sim is not None or args.models is not None) and not args.fit:
        raise ValueError("--sim and --models only apply to --fit")
    if args.to == "netcdf":
        if args.fit or is_json:
            raise ValueError("--to netcdf exports a session file; a fit is exported as csv or xlsx")
        from analysis.session_dataset import write_netcdf

        print(f"wrote {safe(write_netcdf(args.source, args.output, force=args.force))}", file=sys.stderr)
        return 0
    if args.fit or is_json:
        out = args.output or default_output(args.source, args.to, "" if is_json else "-fit")
        if args.fit:  # check the outputs before the (slow) fit
            from contactrig.core.files import refuse_existing
            from daq.export import output_paths

            refuse_existing(output_paths(out, args.to, ["fits", "points"]), force=args.force, inputs=[args.source])
        paths = export_fit(_fit_json(args), args.to, out, source=str(args.source), force=args.force)
    else:
        paths = export_session(args.source, args.to, args.output, force=args.force)
    for p in paths:
        print(f"wrote {safe(p)}", file=sys.stderr)
    return 0


def sessions_command(args: argparse.Namespace) -> int:
    from contactrig.cli.session_index import index_command
    from daq.index import format_table, index_sessions

    done = index_command(args)  # a folder: through its run index (DIR/.contactrig-index.sqlite)
    if done is not None:
        return done

    entries = index_sessions(args.folder, sample=args.sample, sort=args.sort, include_other=args.all)
    if args.json:
        print(json.dumps([e.as_dict() for e in entries], indent=2))  # JSON escapes control characters itself
    else:
        print(format_table(entries, base=args.folder if Path(args.folder).is_dir() else None))
        if not entries:
            print("(no session files)", file=sys.stderr)
    return 0
