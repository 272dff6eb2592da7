"""``contactrig acquire`` as a function: a scene's session plan, run on the bench (or the simulated bench), to HDF5.

Order of work, so that a fault costs nothing already recorded: validate the plan, create (or reopen for
``--resume``) the output file — this proves it is writable before any instrument is touched — open the bench,
identify both instruments, write the start record, then run the blocks (each on disk before the next). An
unreachable instrument removes the file just created (it holds nothing); it never touches an existing session.
"""

from __future__ import annotations

import contextlib
import errno
import os
import sys
import warnings
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from contactrig.core.provenance import host_name, login_name
from contactrig.core.scene import Scene, load_scene, parse_scene
from daq.engine import AcquisitionEngine, Interrupts, OperatorQuit, Prompter, RunOutcome, Writer, answer_yes
from daq.errors import MissingFileError, SessionExistsError, SessionStateError, SessionWriteError
from daq.link import InstrumentLink, open_visa_link
from daq.plan import Measure, PlaceWeight, SessionPlan, session_steps
from daq.records import now_iso
from daq.session_file import SCHEMA_VERSION, SessionFile, load_session, software_versions
from daq.writers import FileWriter, LiveDisplay

__all__ = ["DEFAULT_SIM_SPEED", "AcquisitionResult", "acquire", "drive", "terminal_prompter"]

#: Default ``--sim-speed``: the simulated instruments run this many times faster than real ones.
DEFAULT_SIM_SPEED = 1000.0


@dataclass(frozen=True)
class AcquisitionResult:
    """What ``acquire`` did: the file, the stop record's status and reason, and counts."""

    path: Path
    status: str
    reason: str
    blocks_done: int
    blocks_planned: int
    run: int


def terminal_prompter(stream: TextIO | None = None, read: Any = input) -> Prompter:
    """Ask the operator at the terminal: Enter → go on, ``s`` → skip this weight, ``q`` → stop."""
    out = stream if stream is not None else sys.stderr

    def prompt(step: PlaceWeight) -> Any:
        while True:
            print(
                f"Place weight {step.weight_index + 1}: {step.weight_kg:g} kg in the piston "
                f"({step.repeats_left} block(s) to measure). [Enter] go on, s skip, q stop: ",
                end="",
                file=out,
                flush=True,
            )
            try:
                answer = read().strip().lower()
            except EOFError:
                raise OperatorQuit("no operator input (stdin closed): run unattended with --yes") from None
            if answer in ("", "g", "go", "y", "yes"):
                return "go"
            if answer in ("s", "skip"):
                return "skip"
            if answer in ("q", "quit", "stop"):
                return "quit"
            print(f"'{answer}' is not an answer: press Enter, s or q", file=out, flush=True)

    return prompt


def drive(
    link: InstrumentLink,
    plan_settings: Any,
    steps: Iterable[PlaceWeight | Measure],
    writers: list[Writer],
    start: dict[str, Any],
    scene_text: str,
    *,
    run: int = 0,
    prompter: Prompter = answer_yes,
    interrupts: Interrupts | None = None,
    blocks_planned: int = 0,
    blocks_before: int = 0,
    readings_before: int = 0,
) -> RunOutcome:
    """The acquisition path shared by acquire and replay: identify, start record, blocks, close, stop record.

    ``start`` is completed with the instruments' identities. The link is closed (source idle) on every path.
    """
    try:
        identity = link.identify()
    except BaseException:
        with contextlib.suppress(Exception):  # the identify error is the one to report
            link.close()
        raise
    start = {
        **start,
        "instrument": {**start.get("instrument", {}), "source": identity.source, "voltmeter": identity.voltmeter},
    }
    engine = AcquisitionEngine(
        link,
        plan_settings,
        writers,
        run=run,
        prompter=prompter,
        interrupts=interrupts,
        blocks_planned=blocks_planned,
        blocks_before=blocks_before,
        readings_before=readings_before,
    )
    try:
        engine.start(start, scene_text)
    except BaseException:
        with contextlib.suppress(Exception):
            link.close()
        raise
    return engine.run(steps)


def _resume_state(path: Path, scene: Scene | None, sim: bool) -> tuple[Scene, set[int], int, dict[str, Any]]:
    if not path.exists():
        raise MissingFileError(errno.ENOENT, f"--resume: no session file {path} to continue")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        session = load_session(path)
    if session.imported:
        raise SessionStateError(f"{path} is an imported table, not an acquisition: nothing to resume")
    if session.status == "success":
        raise SessionStateError(f"{path} is a complete session (status success): nothing to resume")
    recorded = parse_scene(session.scene_text, f"{path} (recorded scene)")
    if scene is not None and scene.text != recorded.text:
        raise SessionStateError(
            f"the scene {scene.source} differs from the one recorded in {path}; --resume continues the recorded "
            "plan: leave out the SCENE argument"
        )
    if bool(session.start.get("sim", False)) != sim:
        how = "with --sim" if session.start.get("sim") else "without --sim (on the real bench)"
        raise SessionStateError(f"{path} was recorded {how}; resume it the same way")
    done = {int(b) for b in session.summary["block"]}
    readings = int(session.summary["n"].sum() + session.summary["n_invalid"].sum())
    return recorded, done, readings, session.start


def acquire(
    scene: Scene | str | Path | None,
    output: str | Path,
    *,
    sim: bool = False,
    yes: bool = False,
    sim_speed: float = DEFAULT_SIM_SPEED,
    resume: bool = False,
    force: bool = False,
    prompter: Prompter | None = None,
    stream: TextIO | None = None,
    quiet: bool = False,
    resource_manager: Any = None,
    link_wrapper: Any = None,
    fsync: bool = True,
) -> AcquisitionResult:
    """Run a bench session and write it to ``output`` (see the module docstring for the order of work).

    ``scene``: a :class:`~contactrig.core.scene.Scene`, a path, or None (the packaged default; with ``resume``,
    None means
    the scene recorded in the file). ``sim_speed``: simulated instrument time runs this many times faster
    (1 = real pace, ``inf`` = no waiting). ``link_wrapper(transport) -> transport`` wraps the instrument
    transport (fault-injection in tests). Raises the error that ended the session, after its stop record.
    """
    path = Path(output)
    if isinstance(scene, (str, Path)):
        scene = load_scene(scene)
    if resume:
        scene, done, readings_before, first_start = _resume_state(path, scene, sim)
    else:
        if scene is None:
            scene = load_scene(None)
        done, readings_before, first_start = set(), 0, None
        if path.exists() and not force:
            raise SessionExistsError(
                errno.EEXIST, f"{path} exists; use --force to overwrite it or --resume to continue it"
            )
    plan = SessionPlan.from_scene(scene)
    if sim and not (sim_speed > 0):
        raise ValueError(f"--sim-speed = {sim_speed!r} is not allowed: expected a number > 0 (1 = real pace, inf)")

    # 1. the output file: proves the path is writable before any instrument is touched
    created = False
    if resume:
        if not os.access(path, os.W_OK):
            raise SessionWriteError(errno.EACCES, f"no permission to write {path}")
    else:
        sf = SessionFile.create(path, delta_unit=plan.delta.unit, force=force, fsync=fsync)
        sf.close()
        created = True

    # 2. the bench
    sim_info: dict[str, Any] = {}
    try:
        if sim:
            from daq.simulated import open_sim_link

            link, sim_info = open_sim_link(plan, sim_speed=sim_speed, link_wrapper=link_wrapper)
        else:
            link = open_visa_link(plan.instrument.address, plan.instrument.timeout_ms, resource_manager)
            if link_wrapper is not None:
                link = InstrumentLink(link_wrapper(link.recorder.inner), address=plan.instrument.address)
    except BaseException:
        if created:
            path.unlink(missing_ok=True)
        raise

    # 3. the session. From here on the link is closed (source idle, idempotent) in `finally`, whatever fails —
    # also what fails before `drive` takes the link over (reopening the file, the display, a Ctrl-C).
    sf: SessionFile | None = None
    display: LiveDisplay | None = None
    outcome: RunOutcome | None = None
    try:
        sf = SessionFile.open_for_resume(path, fsync=fsync, keep_blocks=len(done) if resume else None)
        start = _start_record(plan, scene, sim=sim, sim_info=sim_info, run=sf.run, first_start=first_start)
        display = LiveDisplay(plan.blocks_planned, done=len(done), stream=stream, quiet=quiet)
        for note in sim_info.get("rig_warnings", []):
            display.message(f"rig simulation: {note}")
        writers: list[Writer] = [FileWriter(sf), display]
        base_prompt = prompter or (answer_yes if yes else terminal_prompter(stream))
        shown = display

        def ask(step: PlaceWeight) -> Any:
            with shown.paused():
                return base_prompt(step)

        with Interrupts(notify=display.message) as interrupts:
            outcome = drive(
                link,
                plan.delta,
                session_steps(plan, frozenset(done)),
                writers,
                start,
                scene.text,
                run=sf.run,
                prompter=ask,
                interrupts=interrupts,
                blocks_planned=plan.blocks_planned,
                blocks_before=len(done),
                readings_before=readings_before,
            )
    finally:
        try:
            link.close()  # a no-op when drive has closed it already
        except Exception:
            if outcome is not None and outcome.error is None:
                raise
        if display is not None:
            display.close()
        if sf is not None:
            try:
                sf.close()
            except OSError:
                if outcome is not None and outcome.error is None:
                    raise  # otherwise the error that ended the session is the one to report
        if outcome is None and created and (sf is None or sf.n_blocks_at_close == 0):
            path.unlink(missing_ok=True)  # failed before the first block (e.g. identify): nothing recorded
    if outcome.error is not None:
        raise outcome.error
    return AcquisitionResult(
        path=path,
        status=outcome.stop.status,
        reason=outcome.stop.reason,
        blocks_done=outcome.stop.blocks_done,
        blocks_planned=plan.blocks_planned,
        run=sf.run,
    )


def _start_record(
    plan: SessionPlan,
    scene: Scene,
    *,
    sim: bool,
    sim_info: dict[str, Any],
    run: int,
    first_start: dict[str, Any] | None,
) -> dict[str, Any]:
    """The start record of run ``run`` (the instruments' identities are added by :func:`drive`)."""
    return {
        "format": "contactrig-session",
        "schema_version": SCHEMA_VERSION,
        "software": software_versions(),
        "started": now_iso(),
        "operator": plan.session.operator or login_name(),
        "operator_source": "scene" if plan.session.operator else "login",
        "host": host_name(),
        "command": " ".join(sys.argv),
        "imported": False,
        "sim": bool(sim),
        "simulation": sim_info,
        "scene_source": scene.source,
        "scene_name": scene.name,
        "sample": plan.session.sample,
        "rig": plan.session.rig,
        "plan": plan.describe(),
        "instrument": {"address": plan.instrument.address, "timeout_ms": plan.instrument.timeout_ms},
        "run": run,
        "resumed_from": (first_start or {}).get("started") if first_start is not None else None,
    }
