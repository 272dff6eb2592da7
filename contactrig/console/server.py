"""Serving the console: bind (loopback by default), make and store the token, print the URL once, serve."""

from __future__ import annotations

import os
import socket
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TextIO

from contactrig.console.app import Console, build_app
from contactrig.console.security import new_token, store_token

__all__ = ["LOOPBACK", "bind", "default_token_folder", "make_console", "serve"]

LOOPBACK = ("127.0.0.1", "localhost", "::1")


def default_token_folder() -> Path:
    """Where the token is stored (0600): ``$XDG_RUNTIME_DIR/contactrig`` or ``~/.local/state/contactrig``."""
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    base = Path(runtime) if runtime else Path.home() / ".local" / "state"
    return base / "contactrig"


def bind(host: str, port: int) -> socket.socket:
    """A listening socket on ``host``:``port`` (0: a free port)."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind((host, port))
    sock.listen(64)
    sock.set_inheritable(False)
    return sock


def make_console(root: Path, host: str, port: int, token: str | None = None) -> Console:
    """The console's state for a server on ``host``:``port``: the Host headers it answers to are that address and,
    on loopback, ``127.0.0.1``/``localhost`` (bound to every interface, any: the token and the Origin check guard)."""
    names = {host, "127.0.0.1", "localhost"} if host in LOOPBACK else {host}
    hosts = frozenset(f"[{h}]:{port}" if ":" in h else f"{h}:{port}" for h in names)
    any_host = host in ("0.0.0.0", "::", "")  # every interface: any name may reach it; the token still guards
    return Console(root=root.resolve(), token=token or new_token(), allowed_hosts=hosts, any_host=any_host)


def serve(
    root: Path,
    host: str = "127.0.0.1",
    port: int = 0,
    *,
    token_folder: Path | None = None,
    out: TextIO | None = None,
    ready: Callable[[str], None] | None = None,
) -> None:
    """Serve the console over ``root`` until interrupted; the URL (with the token) is printed once to ``out``
    and passed to ``ready``. On the way out, a running session is stopped as one Ctrl-C stops it (after its
    block) and waited for."""
    import uvicorn

    sock = bind(host, port)
    port = sock.getsockname()[1]
    console = make_console(root, host, port)
    stored = store_token(console.token, token_folder or default_token_folder())
    shown = f"[{host}]" if ":" in host else host
    url = f"http://{shown}:{port}/?token={console.token}"
    stream = out if out is not None else sys.stderr
    print(f"contactrig console on {console.root}: {url}\n(token stored in {stored}, mode 0600)", file=stream,
          flush=True)  # fmt: skip
    if ready is not None:
        ready(url)
    config = uvicorn.Config(build_app(console), log_level="warning", access_log=False, lifespan="off")
    server = uvicorn.Server(config)
    try:
        server.run(sockets=[sock])
    finally:
        console.close()
        sock.close()
