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
            "(stored 0600, one file per port). Loopback only unless --host says otherwise (then a warning; the Host "
            "check stays, with the names of --allowed-host); every request needs the token. Sessions run through "
            "the same acquisition code as `contactrig acquire`. SIGINT/SIGTERM (Ctrl-C) stops every running session "
            "after its block, a second one stops them now; the console exits when they have ended (exit 1 when a "
            "session was stopped early, else 0). Needs the extra: pip install 'contactrig[console]'."
        ),
    )
    p.add_argument("folder", nargs="?", default=".", metavar="DIR", help="folder of sessions (default: .)")
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1, loopback)")
    p.add_argument("--port", type=int, default=8765, metavar="N", help="port (default 8765; 0: a free one)")
    p.add_argument(
        "--allowed-host", action="append", default=[], metavar="NAME",
        help="a name or address browsers use to reach the console off loopback (the Host header it answers to; "
        "repeat for several)",
    )  # fmt: skip
    p.add_argument("--no-browser", action="store_true", help="do not open a browser")
    p.set_defaults(handler=console_command)


def console_command(args: argparse.Namespace) -> int:
    root = Path(args.folder)
    if not root.is_dir():
        raise ValueError(f"DIR = {args.folder!r}: expected an existing folder")
    if not 0 <= args.port <= 65535:
        raise ValueError(f"--port = {args.port}: expected 0 … 65535")
    from contactrig.console.security import check_host_name

    allowed = [check_host_name(name) for name in args.allowed_host]
    try:
        from contactrig.console.server import serve
    except ImportError as exc:
        need = f"the console needs its extra ({exc.name} is missing): pip install 'contactrig[console]'"
        raise RuntimeError(need) from None

    def opened(url: str) -> None:
        if not args.no_browser:
            import webbrowser

            webbrowser.open(url)

    return serve(root, args.host, args.port, allowed_hosts=allowed, ready=opened, out=sys.stderr)
