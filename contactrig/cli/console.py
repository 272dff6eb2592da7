"""``contactrig console``: the bench session in a browser (a thin layer over :mod:`contactrig.console`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``console``."""
    p = subparsers.add_parser(
        "console",
        help="a local web console over a folder of sessions: index, new session, the running session, results",
        description=(
            "Serve a web console over DIR (default: the current folder) and print its URL with an access token "
            "(stored 0600). Loopback only unless --host says otherwise; every request needs the token. Sessions "
            "run through the same acquisition code as `contactrig acquire`. Needs the extra: pip install "
            "'contactrig[console]'."
        ),
    )
    p.add_argument("folder", nargs="?", default=".", metavar="DIR", help="folder of sessions (default: .)")
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1, loopback)")
    p.add_argument("--port", type=int, default=8765, metavar="N", help="port (default 8765; 0: a free one)")
    p.add_argument("--no-browser", action="store_true", help="do not open a browser")
    p.set_defaults(handler=console_command)


def console_command(args: argparse.Namespace) -> int:
    root = Path(args.folder)
    if not root.is_dir():
        raise ValueError(f"DIR = {args.folder!r}: expected an existing folder")
    if not 0 <= args.port <= 65535:
        raise ValueError(f"--port = {args.port}: expected 0 … 65535")
    try:
        from contactrig.console.server import serve
    except ImportError as exc:
        need = f"the console needs its extra ({exc.name} is missing): pip install 'contactrig[console]'"
        raise RuntimeError(need) from None

    def opened(url: str) -> None:
        if not args.no_browser:
            import webbrowser

            webbrowser.open(url)

    serve(root, args.host, args.port, ready=opened, out=sys.stderr)
    return 0
