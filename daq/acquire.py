"""``contactrig acquire`` as a function: a scene's session plan, run on the bench (or the simulated bench), to HDF5.

Order of work, so that a fault costs nothing already recorded: validate the plan, create the output file as a
locked temporary file beside its name (or lock and reopen it for ``--resume``) — this proves it is writable before
any instrument is touched — open the bench, identify both instruments, write the start record, give the file its
name (:mod:`daq.session_lock`: renamed over an existing one only with ``--force`` and only if no other process holds
it), then run the blocks (each on disk before the next). An unreachable instrument removes the temporary file (it
holds nothing); an existing session is never truncated, and is replaced only once the new one has its start record.
"""

from __future__ import annotations

import contextlib
import errno
import os
import sys
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from contactrig.core.provenance import host_name, login_name, now_iso
from contactrig.core.scene import Scene, load_scene, parse_scene
from contactrig.core.text import shown
from daq.engine import AcquisitionEngine, Decision, Interrupts, OperatorQuit, Prompter, RunOutcome, Writer, answer_yes
from daq.errors import MissingFileError, NoStartRecordError, SessionExistsError, SessionStateError
from daq.link import Bench, InstrumentLink, OpenedBench, VisaBench
from daq.overrides import OverrideChange, check_bench, plan_values, plan_with_overrides, resume_overrides
from daq.pause import PauseControl
from daq.plan import (
    CONVERSION_OVERHEAD_S,
    Measure,
    PlaceWeight,
    SessionPlan,
    estimate_duration,
    session_steps,
)
from daq.session_file import SCHEMA_VERSION, SessionFile, load_session, software_versions
from daq.session_writer import check_new_session
from daq.writers import FileWriter, LiveDisplay

__all__ = [
    "AcquisitionResult",
    "ResumeChooser",
    "acquire",
    "drive",
    "plan_lines",
    "skipped_weights",
    "terminal_prompter",
    "terminal_resume_chooser",
]


@dataclass(frozen=True)
class AcquisitionResult:
    """What ``acquire`` did: the file, the stop record's status and reason, and counts."""

    path: Path
    status: str
    reason: str
    blocks_done: int
    blocks_planned: int
    run: int


@dataclass(frozen=True)
class _Prior:
    """What the file holds already (``--resume``): the blocks done, their readings, the first run's start record."""

    resumed: bool = False
    done: frozenset[int] = frozenset()
    readings: int = 0
    first_start: dict[str, Any] | None = None
    #: weights the stop records of earlier runs list as skipped
    recorded_skips: frozenset[float] = frozenset()
    #: the start record of the latest run (its overrides carry over to a resumed run)
    last_start: dict[str, Any] | None = None
    #: runs on file: the number of the run about to start (0 for a new session)
    runs: int = 0


@dataclass(frozen=True)
class _Order:
    """This run's loading order: weight indices placed first (skipped earlier, measured now), weight indices kept
    skipped, and the resume questions with their answers (for the start record)."""

    first: tuple[int, ...] = ()
    leave_out: frozenset[int] = frozenset()
    choices: tuple[dict[str, Any], ...] = ()


def terminal_prompter(stream: TextIO | None = None, read: Callable[[], str] = input) -> Prompter:
    """Ask the operator at the terminal: Enter → go on, ``s`` → skip this weight, ``q`` → stop."""
    out = stream if stream is not None else sys.stderr

    def prompt(step: PlaceWeight) -> Decision:
        while True:
            answer = _ask(
                f"Place weight {step.weight_index + 1}: {step.weight_kg:g} kg in the piston "
                f"({step.repeats_left} block(s) to measure). [Enter] go on, s skip, q stop: ",
                out,
                read,
                OperatorQuit("no operator input (stdin closed): run unattended with --yes"),
            )
            if answer in ("", "g", "go", "y", "yes"):
                return "go"
            if answer in ("s", "skip"):
                if _confirmed(f"skip {step.weight_kg:g} kg? [y/N]: ", out, read):
                    return "skip"
                print(f"not skipped: {step.weight_kg:g} kg stays in the plan", file=out, flush=True)
                continue
            if answer in ("q", "quit", "stop"):
                return "quit"
            print(f"'{answer}' is not an answer: press Enter, s or q", file=out, flush=True)

    return prompt


def _ask(question: str, out: TextIO, read: Callable[[], str], on_eof: Exception) -> str:
    """Print ``question`` and return the operator's answer, stripped and lower-case; ``on_eof`` is raised when
    stdin is closed (nobody at the terminal)."""
    print(question, end="", file=out, flush=True)
    try:
        return read().strip().lower()
    except EOFError:
        raise on_eof from None


def _confirmed(question: str, out: TextIO, read: Callable[[], str]) -> bool:
    """Ask a yes/no question; only ``y``/``yes`` is yes (Enter, anything else: no)."""
    eof = OperatorQuit("no operator input (stdin closed): run unattended with --yes")
    return _ask(question, out, read, eof) in ("y", "yes")


#: Asked on ``--resume`` for each weight an earlier run skipped: True = measure it now (placed first in this run),
#: False = keep it skipped.
ResumeChooser = Callable[[float], bool]
MEASURE_NOW, KEEP_SKIPPED = "measure it now", "keep it skipped"


def terminal_resume_chooser(stream: TextIO | None = None, read: Callable[[], str] = input) -> ResumeChooser:
    """Ask the operator at the terminal about a weight an earlier run skipped: ``m`` measure it now, Enter keep it
    skipped (the default)."""
    out = stream if stream is not None else sys.stderr

    def choose(weight_kg: float) -> bool:
        eof = SessionStateError(
            f"no operator input (stdin closed) to say whether to measure the skipped {weight_kg:g} kg: "
            "answer at the terminal, or resume with --yes (keeps it skipped)"
        )
        question = f"{weight_kg:g} kg was skipped: m {MEASURE_NOW} (placed first in this run), [Enter] {KEEP_SKIPPED}: "
        while True:
            answer = _ask(question, out, read, eof)
            if answer in ("", "k", "keep"):
                return False
            if answer in ("m", "measure"):
                return True
            print(f"'{answer}' is not an answer: press m or Enter", file=out, flush=True)

    return choose


def drive(
    link: InstrumentLink,
    block_settings: object,
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
    skipped_before: Sequence[float] = (),
    pause: PauseControl | None = None,
) -> RunOutcome:
    """The acquisition path shared by acquire and replay: identify, start record, blocks, close, stop record.

    ``block_settings`` are the instrument pair's settings of every block; ``start`` is completed with the
    instruments' identities. The link is closed (source idle) on every path.
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
        block_settings,
        writers,
        run=run,
        prompter=prompter,
        interrupts=interrupts,
        blocks_planned=blocks_planned,
        blocks_before=blocks_before,
        readings_before=readings_before,
        skipped_before=skipped_before,
        pause=pause,
    )
    try:
        engine.start(start, scene_text)
    except BaseException:
        with contextlib.suppress(Exception):
            link.close()
        raise
    return engine.run(steps)


def _resume_state(path: Path, scene: Scene | None, simulated: bool) -> tuple[Scene, _Prior]:
    if not path.exists():
        raise MissingFileError(errno.ENOENT, f"--resume: no session file {path} to continue")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            session = load_session(path)
        except NoStartRecordError:
            raise SessionStateError(
                f"{path} has no start record (its acquisition was stopped before it began): nothing to resume; "
                "use --force to start a new session in its place"
            ) from None
    if session.imported:
        raise SessionStateError(f"{path} is an imported table, not an acquisition: nothing to resume")
    if session.running:
        raise SessionStateError(f"{path} is being written by another process right now: let it finish or stop it")
    if session.status == "success":
        raise SessionStateError(f"{path} is a complete session (status success): nothing to resume")
    recorded = parse_scene(session.scene_text, f"{path} (recorded scene)")
    if scene is not None and scene.text != recorded.text:
        raise SessionStateError(
            f"the scene {scene.source} differs from the one recorded in {path}; --resume continues the recorded "
            "plan: leave out the SCENE argument"
        )
    if bool(session.start.get("sim", False)) != simulated:
        how = "with --sim" if session.start.get("sim") else "without --sim (on the real bench)"
        raise SessionStateError(f"{path} was recorded {how}; resume it the same way")
    done = frozenset(int(b) for b in session.summary["block"])
    readings = int(session.summary["n"].sum() + session.summary["n_invalid"].sum())
    stops = [r.get("stop") for r in session.runs if isinstance(r, dict)] + [session.stop]
    skips = frozenset(
        float(w)
        for stop in stops
        if isinstance(stop, dict) and isinstance(stop.get("weights_skipped"), list)
        for w in stop["weights_skipped"]
        if isinstance(w, (int, float)) and not isinstance(w, bool)
    )
    runs = [r for r in session.runs if isinstance(r, dict)]
    prior = _Prior(resumed=True, done=done, readings=readings, first_start=session.start, recorded_skips=skips,
                   last_start=runs[-1] if runs else session.start, runs=len(session.runs))  # fmt: skip
    return recorded, prior


def skipped_weights(plan: SessionPlan, done: frozenset[int], recorded: frozenset[float] = frozenset()) -> list[int]:
    """Weight indices an earlier run skipped and whose blocks are not all done: those its stop records list as
    skipped (``recorded``), and — a killed run leaves no stop record — those without a block while a weight placed
    after them in the plan has blocks."""
    repeats, weights = plan.session.repeats, plan.session.weights_kg
    blocks = [{wi * repeats + r for r in range(repeats)} for wi in range(len(weights))]
    has = [bool(b & done) for b in blocks]
    return [
        wi
        for wi, w in enumerate(weights)
        if not blocks[wi] <= done and (float(w) in recorded or (not has[wi] and any(has[wi + 1 :])))
    ]


def _resume_order(plan: SessionPlan, prior: _Prior, choose: ResumeChooser | None, say: Callable[[str], None]) -> _Order:
    """Ask about each weight an earlier run skipped (``choose``; None: ``--yes``, which keeps it skipped and says
    so): measure it now (placed first) or keep it skipped. The answers go into the start record."""
    if not prior.resumed:
        return _Order()
    first: list[int] = []
    kept: list[int] = []
    choices: list[dict[str, Any]] = []
    for wi in skipped_weights(plan, prior.done, prior.recorded_skips):
        weight = plan.session.weights_kg[wi]
        if choose is None:
            now, by = False, "default with --yes"
            say(f"{weight:g} kg was skipped: {KEEP_SKIPPED} — the default with --yes (resume without --yes to be "
                "asked)")  # fmt: skip
        else:
            now, by = choose(weight), "operator"
        (first if now else kept).append(wi)
        choices.append({"weight_kg": weight, "weight_index": wi, "choice": MEASURE_NOW if now else KEEP_SKIPPED,
                        "by": by})  # fmt: skip
    return _Order(first=tuple(first), leave_out=frozenset(kept), choices=tuple(choices))


def acquire(
    scene: Scene | str | Path | None,
    output: str | Path,
    *,
    bench: Bench | None = None,
    yes: bool = False,
    resume: bool = False,
    force: bool = False,
    prompter: Prompter | None = None,
    stream: TextIO | None = None,
    quiet: bool = False,
    fsync: bool = True,
    extra_writers: Sequence[Writer] = (),
    resume_chooser: ResumeChooser | None = None,
    overrides: Mapping[str, Any] | None = None,
    allow_change: bool = False,
    adaptive: Callable[[SessionPlan], Any] | None = None,
    pause: PauseControl | None = None,
) -> AcquisitionResult:
    """Run a bench session and write it to ``output`` (see the module docstring for the order of work).

    ``scene``: a :class:`~contactrig.core.scene.Scene`, a path, or None (the packaged default; with ``resume``,
    None means the scene recorded in the file). ``bench``: where the blocks are taken (default
    :class:`~daq.link.VisaBench`, the plan's VISA address; ``analysis.simulated_session.SimulatedRigBench`` is
    ``--sim``); a session resumes only on the same kind of bench. ``prompter`` asks the operator to place each
    weight (default: at the terminal, or nobody with ``yes``). ``fsync=False`` leaves syncing to the OS (faster;
    a power cut may then lose the last blocks). ``extra_writers`` get every record too (``acquire --live``: the
    live view; an optional writer must contain its own failures, e.g. ``analysis.watch.Guarded``). Raises the error
    that ended the session, after its stop record.

    At the start the plan is printed to ``stream`` (unless ``quiet``): the weights in loading order, repeats,
    readings per block and the estimated duration (:func:`daq.plan.estimate_duration`). On ``resume``, each weight an
    earlier run skipped is asked about (``resume_chooser``, default: at the terminal; with ``yes`` it is kept
    skipped and the output says so): measured now (placed first) or kept skipped; the answers are recorded in the
    run's start record (``resume_choices``), with the run's ``loading_order_kg``.

    ``overrides``: ``{scene key: value}`` of this run (:mod:`daq.overrides`: ``acquire --address``, ``--sample``
    …), validated as the scene keys and recorded apart from the scene text; a resumed run keeps the earlier run's
    and states a change (a different sample is refused unless ``allow_change``).

    ``adaptive``: given the plan, the steps of an adaptive session (``acquire --adaptive``,
    :func:`analysis.adaptive_session.adaptive_source`): an iterable of steps chosen as the blocks come in (it gets
    every block as a writer), with its ``plan`` (block numbers), ``settings`` (recorded in the start record's
    ``adaptive``), ``plan_lines()``, ``say``/``paused`` (the live display) and the ``stop_reason`` and ``record()``
    the engine puts in the stop record; the operator is asked by the steps themselves. Not with ``resume``.

    ``pause``: the operator's pause requests (the console's Pause and Resume, :mod:`daq.pause`), taken at block
    boundaries and recorded in the run record.
    """
    path = Path(output)
    bench = bench if bench is not None else VisaBench()
    scene, prior = _scene_and_prior(scene, path, resume=resume, force=force, simulated=bench.simulated)
    check_bench(overrides or {}, simulated=bench.simulated)
    plan, run_overrides, changes = _overridden_plan(scene, prior, overrides or {}, allow_change)
    source, plan = _adaptive_steps(adaptive, plan, resume=resume)
    check = getattr(bench, "check", None)  # a bench's own part of the scene (the --sim simulation), before any output
    if check is not None:
        check(plan)
    sf = _prepare_file(path, plan, resume=resume, force=force, fsync=fsync)
    try:
        steps, order = _announce(plan, prior, bench, stream=stream, quiet=quiet, yes=yes, prompter=prompter,
                                 resume_chooser=resume_chooser, changes=changes, source=source)  # fmt: skip
    except BaseException:
        sf.discard()
        raise
    opened = _open_bench(bench, plan, sf, run=prior.runs)
    ask = prompter or (answer_yes if yes or source is not None else terminal_prompter(stream))
    writers = [*extra_writers, *([] if source is None else [source])]
    display: LiveDisplay | None = None
    outcome: RunOutcome | None = None
    notices: list[Callable[[str], None]] = []

    def notify(text: str) -> None:  # to the live display, once there is one
        for say in notices[-1:]:
            say(text)

    # From here on the link is closed (source idle, idempotent) in `finally`, whatever fails — also what fails
    # before `drive` takes the link over (reopening the file, the display, a Ctrl-C). The Ctrl-C policy covers the
    # clean-up too: once the run is over, a further Ctrl-C cannot cut the closing of the file short.
    with Interrupts(notify=notify) as interrupts:
        try:
            if prior.resumed:
                sf.begin_resume(keep_blocks=len(prior.done))
            start = _start_record(plan, scene, simulated=bench.simulated, opened=opened, run=sf.run, prior=prior)
            start["overrides"] = dict(run_overrides)
            start["override_changes"] = [c.as_dict() for c in changes]
            if "session.operator" in run_overrides:
                start["operator_source"] = "override"
            start["loading_order_kg"] = _loading_order(steps) if isinstance(steps, list) else []
            start["resume_choices"] = list(order.choices)
            display = LiveDisplay(plan.blocks_planned, done=len(prior.done), stream=stream, quiet=quiet)
            notices.append(display.message)
            _attach(source, start, display)
            for note in opened.notes:
                display.message(note)
            kept = [plan.session.weights_kg[wi] for wi in sorted(order.leave_out)]
            outcome = _run(opened.link, plan, start, sf, display, (steps, kept, prior), ask, interrupts, writers,
                           pause)  # fmt: skip
        finally:
            interrupts.phase = "writing"  # deferred, never raised: the run has ended already
            _clean_up(opened.link, display, sf, outcome)
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


def _adaptive_steps(
    adaptive: Callable[[SessionPlan], Any] | None, plan: SessionPlan, *, resume: bool
) -> tuple[Any, SessionPlan]:
    """The steps of an adaptive session (None for a fixed plan) and the plan they number their blocks in."""
    if adaptive is None:
        return None, plan
    if resume:
        raise SessionStateError("--adaptive does not resume a session: start a new one")
    source = adaptive(plan)
    return source, source.plan


def _attach(source: Any, start: dict[str, Any], display: LiveDisplay) -> None:
    """An adaptive session's settings into the start record; its evidence line after each block to the display,
    and the operator asked with the bar cleared."""
    if source is not None:
        start["adaptive"] = dict(source.settings)
        source.say, source.paused = display.message, display.paused


def _announce(
    plan: SessionPlan,
    prior: _Prior,
    bench: Bench,
    *,
    stream: TextIO | None,
    quiet: bool,
    yes: bool,
    prompter: Prompter | None,
    resume_chooser: ResumeChooser | None,
    changes: Sequence[OverrideChange] = (),
    source: Any = None,
) -> tuple[Iterable[PlaceWeight | Measure], _Order]:
    """Ask about the weights an earlier run skipped, then print the plan; returns the steps still to take (an
    adaptive session's ``source``: its own lines, its steps)."""
    out = stream if stream is not None else sys.stderr

    def say(text: str) -> None:
        if not quiet:
            print(text, file=out, flush=True)

    if source is not None:
        for line in source.plan_lines():
            say(line)
        return source, _Order()

    chooser = resume_chooser if resume_chooser is not None else None if yes else terminal_resume_chooser(stream)
    order = _resume_order(plan, prior, chooser, say)
    for change in changes:
        say(change.describe())
    steps = list(session_steps(plan, prior.done, first=order.first, leave_out=order.leave_out))
    time_scale = float(getattr(bench, "time_scale", 1.0)) if bench.simulated else 1.0
    for line in plan_lines(plan, steps, blocks_on_file=len(prior.done), attended=prompter is not None or not yes,
                           time_scale=time_scale):  # fmt: skip
        say(line)
    return steps, order


def _overridden_plan(
    scene: Scene, prior: _Prior, given: Mapping[str, Any], allow_change: bool
) -> tuple[SessionPlan, dict[str, Any], list[OverrideChange]]:
    """The plan of this run, its overrides and — on ``--resume`` — the changes from the run before
    (:func:`daq.overrides.resume_overrides`: the earlier run's overrides are kept)."""
    if not prior.resumed:
        return plan_with_overrides(scene, given), dict(given), []
    earlier = prior.last_start.get("overrides") if prior.last_start is not None else None
    earlier = dict(earlier) if isinstance(earlier, dict) else {}
    before = plan_values(plan_with_overrides(scene, earlier))
    merged, changes = resume_overrides(earlier, given, before, allow_change=allow_change)
    return plan_with_overrides(scene, merged), merged, changes


def _scene_and_prior(
    scene: Scene | str | Path | None, path: Path, *, resume: bool, force: bool, simulated: bool
) -> tuple[Scene, _Prior]:
    """The scene to run and what the file holds already; refuses an existing file unless ``resume`` or ``force``."""
    if isinstance(scene, (str, Path)):
        scene = load_scene(scene)
    if resume:
        return _resume_state(path, scene, simulated)
    if scene is None:
        scene = load_scene(None)
    if os.path.lexists(path) and not force:
        raise SessionExistsError(errno.EEXIST, f"{path} exists; use --force to overwrite it or --resume to continue it")
    check_new_session(path, force=force)  # --force: a file in use is refused before anything is done
    return scene, _Prior()


def _prepare_file(path: Path, plan: SessionPlan, *, resume: bool, force: bool, fsync: bool) -> SessionFile:
    """The session file, open and locked before any instrument is touched (proves the path is writable): a resumed
    file as it is (changed only once the bench answers), or a new one as a temporary file beside ``path`` that takes
    its name once its start record is on disk (:mod:`daq.session_lock`)."""
    if resume:
        return SessionFile.open_existing(path, fsync=fsync)
    unit = plan.pair.reading_unit(plan.block_settings)
    return SessionFile.create(path, reading_unit=unit, force=force, fsync=fsync)


def _open_bench(bench: Bench, plan: SessionPlan, sf: SessionFile, *, run: int) -> OpenedBench:
    """Open the bench for run ``run``; if it cannot be reached, a new file (it holds nothing) is removed, a resumed
    one closed."""
    try:
        return bench.open(plan, run=run)
    except BaseException:
        sf.discard()
        raise


def _run(
    link: InstrumentLink,
    plan: SessionPlan,
    start: dict[str, Any],
    sf: SessionFile,
    display: LiveDisplay,
    todo: tuple[Iterable[PlaceWeight | Measure], list[float], _Prior],
    prompter: Prompter,
    interrupts: Interrupts,
    extra_writers: Sequence[Writer] = (),
    pause: PauseControl | None = None,
) -> RunOutcome:
    """The blocks still to do (``todo``: the steps, the weights kept skipped, what the file holds), to the file and
    the live display, the operator asked with the display paused."""
    steps, kept, prior = todo

    def ask(step: PlaceWeight) -> Decision:
        with display.paused():
            return prompter(step)

    return drive(
        link,
        plan.block_settings,
        steps,
        [FileWriter(sf), display, *extra_writers],
        start,
        plan.scene.text,
        run=sf.run,
        prompter=ask,
        interrupts=interrupts,
        blocks_planned=plan.blocks_planned,
        blocks_before=len(prior.done),
        readings_before=prior.readings,
        skipped_before=kept,
        pause=pause,
    )


def _loading_order(steps: Sequence[PlaceWeight | Measure]) -> list[float]:
    return [s.weight_kg for s in steps if isinstance(s, PlaceWeight)]


def plan_lines(
    plan: SessionPlan,
    steps: Sequence[PlaceWeight | Measure],
    *,
    blocks_on_file: int = 0,
    attended: bool = True,
    time_scale: float = 1.0,
) -> list[str]:
    """What ``acquire`` prints at the start: the plan (weights in loading order, repeats, readings per block) and
    the estimated duration, the operator's allowance per weight stated as such."""
    order = _loading_order(steps)
    est = estimate_duration(plan, steps, attended=attended, time_scale=time_scale)
    count = getattr(plan.block_settings, "count", "?")
    still = f" still to take ({blocks_on_file} on file)" if blocks_on_file else ""
    lines = [
        f"plan: {est.blocks} blocks{still} — {len(order)} weight(s) in loading order "
        f"{', '.join(f'{w:g}' for w in order) or 'none'} kg; {plan.session.repeats} repeat(s) per weight; "
        f"{count} readings per block"
    ]
    if est.block_s is None or est.measuring_s is None or est.total_s is None:
        return [*lines, "estimated duration: not known for this instrument pair's settings"]
    s = plan.block_settings
    how = (
        f"{count} × ({s.delay_s * 1e3:g} ms delay + NPLC {s.nplc:g} / {s.line_frequency_hz:g} Hz + "
        f"{CONVERSION_OVERHEAD_S * 1e3:g} ms assumed overhead per conversion)"
    )
    if time_scale != 1.0:
        how += f", simulated bench: instrument time × {time_scale:g}"
    operator = (
        f" + {_duration(est.operator_s)} operator allowance ({_duration(est.operator_allowance_s)} per weight to "
        "place it: an allowance, not a measurement)"
        if est.operator_allowance_s
        else " (unattended: no operator time)"
    )
    lines.append(
        f"estimated duration: {_duration(est.measuring_s)} measuring ({est.blocks} blocks × {est.block_s:.3g} s: "
        f"{how}){operator} ≈ {_duration(est.total_s)}"
    )
    return lines


def _duration(seconds: float) -> str:
    s = round(seconds)
    if seconds < 10:
        return f"{seconds:.2g} s"
    if s >= 3600:
        return f"{s // 3600} h {s % 3600 // 60:02d} min"
    if s >= 60:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s} s"


def _clean_up(
    link: InstrumentLink,
    display: LiveDisplay | None,
    sf: SessionFile,
    outcome: RunOutcome | None,
) -> None:
    """Close link, display and file on every path; an error here is reported only when the run itself was fine."""
    ok = outcome is not None and outcome.error is None
    try:
        link.close()  # a no-op when drive has closed it already
    except Exception:
        if ok:
            raise
    if display is not None:
        display.close()
    if outcome is None and sf.n_blocks == 0:
        sf.discard()  # failed before the first block (e.g. identify): nothing recorded, a new file is not kept
        return
    try:
        sf.close()
    except OSError:
        if ok:
            raise  # otherwise the error that ended the session is the one to report


def _start_record(
    plan: SessionPlan,
    scene: Scene,
    *,
    simulated: bool,
    opened: OpenedBench,
    run: int,
    prior: _Prior,
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
        "command": shown(" ".join(sys.argv)),  # a non-UTF-8 file name in it: as visible escapes
        "imported": False,
        "sim": bool(simulated),
        "simulation": opened.simulation,
        "scene_source": shown(scene.source),
        "scene_name": scene.name,
        "sample": plan.session.sample,
        "notes": plan.session.notes,
        "rig": plan.session.rig,
        "plan": plan.describe(),
        "instrument": {
            "address": plan.instrument.address,
            "timeout_ms": plan.instrument.timeout_ms,
            "pair": plan.instrument.pair,
            # how it was reached: VISA library, Nagle off on LAN, serial parameters and chunk size over RS-232
            **opened.link.connection,
            # what every block sets besides the block settings (filters, math, timestamps…), read back each block
            "pinned_state": opened.link.pinned_state(),
        },
        "run": run,
        "resumed_from": prior.first_start.get("started") if prior.first_start is not None else None,
    }
