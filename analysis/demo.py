"""``contactrig demo``: the main job on the packaged default scene, end to end, in one call.

1. simulate the rig for every model of the default scene (``sims.rig.sweep``; contact database built once) and
   save it (``sim.h5``);
2. acquire a session on the simulated bench, unattended (``acquire(..., bench=SimulatedRigBench(), yes=True)``), whose
   resistance is R_s + f·(ζh/A(W) + clean metal) of the scene's ``[session].sim_model`` — f a seeded, mean-one
   log-normal factor per block with Tab. 1's noise structure (``[session].sim_noise``, :mod:`analysis.noise_model`)
   — plus the simulated instruments' noise
   (``session.h5``);
3. replay the session through the driver and check it reproduces every block (``daq.replay.replay_session``);
4. fit the session against every model, and the seed paper's Tab. 1 (all six series, and M1–M3 alone, since
   M4–M6 are arithmetic copies of them), with the resistance model's sentence for each (fitted σ_f, R_s and the
   clean-metal fraction, :mod:`analysis.resistance_model`);
5. ask the boundary-element reference which contact model it favours on the scene's surface, and by how much
   (:func:`analysis.pipeline.rank_against_bem`: 5 mean pressures 0.3–30 MPa, one realisation; ``compare=False``
   leaves it out);
6. write the figures, ``report.md`` and the self-contained ``report.html`` into the output directory.

Every file the demo writes is checked before it starts: an existing one (an earlier demo's ``session.h5``, say) is
refused unless ``force`` (``--force``); the folder is created when missing (:mod:`contactrig.core.files`).

Because the bench was built from one model with known R_s and ζ, the report shows whether the fit recovers them
(within intervals that reflect the Tab. 1-like repeat scatter) — an end-to-end check of the whole chain.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

__all__ = ["DemoResult", "run_demo"]


@dataclass(frozen=True)
class DemoResult:
    """Where the demo wrote its files, how long each step took [s] and what the replay found."""

    directory: Path
    report: Path
    session: Path
    sim: Path
    timings_s: dict[str, float]
    replay: dict[str, Any]
    analyses: list[Any] = field(repr=False, default_factory=list)


#: Titles of the demo's analyses (one report section and one set of figure files each).
TITLES = ("Simulated session", "Seed paper Tab. 1", "Seed paper Tab. 1 (M1, M2, M3)")


def _session_note(caught: Any) -> bool:
    """A warning :func:`daq.load_session` raised for a note that ``Session.warnings`` already holds."""
    from daq.errors import SessionNoteWarning

    return issubclass(caught.category, SessionNoteWarning)


def run_demo(
    directory: str | Path = "contactrig-demo",
    *,
    n_boot: int = 2000,
    stream: TextIO | None = None,
    force: bool = False,
    compare: bool = True,
    progress: Any = None,
) -> DemoResult:
    """Run the demo into ``directory`` (created when missing; files of an earlier demo in it are refused unless
    ``force``). Progress goes to ``stream`` (None: stdout). ``compare``: run the boundary-element comparison;
    ``progress(done, total)``: called as its tasks finish (the command draws the bar: contactrig.cli.progress)."""
    import warnings

    from analysis.measured import MeasuredCurve
    from analysis.pipeline import analyse, analyse_tab1, simulate
    from analysis.report import output_directory, report_outputs, write_report
    from analysis.simulated_session import SimulatedRigBench
    from contactrig.core.files import refuse_existing
    from contactrig.core.scene import load_scene
    from contactrig.core.text import escape_terminal
    from contactrig.core.validation import check_int
    from daq import load_session
    from daq.acquire import acquire
    from daq.replay import replay_session
    from daq.sweep_file import save_sweep

    check_int("bootstrap", n_boot, 0, 1_000_000)
    out = output_directory(directory)
    refuse_existing([out / "sim.h5", out / "session.h5", *report_outputs(out, TITLES)], force=force)
    say = stream if stream is not None else sys.stdout
    timings: dict[str, float] = {}
    t_all = time.perf_counter()

    def step(name: str, t0: float) -> None:
        timings[name] = time.perf_counter() - t0
        print(f"  {name:<34} {timings[name]:6.2f} s", file=say, flush=True)

    print(f"contactrig demo → {out.resolve()}", file=say, flush=True)
    scene = load_scene(None)
    t0 = time.perf_counter()
    sweep_result, database = simulate(scene, None)
    sim_path = save_sweep(sweep_result, out / "sim.h5", force=force)
    step(f"simulate {len(sweep_result.models)} models", t0)

    t0 = time.perf_counter()
    session_path = out / "session.h5"
    acq = acquire(scene, session_path, bench=SimulatedRigBench(math.inf), yes=True, quiet=True, force=force, stream=say)
    step(f"acquire ({acq.blocks_done} blocks, {acq.status})", t0)

    t0 = time.perf_counter()
    rep = replay_session(session_path)
    step(f"replay ({'identical' if rep.identical else 'DIFFERENT'})", t0)

    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        session = load_session(session_path)
    curve = MeasuredCurve.from_session(session, source=str(session_path))
    sim_info = {"source": f"{sim_path} (simulated now)", "warnings": sweep_result.warnings,
                "provenance": sweep_result.provenance}  # fmt: skip
    measured_info = {
        "kind": "session",
        "path": str(session_path),
        "complete": session.complete,
        "status": session.status,
        "imported": session.imported,
        "start": session.start,
        "stop": session.stop,
        "warnings": list(session.warnings) + [str(w.message) for w in caught if not _session_note(w)],
    }
    analyses = [
        analyse(
            curve, sweep_result, scene, title=TITLES[0], n_boot=n_boot, measured_info=measured_info,
            sim_info=sim_info, database=database,
        ),
        analyse_tab1(sweep_result, scene, sim_info=sim_info, n_boot=n_boot, title=TITLES[1]),
        analyse_tab1(
            sweep_result, scene, series=["M1", "M2", "M3"], sim_info=sim_info, n_boot=n_boot, title=TITLES[2]
        ),
    ]  # fmt: skip
    step("fit session and Tab. 1", t0)

    t0 = time.perf_counter()
    analyses, ranking = _extras(analyses, scene, list(sweep_result.models), compare, progress)
    step("BEM reference and resistance model" if compare else "resistance model", t0)

    t0 = time.perf_counter()
    preamble = _preamble(sim_path, sweep_result, session_path, acq, rep, analyses, ranking, timings)
    report = write_report(analyses, out, title="contactrig demo", preamble=preamble, force=force)
    step("figures and report", t0)
    timings["total"] = time.perf_counter() - t_all
    print(f"  {'total':<34} {timings['total']:6.2f} s", file=say, flush=True)
    for a in analyses:
        print(escape_terminal(f"{a.title}: {_verdict(a)}"), file=say)
    if ranking is not None:
        from analysis.compare_models import favoured

        print(escape_terminal(favoured(ranking)), file=say)
    return DemoResult(
        directory=out,
        report=report,
        session=session_path,
        sim=sim_path,
        timings_s=timings,
        replay=rep.as_dict(),
        analyses=analyses,
    )


def _extras(
    analyses: list[Any], scene: Any, models: list[str], compare: bool, progress: Any = None
) -> tuple[list[Any], Any]:
    """The report's extras: the resistance model's sentence for every analysis and, with ``compare``, the
    boundary-element comparison of the scene's surface (one run: every analysis has the same scene) shown in the
    first analysis's section."""
    from analysis.pipeline import rank_against_bem, with_report_extras

    ranking = rank_against_bem(scene, models, progress=progress) if compare else None
    note = "" if compare else "not run (--no-compare-models)"
    out = [with_report_extras(analyses[0], ranking=ranking, ranking_note=note)]
    out += [with_report_extras(a) for a in analyses[1:]]
    return out, ranking


def _preamble(
    sim_path: Path, sweep_result: Any, session_path: Path, acq: Any, rep: Any, analyses: list[Any], ranking: Any,
    timings: dict[str, float],
) -> list[Any]:  # fmt: skip
    """The demo's summary at the top of the report (report blocks: what came from files is data)."""
    from analysis.report import Bullets, Code, Data, Para, Strong

    replay: Any = "every block reproduced identically"
    if not rep.identical:
        replay = ["DIFFERENCES: ", Data("; ".join(rep.differences[:5]))]
    items: list[Any] = [
        ["simulation: ", Code(sim_path.name), ", models ", Data(", ".join(sweep_result.models))],
        ["session: ", Code(session_path.name), f", {acq.blocks_done}/{acq.blocks_planned} blocks, status ",
         Data(acq.status)],
        ["replay: ", replay, f" ({rep.blocks_replayed} blocks, {rep.readings_replayed} readings)"],
        _magnitude_line(analyses[0], analyses[1]),
    ]  # fmt: skip
    blocks: list[Any] = [
        Para(
            "The demo ran the main job on the packaged default scene: rig simulation of every model, a session "
            "acquired on the simulated bench, replayed through the driver, fitted; then the seed paper's Tab. 1."
        ),
        Bullets(tuple(items)),
    ]
    if ranking is not None:
        from analysis.compare_models import favoured

        blocks.append(Para(["Which contact model the boundary-element reference favours: ", Strong(favoured(ranking)),
                            " (details and figure in the first section's contact-area part)."]))  # fmt: skip
    blocks += [Para("Verdicts:"), Bullets(tuple(f"{a.title}: {_verdict(a)}" for a in analyses))]
    blocks += [Para("Timings before figures: " + ", ".join(f"{k} {v:.2f} s" for k, v in timings.items()))]
    return blocks


def _verdict(a: Any) -> str:
    """The comparison's statement, or why there is none."""
    return a.comparison.statement if a.comparison is not None else "; ".join(a.left_out)


def _magnitude_line(session: Any, tab1: Any) -> str:
    """One bullet: the simulated session's mean R at the first and last weight against Tab. 1's [mΩ]."""
    c = session.circuit
    s, t = session.curve.mean_ohm * 1e3, tab1.curve.mean_ohm * 1e3
    return (
        f"magnitude: simulated session {s[0]:.3g} → {s[-1]:.3g} mΩ over {session.curve.weight_kg[0]:g}–"
        f"{session.curve.weight_kg[-1]:g} kg, Tab. 1 {t[0]:.3g} → {t[-1]:.3g} mΩ (scene [circuit]: "
        f"ζ = {c.resistivity_ohm_m:g} Ω·m, R_s = {c.series_resistance_ohm * 1e3:g} mΩ, fitted to Tab. 1)"
    )
