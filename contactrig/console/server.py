"""Serving the console: bind (loopback by default), make and store the token, print the URL once, serve, and stop
as a terminal stops.

Signals: the HTTP server runs in a thread; the main thread keeps SIGINT and SIGTERM. The first stops every running
session as the terminal's first Ctrl-C does (after its block: source idle, stop record written) and starts no new
one; the second stops them now (the second Ctrl-C); once every session has ended the event streams are closed, the
server goes down, and what was stopped is printed. A session's child also watches the console (its stdin): killed
outright, the console still leaves no acquisition running on its own (:mod:`contactrig.console.child`).
"""

from __future__ import annotations

import os
import signal
import socket
import sys
import threading
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, TextIO

from contactrig.console.app import Console, build_app
from contactrig.console.runner import SessionRun
from contactrig.console.security import new_token, remove_token, store_token

__all__ = ["ALL_INTERFACES", "LOOPBACK", "bind", "default_token_folder", "make_console", "serve"]

LOOPBACK = ("127.0.0.1", "localhost", "::1")
ALL_INTERFACES = ("0.0.0.0", "::", "")
#: seconds the server is given to finish open requests once every session has ended
GRACEFUL_S = 2


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


def _host_names(host: str, allowed: Iterable[str]) -> set[str]:
    host = host.lower()
    names = {name.lower() for name in allowed}
    if host in LOOPBACK:
        names |= {host, "127.0.0.1", "localhost"}
    elif host in ALL_INTERFACES:  # loopback reaches it too
        names |= {"127.0.0.1", "localhost"} | ({"::1"} if host == "::" else set())
    else:
        names.add(host)
    return names


def make_console(root: Path, host: str, port: int, token: str | None = None, allowed: Iterable[str] = ()) -> Console:
    """The console's state for a server on ``host``:``port``. The Host headers it answers to: that address (on
    loopback also ``127.0.0.1``/``localhost``; bound to every interface, loopback's names) and the names in
    ``allowed`` (``--allowed-host``, checked by :func:`~contactrig.console.security.check_host_name`), each with the
    port — the check is never switched off. The token's cookie is named after the port."""
    hosts = set()
    for h in _host_names(host, allowed):
        shown = f"[{h}]" if ":" in h else h
        hosts.add(f"{shown}:{port}")
        if port == 80:  # a browser leaves the default port out of Host
            hosts.add(shown)
    return Console(root=root.resolve(), token=token or new_token(), allowed_hosts=frozenset(hosts),
                   cookie=f"contactrig_console_{port}")  # fmt: skip


class _Signals:
    """SIGINT/SIGTERM counted (the handler only counts: the main thread's loop acts on them)."""

    def __init__(self) -> None:
        self.names: list[str] = []

    def __call__(self, signum: int, frame: Any) -> None:
        self.names.append(signal.Signals(signum).name)


def serve(
    root: Path,
    host: str = "127.0.0.1",
    port: int = 0,
    *,
    allowed_hosts: Iterable[str] = (),
    token_folder: Path | None = None,
    out: TextIO | None = None,
    ready: Callable[[str], None] | None = None,
) -> int:
    """Serve the console over ``root`` until SIGINT/SIGTERM; the URL (with the token) is printed once to ``out``
    and passed to ``ready``. Off loopback a warning says the bench is reachable from the network. On the way out,
    every running session is stopped as the terminal's Ctrl-C stops it (see the module) and waited for. Returns the
    exit code: 0, or 1 when a session was stopped before its plan was done (its file can be resumed)."""
    import uvicorn

    sock = bind(host, port)
    port = sock.getsockname()[1]
    console = make_console(root, host, port, allowed=allowed_hosts)
    console.catalog.kick()  # the index refreshed from the start, in the background: the first page finds it ready
    console.queue.begin()  # a queue left by the last console goes on
    stored = store_token(console.token, token_folder or default_token_folder(), port)
    where = "127.0.0.1" if host in ALL_INTERFACES else host
    shown = f"[{where}]" if ":" in where else where
    url = f"http://{shown}:{port}/?token={console.token}"
    stream = out if out is not None else sys.stderr
    print(f"contactrig console on {console.root}: {url}\n(token stored in {stored}, mode 0600)", file=stream,
          flush=True)  # fmt: skip
    if host not in LOOPBACK:
        names = ", ".join(sorted(console.allowed_hosts))
        print(f"WARNING: --host {host}: the console, and the current source it drives, is reachable from the network "
              f"(anyone holding the token can run the bench). It answers to Host: {names} (add names with "
              "--allowed-host).", file=stream, flush=True)  # fmt: skip
    if ready is not None:
        ready(url)
    config = uvicorn.Config(build_app(console), log_level="warning", access_log=False, lifespan="off",
                            timeout_graceful_shutdown=GRACEFUL_S)  # fmt: skip
    server = uvicorn.Server(config)
    http = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, name="console-http", daemon=True)
    signals = _Signals()
    main = threading.current_thread() is threading.main_thread()
    previous = {sig: signal.signal(sig, signals) for sig in (signal.SIGINT, signal.SIGTERM)} if main else {}
    stopped: list[SessionRun] = []
    try:
        http.start()
        stopped = _supervise(console, http, signals, stream)
    finally:
        console.close()  # normally nothing is left running here; after an error: stop after the block, wait
        server.should_exit = True
        http.join(timeout=GRACEFUL_S + 3)
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        sock.close()
        remove_token(stored, console.token)
    for run in stopped:
        print(f"contactrig console: stopped {_outcome(run)}", file=stream, flush=True)
    early = [r for r in stopped if (r.state.stop or {}).get("status") != "success"]
    return 1 if early else 0


def _supervise(console: Console, http: threading.Thread, signals: _Signals, out: TextIO) -> list[SessionRun]:
    """The main thread's loop: act on each signal; return (the sessions stopped) once the console is closing and no
    session runs any more."""
    handled = 0
    stopped: list[SessionRun] = []
    while True:
        while len(signals.names) > handled:
            name = signals.names[handled]
            handled += 1
            if handled == 1:
                stopped = console.stop_runs()
                files = ", ".join(r.state.file for r in stopped)
                what = (f"stopping {len(stopped)} running session(s) after the current block: {files} ({name} "
                        "again: stop now)" if stopped else "no session running; the console exits")  # fmt: skip
                print(f"contactrig console: {name}: {what}", file=out, flush=True)
            else:
                running = console.stop_runs(now=True)
                if running:
                    files = ", ".join(r.state.file for r in running)
                    print(f"contactrig console: {name} again: stopping now (the block under way is discarded): "
                          f"{files}", file=out, flush=True)  # fmt: skip
        if not http.is_alive() and not console.closing.is_set():
            stopped = console.stop_runs()
            print("contactrig console: the web server ended; running sessions stop after their block", file=out,
                  flush=True)  # fmt: skip
        if console.closing.is_set() and not console.running():
            return stopped
        http.join(0.05)


def _outcome(run: SessionRun) -> str:
    """``FILE: STATUS, k of n blocks on file — REASON``, or the error the run ended with."""
    s = run.state
    if s.stop is not None:
        return (f"{s.file}: {s.stop.get('status')}, {s.stop.get('blocks_done')} of {s.stop.get('blocks_planned')} "
                f"blocks on file — {s.stop.get('reason')}")  # fmt: skip
    return f"{s.file}: {(s.end or {}).get('error') or 'ended'}"
