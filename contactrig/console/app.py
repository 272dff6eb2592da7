"""The console's web application (Starlette): pages, the JSON API, server-sent events, and the guards.

Every request passes :class:`Guard` first (token, Host, Origin on state changes, security headers). The pages are one
static HTML shell with its script and stylesheet served from this package (no CDN, no inline script; the page
builds its DOM with ``textContent``, so a string from a file is never markup). Sessions are listed, searched, marked
and compared through :class:`~contactrig.console.catalog.Catalog` (:mod:`daq.run_index`, the one index, as
``contactrig sessions --where``, refreshed in the background); a session is acquired by
:class:`~contactrig.console.runner.SessionRun` (``daq.acquire.acquire`` in a child process); fit, report and export
run the ``contactrig`` commands themselves, so the page shows what the terminal prints.
"""

from __future__ import annotations

import asyncio
import json
import re
import secrets
import subprocess
import sys
import threading
import time
import warnings
from collections.abc import AsyncIterator, Awaitable, Callable, MutableMapping
from dataclasses import dataclass, field
from http.cookies import SimpleCookie
from importlib import resources
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs

from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import (
    FileResponse,
    JSONResponse,
    PlainTextResponse,
    RedirectResponse,
    Response,
    StreamingResponse,
)
from starlette.routing import Route

from contactrig.console.bench_queue import BenchQueue, QueueError
from contactrig.console.catalog import Catalog
from contactrig.console.runner import RunState, SessionRun
from contactrig.console.security import check_token, resolve_under, same_origin

__all__ = ["Console", "build_app"]

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

COOKIE = "contactrig_console"
#: the pages' policy: scripts, styles, images and connections only from the console itself; nothing inline
PAGE_CSP = (
    "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; connect-src 'self'; "
    "base-uri 'none'; form-action 'self'; frame-ancestors 'none'"
)
#: files from DIR (report.html, figures, exports): a sandbox without scripts; the report's own styles and images
FILE_CSP = "sandbox; default-src 'none'; img-src 'self' data:; style-src 'unsafe-inline'; frame-ancestors 'self'"
SAFE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,120}\.(h5|hdf5|nxs)$")
STATIC = {"app.js": "text/javascript", "style.css": "text/css", "index.html": "text/html", "plot.js": "text/javascript",
          "uPlot.iife.min.js": "text/javascript", "uPlot.min.css": "text/css"}  # fmt: skip
SUBPROCESS_TIMEOUT_S = 600
#: past sessions overlaid at most (the latest)
MAX_OVERLAID = 10
#: seconds between the two SIGINTs of "stop now" (POSIX does not queue a second pending SIGINT)
STOP_GAP_S = 0.2


@dataclass
class Console:
    """The console's state: its folder, token, the hosts it answers to, its runs and the index cache."""

    root: Path
    token: str
    #: the Host headers answered (``name:port``): the listening address, loopback names, ``--allowed-host`` names
    allowed_hosts: frozenset[str]
    #: the token's cookie: one per port, so two consoles on one machine do not overwrite each other's
    cookie: str = COOKIE
    runs: dict[str, SessionRun] = field(default_factory=dict)
    #: the run index of ``root`` with its background refresh
    catalog: Catalog = field(init=False)
    #: the bench's queue of planned sessions (its file in ``root``)
    queue: BenchQueue = field(init=False)
    lock: threading.Lock = field(default_factory=threading.Lock)
    #: set by the first SIGINT/SIGTERM: running sessions stop after their block, no new one starts
    closing: threading.Event = field(default_factory=threading.Event)
    #: set when every session has ended and the server goes down: event streams end
    closed: threading.Event = field(default_factory=threading.Event)

    def __post_init__(self) -> None:
        self.catalog = Catalog(self.root, self.closed)
        self.queue = BenchQueue(self.root, start=lambda form: _start(self, form).state.id,
                                busy=lambda at: self.running_on(at) is not None, closing=self.closing)  # fmt: skip
        self.queue.load()

    def running_on(self, address: str) -> SessionRun | None:
        return next((r for r in self.runs.values() if r.running and r.state.address == address), None)

    def running(self) -> list[SessionRun]:
        """The runs whose acquisition has not ended."""
        return [r for r in list(self.runs.values()) if r.running]

    def stop_runs(self, now: bool = False) -> list[SessionRun]:
        """Stop every running session as the terminal's Ctrl-C does: after its block, or (``now``) at once; no new
        session starts from here on. Returns the runs asked to stop."""
        with self.lock:
            self.closing.set()
            asked = self.running()
        for run in asked:
            if run.state.stop_requests < (2 if now else 1):
                run.request_stop()
        return asked

    def close(self) -> None:
        """Stop every running session after its block, wait for each to end, close their pipes."""
        self.closing.set()
        for run in list(self.runs.values()):
            run.close()
        self.closed.set()


class Guard:
    """ASGI middleware: 403 without the token (cookie, ``X-Contactrig-Token`` header or ``?token=`` — the last
    sets the cookie and redirects to the bare URL), 403 for a Host the console does not answer to (DNS rebinding),
    403 for a state-changing request from another origin; security headers on every response."""

    def __init__(self, app: ASGIApp, console: Console) -> None:
        self.app, self.console = app, console

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope["headers"]}
        query = parse_qs(scope.get("query_string", b"").decode("latin-1"))
        host = headers.get("host", "").lower() or None  # host names are case-insensitive (browsers send lower case)
        if host is None or host not in self.console.allowed_hosts:
            await _deny("unknown Host (a name the console answers to is added with --allowed-host)", scope, receive,
                        send)  # fmt: skip
            return
        from_query = (query.get("token") or [None])[0]
        cookie = SimpleCookie()
        try:
            cookie.load(headers.get("cookie", ""))
        except Exception:
            cookie = SimpleCookie()
        name = self.console.cookie
        given = headers.get("x-contactrig-token") or (cookie[name].value if name in cookie else None)
        if not check_token(given, self.console.token):
            if scope["method"] == "GET" and check_token(from_query, self.console.token):
                await _set_cookie_and_redirect(name, self.console.token, scope, receive, send)
                return
            await _deny("token missing or wrong", scope, receive, send)
            return
        hosts = self.console.allowed_hosts
        if scope["method"] not in ("GET", "HEAD") and not same_origin(headers.get("origin"), host, hosts):
            await _deny("cross-origin request refused", scope, receive, send)
            return
        await self.app(scope, receive, _with_headers(send, scope["path"]))


def _with_headers(send: Send, path: str) -> Send:
    csp = FILE_CSP if path.startswith("/files/") else PAGE_CSP

    async def wrapped(message: Message) -> None:
        if message["type"] == "http.response.start":
            extra = [
                (b"content-security-policy", csp.encode()),
                (b"x-content-type-options", b"nosniff"),
                (b"referrer-policy", b"no-referrer"),
                (b"cache-control", b"no-store"),
            ]
            if not path.startswith("/files/"):
                extra.append((b"x-frame-options", b"DENY"))
            message["headers"] = [*message.get("headers", []), *extra]
        await send(message)

    return wrapped


async def _deny(why: str, scope: Scope, receive: Receive, send: Send) -> None:
    headers = {"content-security-policy": PAGE_CSP}
    response = PlainTextResponse(f"403 forbidden: {why}", status_code=403, headers=headers)
    await response(scope, receive, send)


async def _set_cookie_and_redirect(name: str, token: str, scope: Scope, receive: Receive, send: Send) -> None:
    response = RedirectResponse(scope["path"] if scope["path"] == "/" else "/", status_code=303)
    response.set_cookie(name, token, httponly=True, samesite="strict", path="/")
    await response(scope, receive, send)


# -- pages and static files ---------------------------------------------------------------------------------------


def _static(name: str) -> Response:
    data = resources.files("contactrig.console").joinpath("static", name).read_bytes()
    return Response(data, media_type=STATIC[name])


async def page(request: Request) -> Response:
    return _static("index.html")


async def static(request: Request) -> Response:
    name = request.path_params["name"]
    if name not in STATIC:
        return PlainTextResponse("not found", status_code=404)
    return _static(name)


async def files(request: Request) -> Response:
    """A file under DIR (report, figure, export), sandboxed; anything else 404."""
    console: Console = request.app.state.console
    path = resolve_under(console.root, request.path_params["path"])
    if path is None:
        return PlainTextResponse("not found", status_code=404)
    kinds = {".html": "text/html", ".png": "image/png", ".svg": "image/svg+xml", ".csv": "text/csv",
             ".md": "text/plain", ".json": "application/json"}  # fmt: skip
    media = kinds.get(path.suffix.lower(), "application/octet-stream")
    download = media == "application/octet-stream" or path.suffix.lower() == ".csv"
    return FileResponse(path, media_type=media, filename=path.name if download else None)


# -- the sessions index -------------------------------------------------------------------------------------------


def _relative(console: Console, path: str) -> str:
    try:
        return Path(path).relative_to(console.root).as_posix()
    except ValueError:
        return path


class IndexJSON(JSONResponse):
    """JSON of what files and sidecars hold: ASCII with escapes, so that text an older contactrig stored with lone
    surrogates (kept by the index as the file holds it) is still sent; a non-finite number is null (JSON has none)."""

    def render(self, content: Any) -> bytes:
        from contactrig.core.provenance import json_finite

        return json.dumps(json_finite(content), ensure_ascii=True, allow_nan=False, separators=(",", ":")).encode()


async def sessions(request: Request) -> Response:
    """One page of the run index (:meth:`Catalog.rows`: the index as it is, never a scan), the newest first;
    ``where`` (repeated) are ``contactrig sessions --where`` texts, ``sort`` a ``--sort`` key, ``order=asc`` the
    oldest first, ``offset`` the rows skipped (a later page); ``matched`` counts the sessions that match. A refresh
    is started in the background (``kick=0``: not); ``indexing`` and ``generation`` let the page poll until it has
    ended and draw again."""
    from contactrig.console.catalog import PAGE_ROWS
    from daq.index import SORT_KEYS

    console: Console = request.app.state.console
    catalog = console.catalog
    sort = request.query_params.get("sort", "start")
    sort = sort if sort in SORT_KEYS else "start"
    where = [w for w in request.query_params.getlist("where") if w.strip()]
    if request.query_params.get("kick") != "0":
        catalog.kick()
    generation, indexing = catalog.state()  # before the rows: the rows are at least as new as these say
    offset = request.query_params.get("offset", "0")
    if not offset.isascii() or not offset.isdigit() or len(offset) > 15:
        return JSONResponse({"error": f"offset {offset!r}: a whole number of rows, 0 or more"}, status_code=400)
    try:
        rows, matched = await asyncio.to_thread(catalog.rows, where, sort, offset=int(offset),
                                                descending=request.query_params.get("order") != "asc")  # fmt: skip
    except (ValueError, OSError) as exc:
        return JSONResponse({"error": _one_line(exc)}, status_code=400)
    more = int(offset) + len(rows) < matched
    return IndexJSON({"sessions": rows, "more": more, "matched": matched, "offset": int(offset), "page": PAGE_ROWS,
                      "indexing": indexing, "generation": generation, "notes": catalog.notes})  # fmt: skip


async def add_mark(request: Request) -> Response:
    """A tag or remark on a session: ``{"path", "kind": "tag"|"remark", "text", "who"}``
    (:func:`daq.run_index.add_mark`: one line appended to the folder's sidecar, the session never touched)."""
    console: Console = request.app.state.console
    body = await _json_body(request)
    try:
        path = _session_file(console, body.get("path"))
        kind, text, who = (body.get(k) for k in ("kind", "text", "who"))
        if not all(isinstance(v, str) for v in (kind, text, who)):
            raise BadRequest("kind, text and who: expected text (kind tag or remark)")
        mark = await asyncio.to_thread(console.catalog.add_mark, path, str(kind), str(text), str(who))
    except (ValueError, OSError) as exc:
        return JSONResponse({"error": _one_line(exc)}, status_code=400)
    return JSONResponse({"mark": {k: mark[k] for k in ("kind", "text", "who", "at")}})


async def diff(request: Request) -> Response:
    """Why two sessions differ (:func:`daq.session_diff.session_diff`): ``a`` and ``b``, paths in the folder."""
    console: Console = request.app.state.console
    try:
        a, b = (_session_file(console, request.query_params.get(k)) for k in ("a", "b"))
        result = await asyncio.to_thread(console.catalog.diff, a, b)
    except (ValueError, OSError, RuntimeError) as exc:
        return JSONResponse({"error": _one_line(exc)}, status_code=400)
    return IndexJSON(result)


# -- a new session ------------------------------------------------------------------------------------------------


def _scene_choices(console: Console) -> list[dict[str, str]]:
    choices = [{"id": "", "label": "packaged default scene (what `contactrig scene init` writes)"}]
    for p in sorted(console.root.glob("*.toml")):
        if resolve_under(console.root, p.name) is not None:
            choices.append({"id": p.name, "label": p.name})
    return choices


async def scenes(request: Request) -> Response:
    return JSONResponse({"scenes": _scene_choices(request.app.state.console)})


async def overrides_form(request: Request) -> Response:
    """The per-run overrides the New-session form offers: the declared table :data:`daq.overrides.OVERRIDES`."""
    from contactrig.core.validation import scene_key
    from daq.overrides import OVERRIDES

    rows = [{"key": o.key, "option": o.option, "help": o.help, "sim_only": o.sim_only, "on_resume": o.on_resume,
             "scene_key": scene_key(o.key)} for o in OVERRIDES]  # fmt: skip
    return JSONResponse({"overrides": rows})


class BadRequest(ValueError):
    """A form value the console refuses (one line, shown in the page)."""


def _scene_path(console: Console, scene_id: object) -> Path | None:
    if scene_id in (None, ""):
        return None
    if not isinstance(scene_id, str) or resolve_under(console.root, scene_id) is None or "/" in scene_id:
        raise BadRequest(f"scene {scene_id!r}: not a scene file in the console's folder")
    return console.root / scene_id


def _speed(body: dict[str, Any]) -> float | None:
    value = body.get("sim_speed")
    if value in (None, ""):
        return None
    try:
        speed = float(value)
    except (TypeError, ValueError):
        raise BadRequest(f"sim_speed {value!r}: expected a number > 0 (1 = real pace) or inf") from None
    if not speed > 0:
        raise BadRequest(f"sim_speed {value!r}: expected a number > 0 (1 = real pace) or inf")
    return speed


def _plan(console: Console, body: dict[str, Any]) -> tuple[Any, list[str]]:
    """The scene's plan and the lines ``acquire`` prints for it (weights, repeats, estimated duration)."""
    from analysis.simulated_session import DEFAULT_SIM_SPEED
    from contactrig.core.scene import load_scene
    from daq.acquire import plan_lines
    from daq.overrides import check_bench, plan_with_overrides
    from daq.plan import session_steps

    scene = load_scene(_scene_path(console, body.get("scene")))
    overrides = _overrides(body)
    check_bench(overrides, simulated=bool(body.get("sim")))
    plan = plan_with_overrides(scene, overrides)
    speed = _speed(body) or DEFAULT_SIM_SPEED
    time_scale = (0.0 if speed == float("inf") else 1.0 / speed) if body.get("sim") else 1.0
    steps = list(session_steps(plan))
    return plan, plan_lines(plan, steps, attended=True, time_scale=time_scale)


async def plan_preview(request: Request) -> Response:
    console: Console = request.app.state.console
    body = await _json_body(request)
    try:
        plan, lines = await asyncio.to_thread(_plan, console, body)
    except (ValueError, OSError) as exc:
        return JSONResponse({"error": _one_line(exc)}, status_code=400)
    return JSONResponse({"lines": lines, "address": plan.instrument.address, "blocks_planned": plan.blocks_planned})


async def _json_body(request: Request) -> dict[str, Any]:
    try:
        body = await request.json()
    except (json.JSONDecodeError, UnicodeDecodeError):
        return {}
    return body if isinstance(body, dict) else {}


def _one_line(exc: BaseException) -> str:
    from contactrig.core.text import bound_error_line

    return bound_error_line(str(exc).splitlines()[0] if str(exc) else type(exc).__name__)


def _start(console: Console, body: dict[str, Any]) -> SessionRun:
    """Check the form and start the acquisition child (refused: a session already running on the address)."""
    resume = bool(body.get("resume"))
    output = body.get("output")
    if resume:
        if not isinstance(output, str) or resolve_under(console.root, output) is None:
            raise BadRequest(f"resume {output!r}: not a session file in the console's folder")
        scene_path = None
        address, blocks_planned, before, weights, sample, recorded_speed = _recorded(console.root / output)
    else:
        if not isinstance(output, str) or not SAFE_NAME.match(output):
            raise BadRequest(
                f"file name {output!r}: expected a plain name ending in .h5 (letters, digits, '.', '_', '-')"
            )
        if (console.root / output).exists() or (console.root / output).is_symlink():
            raise BadRequest(f"{output} exists: choose another name, or resume it from the sessions page")
        scene_path = _scene_path(console, body.get("scene"))
        plan, _ = _plan(console, body)
        blocks_planned, address = plan.blocks_planned, plan.instrument.address
        before, weights, sample = 0, len(plan.session.weights_kg), plan.session.sample
        recorded_speed = None
    overrides = _overrides(body)
    if resume:
        from daq.overrides import check_bench

        check_bench(overrides, simulated=bool(body.get("sim")))
        address = str(overrides.get("instrument.address", address))
        sample = str(overrides.get("session.sample", sample))
    speed = _speed(body) or recorded_speed  # a resumed simulated session keeps its speed unless the form sets one
    budget = _budget(body, resume=resume)
    prior = _noise_from(console, body, adaptive=budget is not None)
    request = {"scene": None if scene_path is None else str(scene_path), "output": str(console.root / output),
               "sim": bool(body.get("sim")), "sim_speed": speed, "resume": resume, "overrides": overrides,
               "allow_change": bool(body.get("allow_change"))}  # fmt: skip
    if budget is not None:  # as `acquire --adaptive --budget-min N`: the child runs analysis.adaptive_session
        request["adaptive"] = {"budget_min": budget, **({"noise_from": prior} if prior is not None else {})}
    client = str(body.get("client") or "")[:64]
    with console.lock:
        if console.closing.is_set():
            raise BadRequest("the console is shutting down: no new session starts")
        busy = console.running_on(address)
        if busy is not None:
            raise BadRequest(f"a session is running on {address} already ({busy.state.file}): one at a time per bench")
        state = RunState(id=secrets.token_hex(8), file=output, address=address, controller=client,
                         sim=bool(body.get("sim")), resume=resume, blocks_planned=blocks_planned,
                         blocks_before=before, weights_left=weights, sample=sample, budget_min=budget)  # fmt: skip
        run = SessionRun(state, request, cwd=str(console.root))
        console.runs[state.id] = run
    return run


def _budget(body: dict[str, Any], *, resume: bool) -> float | None:
    """The form's ``adaptive`` (a checkbox) and ``budget_min`` (empty: the default, 60 min), checked as ``acquire
    --adaptive --budget-min`` checks them; None for a fixed plan."""
    from analysis.adaptive_session import DEFAULT_BUDGET_MIN
    from contactrig.core.validation import check_range

    given = body.get("budget_min")
    if not body.get("adaptive"):
        if given not in (None, ""):
            raise BadRequest("budget_min only applies to an adaptive session (tick adaptive)")
        return None
    if resume:
        raise BadRequest("adaptive: an adaptive session is not resumed: start a new one")
    if given in (None, ""):
        return DEFAULT_BUDGET_MIN
    try:
        budget = float(given)
    except (TypeError, ValueError):
        raise BadRequest(f"budget_min {given!r}: expected minutes of bench time, a number > 0") from None
    try:
        check_range("--budget-min", budget, 0.0, 24 * 60.0, lo_open=True, unit="min")
    except ValueError as exc:
        raise BadRequest(f"budget_min: {exc}") from None
    return budget


def _overrides(body: dict[str, Any]) -> dict[str, Any]:
    """The form's per-run overrides of the scene, ``{scene key: text}`` → ``{scene key: value}``, parsed by their
    declarations (:data:`daq.overrides.OVERRIDES`, as ``acquire --address/--sample/…``); empty fields are left out."""
    from daq.overrides import OVERRIDES

    given = body.get("overrides") or {}
    if not isinstance(given, dict):
        raise BadRequest("overrides: expected an object {scene key: text}")
    known = {o.key: o for o in OVERRIDES}
    for key in given:
        if key not in known:
            raise BadRequest(f"overrides: {str(key)[:60]!r} is not one of {', '.join(known)}")
    out = {}
    for key, text in given.items():
        if text in (None, ""):
            continue
        if not isinstance(text, str) or len(text) > 100_000:
            raise BadRequest(f"{known[key].option}: expected text of at most 100000 characters")
        out[key] = known[key].parse(text)
    return out


def _recorded(path: Path) -> tuple[str, int, int, int, str, float | None]:
    """A session to resume: its bench address, blocks planned, blocks on file, weights not yet measured, sample, and
    the simulated bench's speed of its last run (None: not simulated)."""
    from daq.session_file import load_session

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the notes of an unfinished session: resuming is the point
            session = load_session(path, timeout=30)
    except Exception as exc:
        raise BadRequest(f"{path.name}: {exc}") from None
    start = session.start
    plan = start.get("plan") or {}
    planned = int(plan.get("blocks_planned") or 0)
    done = len(session.summary)
    weights = (plan.get("session") or {}).get("weights_kg") or []
    measured = set(session.summary["weight_kg"].tolist())
    address = str((start.get("instrument") or {}).get("address", ""))
    last = session.runs[-1] if session.runs and isinstance(session.runs[-1], dict) else start
    speed = (last.get("simulation") or {}).get("sim_speed") if last.get("sim") else None
    recorded = float(speed) if isinstance(speed, (int, float)) and speed > 0 else None
    return address, planned, done, len(set(weights) - measured), str(start.get("sample") or ""), recorded


async def start_run(request: Request) -> Response:
    body = await _json_body(request)
    try:
        run = await asyncio.to_thread(_start, request.app.state.console, body)
    except (ValueError, OSError) as exc:
        status = 409 if "running on" in str(exc) or "shutting down" in str(exc) else 400
        return JSONResponse({"error": _one_line(exc)}, status_code=status)
    return JSONResponse(run.snapshot())


# -- the bench's queue -------------------------------------------------------------------------------------------


def _noise_from(console: Console, body: dict[str, Any], *, adaptive: bool) -> str | None:
    """The form's ``noise_from`` (empty: none), as ``acquire --adaptive --noise-from SESSION.h5`` takes it: a session
    file in the console's folder whose noise is the design's prior, read now
    (:func:`analysis.adaptive_session.file_prior`); its path, or None."""
    given = body.get("noise_from")
    if given in (None, ""):
        return None
    if not adaptive:
        raise BadRequest("noise_from only applies to an adaptive session (tick adaptive)")
    path = resolve_under(console.root, given) if isinstance(given, str) else None
    if path is None:
        raise BadRequest(f"noise_from {given!r}: not a session file in the console's folder")
    from analysis.adaptive_session import file_prior

    try:
        file_prior(str(path))
    except ValueError as exc:
        raise BadRequest(f"noise_from: {exc}") from None
    return str(path)


def _queued(console: Console, body: dict[str, Any]) -> tuple[dict[str, Any], str]:
    """The New-session form of a planned session, checked as a start checks it (scene, overrides, file name), and
    its bench address."""
    output = body.get("output")
    if not isinstance(output, str) or not SAFE_NAME.match(output):
        raise BadRequest(f"file name {output!r}: expected a plain name ending in .h5 (letters, digits, '.', '_', '-')")
    if (console.root / output).exists() or (console.root / output).is_symlink():
        raise BadRequest(f"{output} exists: choose another name")
    plan, _ = _plan(console, body)
    client = str(body.get("client") or "")[:64]
    form = {"scene": body.get("scene") or "", "sim": bool(body.get("sim")), "sim_speed": body.get("sim_speed"),
            "overrides": body.get("overrides") or {}, "output": output, "client": client}  # fmt: skip
    if _budget(body, resume=False) is not None:  # an adaptive session keeps its budget (and prior) in the queue
        form.update(adaptive=True, budget_min=body.get("budget_min"))
        if _noise_from(console, body, adaptive=True) is not None:
            form.update(noise_from=body.get("noise_from"))
    elif body.get("noise_from") not in (None, ""):
        _noise_from(console, body, adaptive=False)  # refused: only with adaptive
    return form, plan.instrument.address


async def queue_state(request: Request) -> Response:
    return JSONResponse(request.app.state.console.queue.snapshot())


async def queue_add(request: Request) -> Response:
    """A planned session at the end of the queue: the New-session form, and ``wait`` (true: it starts at the
    operator's Start, else as soon as its bench is free)."""
    console: Console = request.app.state.console
    body = await _json_body(request)
    try:
        form, address = await asyncio.to_thread(_queued, console, body)
        item = console.queue.add(form, address, bool(body.get("wait")))
    except (ValueError, OSError) as exc:
        return JSONResponse({"error": _one_line(exc)}, status_code=409 if isinstance(exc, QueueError) else 400)
    return JSONResponse(item)


async def queue_action(request: Request) -> Response:
    """``move`` (``{"to": position}``), ``cancel`` or ``start`` (the operator's Start) one queued session."""
    queue: BenchQueue = request.app.state.console.queue
    body = await _json_body(request)
    item, action = request.path_params["item"], request.path_params["action"]
    try:
        if action == "move":
            to = body.get("to")
            if not isinstance(to, int) or isinstance(to, bool):
                raise QueueError(f"to {to!r}: expected a position (0 = first)")
            queue.move(item, to)
        elif action == "cancel":
            queue.cancel(item)
        elif action == "start":
            queue.go(item)
        else:
            return JSONResponse({"error": "no such action"}, status_code=404)
    except (ValueError, OSError) as exc:
        return JSONResponse({"error": _one_line(exc)}, status_code=409)
    return JSONResponse(queue.snapshot())


def _run(request: Request) -> SessionRun | None:
    return request.app.state.console.runs.get(request.path_params["run"])


async def runs(request: Request) -> Response:
    console: Console = request.app.state.console
    return JSONResponse({"runs": [_brief(r) for r in console.runs.values()]})


def _brief(run: SessionRun) -> dict[str, Any]:
    s = run.state
    blocks = s.blocks_before + len(s.blocks)
    return {"id": s.id, "file": s.file, "phase": s.phase, "address": s.address, "blocks": blocks,
            "blocks_planned": s.blocks_planned, "budget_min": s.budget_min}  # fmt: skip


async def run_state(request: Request) -> Response:
    run = _run(request)
    if run is None:
        return JSONResponse({"error": "no such run"}, status_code=404)
    return JSONResponse(run.snapshot())


async def answer(request: Request) -> Response:
    """The operator's answer to one question: ``{"prompt": id, "decision": "go"|"skip"|"quit"}`` to a weight,
    ``{"prompt": id, "measure": bool}`` on resume, ``{"prompt": id, "decision": "go"|"quit"}`` or ``{"prompt": id,
    "decision": "place", "weight_kg": w}`` to an adaptive session's suggestion. 409 (and nothing done) when that
    question is not the one asked now
    or was answered already: a late, duplicate or foreign answer never answers another question."""
    run = _run(request)
    body = await _json_body(request)
    if run is None:
        return JSONResponse({"error": "no such run"}, status_code=404)
    prompt = body.get("prompt")
    if not isinstance(prompt, str) or not prompt:
        return JSONResponse({"error": "prompt: expected the id of the question answered"}, status_code=400)
    if "decision" in body:
        if body["decision"] not in ("go", "skip", "quit", "place"):
            return JSONResponse({"error": "decision: expected go, skip, quit or (an adaptive session's) place"},
                                status_code=400)  # fmt: skip
        reply: dict[str, Any] = {"decision": body["decision"]}
        if body["decision"] == "place":  # another weight than the suggested one: which (checked against the question)
            reply["weight_kg"] = body.get("weight_kg")
    elif isinstance(body.get("measure"), bool):
        reply = {"measure": body["measure"]}
    else:
        return JSONResponse({"error": "expected decision (go, skip, quit) or measure (true, false)"}, status_code=400)
    refused = run.answer(prompt, reply)
    if refused is not None:
        return JSONResponse({"error": refused, "refused": True}, status_code=409)
    return JSONResponse({"ok": True})


async def stop(request: Request) -> Response:
    """Stop after this block (first request) or now (second): SIGINT to the acquisition, as Ctrl-C. A browser that
    did not start the run is asked to confirm (``confirm: true``)."""
    run = _run(request)
    body = await _json_body(request)
    if run is None:
        return JSONResponse({"error": "no such run"}, status_code=404)
    if str(body.get("client") or "") != run.state.controller and not body.get("confirm"):
        return JSONResponse({"confirm": "this session was started from another browser: stop it anyway?"},
                            status_code=409)  # fmt: skip
    want = 2 if body.get("now") else 1
    count = run.state.stop_requests
    while count < want and run.running:
        if count:  # two signals close together may arrive as one: give the first its time to be handled
            await asyncio.sleep(STOP_GAP_S)
        count = run.request_stop()
    return JSONResponse({"stop_requests": count})


async def pause(request: Request) -> Response:
    """The operator's Pause, ``{"reason": text, "who": name}``: the session finishes its block, leaves the source
    idle, records the pause (reason, who, UTC time) in its file and waits for Resume (:mod:`daq.pause`). 400 for a
    missing reason or name, 409 when there is nothing to pause."""
    return await _pause_or_resume(request, "pause")


async def resume(request: Request) -> Response:
    """The operator's Resume, ``{"who": name}``: the paused session goes on with its next block."""
    return await _pause_or_resume(request, "resume")


async def _pause_or_resume(request: Request, action: str) -> Response:
    run = _run(request)
    body = await _json_body(request)
    if run is None:
        return JSONResponse({"error": "no such run"}, status_code=404)
    for key in ("reason", "who") if action == "pause" else ("who",):
        if not isinstance(body.get(key), str) or not body[key].strip():
            return JSONResponse({"error": f"{key}: expected a non-empty text"}, status_code=400)
    refused = run.pause(body["reason"], body["who"]) if action == "pause" else run.resume(body["who"])
    if refused is not None:
        return JSONResponse({"error": refused}, status_code=409)
    return JSONResponse({"ok": True})


async def events(request: Request) -> Response:
    """Server-sent events: the run's state each time it changes (polled from memory; never touches the child), with
    ``console_closing`` while the console stops its sessions; the stream ends with the run, or when the console goes
    down (an ``event: closed`` first, so the page does not reconnect)."""
    console: Console = request.app.state.console
    run = _run(request)
    if run is None:
        return JSONResponse({"error": "no such run"}, status_code=404)

    async def stream() -> AsyncIterator[str]:
        version, closing = -1, False
        while True:
            if run.state.version != version or console.closing.is_set() != closing:
                snap = run.snapshot()
                version, closing = snap["version"], console.closing.is_set()
                snap["console_closing"] = closing
                yield f"data: {json.dumps(snap)}\n\n"
                if snap["phase"] == "ended":
                    return
            if console.closed.is_set():
                yield 'event: closed\ndata: {"console": "closed"}\n\n'
                return
            await asyncio.sleep(0.1)

    return StreamingResponse(stream(), media_type="text/event-stream")


# -- a finished session -------------------------------------------------------------------------------------------


def _session_file(console: Console, relative: object) -> Path:
    if not isinstance(relative, str) or resolve_under(console.root, relative) is None:
        raise BadRequest(f"session {relative!r}: not a session file in the console's folder")
    return console.root / relative


def _details(path: Path) -> dict[str, Any]:
    """A session file for its page (read lock-free, so a session another process is writing shows too): status,
    stop record, the runs (each with its start, command and notes), every block on file (:func:`view.summary_rows`:
    1-based numbers and the terminal's formatting), sample, operator, notes and what the reader said."""
    from contactrig.console.view import summary_rows
    from daq.session_file import load_session

    with warnings.catch_warnings(record=True) as notes:
        warnings.simplefilter("always")
        s = load_session(path, timeout=60)
    runs = [r for r in s.runs if isinstance(r, dict)] if isinstance(s.runs, list) else []
    history = [{"run": r.get("run", i), "started": r.get("started"), "command": r.get("command"),
                "resumed_from": r.get("resumed_from"), "stop": r.get("stop"), "notes": r.get("notes")}
               for i, r in enumerate(runs)]  # fmt: skip
    said = [*s.warnings, *(str(n.message) for n in notes)]
    first = runs[0] if runs else (s.start if isinstance(s.start, dict) else {})
    return {"status": s.status, "stop": s.stop, "history": history, "blocks": summary_rows(s.summary),
            "sample": s.start.get("sample"), "operator": s.start.get("operator"), "notes": s.start.get("notes"),
            "runs": len(runs), "weights": _planned_weights(s.start), "warnings": said,
            "marks": Catalog.marks_of(path, first)}  # fmt: skip


def _planned_weights(start: dict[str, Any]) -> list[float]:
    """The plan's weights [kg] (the plot's weight axis covers them from the first block on)."""
    plan = start.get("plan")
    session = plan.get("session") if isinstance(plan, dict) else None
    weights = session.get("weights_kg") if isinstance(session, dict) else None
    try:
        return sorted(float(w) for w in weights or [])
    except (TypeError, ValueError):
        return []


async def session_details(request: Request) -> Response:
    console: Console = request.app.state.console
    try:
        path = _session_file(console, request.query_params.get("path"))
        details = await asyncio.to_thread(_details, path)
    except (ValueError, OSError, RuntimeError) as exc:
        return JSONResponse({"error": _one_line(exc)}, status_code=400)
    return IndexJSON(details, headers={"cache-control": "no-store"})


def _contactrig(args: list[str], cwd: Path, closed: threading.Event | None = None) -> dict[str, Any]:
    """Run a ``contactrig`` command as the terminal would; its output (escaped by the command) for the page. Ended
    (SIGTERM) when the console goes down (``closed``), so that no command outlives it."""
    proc = subprocess.Popen([sys.executable, "-m", "contactrig", *args], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, encoding="utf-8", errors="replace")  # fmt: skip
    deadline = time.monotonic() + SUBPROCESS_TIMEOUT_S
    while True:
        try:
            out, err = proc.communicate(timeout=0.2)
            return {"code": proc.returncode, "stdout": out, "stderr": err}
        except subprocess.TimeoutExpired:
            pass
        if (closed is not None and closed.is_set()) or time.monotonic() > deadline:
            proc.terminate()
            out, err = proc.communicate()
            why = "the console is shutting down" if closed is not None and closed.is_set() else "it took too long"
            return {"code": proc.returncode, "stdout": out, "stderr": f"{err}\nstopped: {why}".strip()}


async def session_action(request: Request) -> Response:
    """``fit`` (the table and verdict as ``contactrig fit`` prints them), ``report`` (report.html, then a link to
    it) or ``export`` (CSV or xlsx beside the session)."""
    console: Console = request.app.state.console
    body = await _json_body(request)
    action = request.path_params["action"]
    try:
        path = _session_file(console, body.get("path"))
    except BadRequest as exc:
        return JSONResponse({"error": _one_line(exc)}, status_code=400)
    rel = path.relative_to(console.root).as_posix()
    stem = path.name.rsplit(".", 1)[0]
    if action == "fit":
        result = await asyncio.to_thread(_contactrig, ["fit", rel, "--bootstrap", "200"], console.root, console.closed)
        curves = _fit_curves if result["code"] == 0 else None
        result["curves"] = await asyncio.to_thread(curves, rel, console.root, console.closed) if curves else []
    elif action == "report":
        folder = f"{stem}-report"
        result = await asyncio.to_thread(
            _contactrig, ["report", rel, "-o", folder, "--force", "--bootstrap", "200", "--quiet",
                          "--no-compare-models"], console.root, console.closed)  # fmt: skip
        result["link"] = f"/files/{Path(rel).parent.joinpath(folder, 'report.html').as_posix()}"
    elif action == "export":
        to = "xlsx" if body.get("to") == "xlsx" else "csv"
        result = await asyncio.to_thread(_contactrig, ["export", rel, "--to", to, "--force"], console.root,
                                         console.closed)  # fmt: skip
        written = [ln[len("wrote "):] for ln in result["stderr"].splitlines() if ln.startswith("wrote ")]
        result["written"] = [_relative(console, str((console.root / w).resolve())) for w in written]
        result["links"] = [f"/files/{w}" for w in result["written"]]
    else:
        return JSONResponse({"error": "no such action"}, status_code=404)
    return JSONResponse(result)


def _fit_curves(rel: str, cwd: Path, closed: threading.Event | None = None) -> list[dict[str, Any]]:
    """The models' fitted curves for the plot, from ``contactrig fit --json`` (point estimates: no bootstrap)."""
    from contactrig.console.view import fit_curves

    out = _contactrig(["fit", rel, "--bootstrap", "0", "--json", "--no-record"], cwd, closed)  # the fit shown: recorded
    try:
        return fit_curves(json.loads(out["stdout"])) if out["code"] == 0 else []
    except json.JSONDecodeError:
        return []


async def follow(request: Request) -> Response:
    """A session followed from its file (``contactrig acquire`` in a terminal, or any other process): its state as
    ``contactrig watch`` sees it (:func:`view.follow`), read lock-free; no control — that stays with the process
    that writes it. ``run``: the id of this console's run on the file, when it is one (its page has the controls)."""
    from contactrig.console.view import follow as follow_file

    console: Console = request.app.state.console
    try:
        path = _session_file(console, request.query_params.get("path"))
        state = await asyncio.to_thread(follow_file, path)
    except (ValueError, OSError, RuntimeError) as exc:
        return JSONResponse({"error": _one_line(exc)}, status_code=400)
    rel = path.relative_to(console.root).as_posix()
    here = next((r for r in console.runs.values() if r.state.file == rel and r.running), None)
    state["run"] = None if here is None else here.state.id
    state["path"] = rel
    return JSONResponse(state)


def _overlay(console: Console, sample: str, leave_out: str) -> list[dict[str, Any]]:
    """Past sessions of ``sample`` (the run index's ``sample=``: the same text, case-insensitive): per weight, the
    mean of the block means."""
    from daq.run_index import UNREADABLE, Condition, query
    from daq.session_file import load_session

    found = []
    rows = query(console.root, [Condition("sample", "=", sample)])[0] if sample else []
    for e in rows:
        rel = _relative(console, e["path"])
        if rel == leave_out or e["status"] in UNREADABLE:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                summary = load_session(e["path"], timeout=30).summary
            except Exception:
                continue
        ok = summary[~summary["compliance"]] if "compliance" in summary.columns else summary
        means = ok.groupby("weight_kg")["mean_ohm"].mean()
        points = [{"weight_kg": float(w), "mean_ohm": float(m)} for w, m in means.items() if m == m]
        found.append({"path": rel, "start": e["start_time"], "points": points})
    return found[-MAX_OVERLAID:]


async def overlay(request: Request) -> Response:
    console: Console = request.app.state.console
    sample = request.query_params.get("sample", "")
    found = await asyncio.to_thread(_overlay, console, sample, request.query_params.get("leave_out", ""))
    return JSONResponse({"sessions": found})


def build_app(console: Console) -> ASGIApp:
    """The ASGI application of ``console`` (wrapped by :class:`Guard`)."""
    routes = [
        Route("/", page),
        Route("/static/{name}", static),
        Route("/files/{path:path}", files),
        Route("/api/sessions", sessions),
        Route("/api/scenes", scenes),
        Route("/api/overrides", overrides_form),
        Route("/api/plan", plan_preview, methods=["POST"]),
        Route("/api/queue", queue_state),
        Route("/api/queue", queue_add, methods=["POST"]),
        Route("/api/queue/{item}/{action}", queue_action, methods=["POST"]),
        Route("/api/runs", runs),
        Route("/api/runs", start_run, methods=["POST"]),
        Route("/api/runs/{run}", run_state),
        Route("/api/runs/{run}/answer", answer, methods=["POST"]),
        Route("/api/runs/{run}/stop", stop, methods=["POST"]),
        Route("/api/runs/{run}/pause", pause, methods=["POST"]),
        Route("/api/runs/{run}/resume", resume, methods=["POST"]),
        Route("/api/runs/{run}/events", events),
        Route("/api/session", session_details),
        Route("/api/overlay", overlay),
        Route("/api/follow", follow),
        Route("/api/session/mark", add_mark, methods=["POST"]),
        Route("/api/diff", diff),
        Route("/api/session/{action}", session_action, methods=["POST"]),
    ]
    app = Starlette(routes=routes)
    app.state.console = console
    return Guard(app, console)
