"""``contactrig scene init|show``: start a scene from the documented default, and see the scene a file was made with.

``contactrig scene init [PATH] [--force]`` writes the packaged default scene (every key with its unit, range and
meaning in a comment) to PATH (default ``scene.toml``); an existing file is kept unless ``--force``.
``contactrig scene show FILE`` prints the scene text recorded in a session, sweep or contact-database file (or checks
and prints a scene ``.toml``), so a result can always be traced to the exact settings that made it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``scene init`` and ``scene show``."""
    p = subparsers.add_parser(
        "scene",
        help="write the documented default scene, or show the scene a file was made with",
        description="Scene files: start one from the documented default (init), or print the scene recorded in a "
        "session, sweep or database file (show).",
    )
    sub = p.add_subparsers(dest="scene_command", metavar="ACTION", parser_class=type(p))
    init = sub.add_parser("init", help="write the default scene, a comment per key (unit, range, meaning)")
    init.add_argument("path", nargs="?", default="scene.toml", help="file to write (default: scene.toml)")
    init.add_argument("--force", action="store_true", help="replace an existing file")
    init.set_defaults(handler=run_init)
    show = sub.add_parser("show", help="print the scene recorded in a session, sweep or database file")
    show.add_argument("file", help="a session (.h5 from acquire/import), sweep (simulate -o), database or .toml file")
    show.set_defaults(handler=run_show)
    p.set_defaults(handler=lambda args: _usage(p))


def _usage(parser: argparse.ArgumentParser) -> int:
    parser.print_help(sys.stderr)
    return 2


def run_init(args: argparse.Namespace) -> int:
    """Write the packaged default scene to ``args.path`` (atomically; refused when it exists, unless --force)."""
    from contactrig.core.files import write_text_atomic
    from contactrig.core.scene import default_scene_text

    path = write_text_atomic(args.path, default_scene_text(), force=args.force)
    print(f"wrote {path}: the default scene; edit it and pass it to any command (e.g. contactrig simulate {path})")
    return 0


def recorded_scene_text(path: str | Path) -> tuple[str, str]:
    """(kind, scene text) of the file at ``path``: a scene ``.toml`` (parsed, to report errors), or the scene
    recorded in a session, sweep or contact-database file. A file with no recorded scene is a ValueError."""
    kind, text, _ = recorded_scene(path)
    return kind, text


def recorded_scene(path: str | Path) -> tuple[str, str, list]:
    """(kind, scene text, the run start records of a session — [] for other files) of the file at ``path``."""
    from contactrig.core.scene import load_scene
    from daq.bounded import check_regular_file

    p = Path(path)
    check_regular_file(p, "file")  # a FIFO or device is refused before it is opened (it would block)
    with p.open("rb") as f:
        is_hdf5 = f.read(8) == b"\x89HDF\r\n\x1a\n"
    if not is_hdf5:
        return "scene file", load_scene(p).text, []
    kind, text, runs = _recorded(p)
    if not text.strip():
        raise ValueError(f"{p}: this {kind} records no scene text")
    return kind, text, runs


def _format_of(p: Path) -> str:
    """The format attribute of an HDF5 file; a session being written is opened without locking (the lock-free
    reader of :mod:`daq.session_reader`)."""
    from daq.session_reader import open_for_reading

    f, _ = open_for_reading(p)
    with f:
        return str(f.attrs.get("format", f.attrs.get("contactrig_format", "")))[:80]


def _recorded(p: Path) -> tuple[str, str, list]:
    from daq.bounded import call_bounded

    fmt = call_bounded(_format_of, (p,), path=p, what="HDF5 file")  # untrusted: a child process with a deadline
    if fmt == "contactrig-contact-database":
        from daq.database_file import load_database

        return "contact database", str(load_database(p).provenance.get("scene_text", "")), []
    if fmt == "contactrig-sweep":
        from daq.sweep_file import load_sweep

        return "rig sweep", str(load_sweep(p).provenance.get("scene_text", "")), []
    import warnings

    from daq import load_session

    with warnings.catch_warnings():  # running, incomplete, aborted: the scene is shown all the same
        warnings.simplefilter("ignore")
        session = load_session(p)
    return "session", session.scene_text, list(session.runs)


def run_show(args: argparse.Namespace) -> int:
    """Print the scene of ``args.file`` (control characters shown escaped: the text is data from a file); for a
    session, then the overrides of each run and the effective values (:func:`daq.overrides.describe_runs`)."""
    from contactrig.core.text import escape_terminal
    from daq.overrides import describe_runs

    kind, text, runs = recorded_scene(args.file)
    print(f"# scene of {escape_terminal(str(args.file))} ({kind})")
    print(escape_terminal(text, keep_newlines=True))
    for line in describe_runs(runs):
        print(escape_terminal(line))
    return 0
