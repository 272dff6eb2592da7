"""Issue #11, "No silent wrong answer" (analysis side): files are never lost, results are never silently mixed up,
and partial sessions are analysed as far as the data allow — each through the real ``contactrig`` entry point with
the mistakes a new user makes. Every refusal is one line, exit code 2, no traceback, input files unchanged."""

from __future__ import annotations

import hashlib
import itertools
import json
import math

import h5py
import numpy as np
import pytest

from contactrig.cli.main import main

W = np.array([5.0, 10.0, 15.0, 20.0])


# ---- helpers --------------------------------------------------------------------------------------------------
def _run(argv):
    try:
        return main([str(a) for a in argv])
    except SystemExit as exc:  # argparse usage errors exit with their code
        return exc.code


def _state(path):
    """Content hash and mtime of a file: what 'unchanged' means."""
    return hashlib.sha256(path.read_bytes()).hexdigest(), path.stat().st_mtime_ns


def _one_line_error(capsys, rc):
    err = capsys.readouterr().err.strip()
    assert rc == 2, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err and "[Errno" not in err, err
    return err


def _scene_text(clearance="40e-6"):
    from contactrig.core.scene import default_scene_text

    text = default_scene_text()
    assert "clearance_m = 40e-6" in text
    return text.replace("clearance_m = 40e-6", f"clearance_m = {clearance}")


def _scene(clearance="40e-6"):
    from contactrig.core.scene import parse_scene

    return parse_scene(_scene_text(clearance), "test scene")


def _sweep_file(path, weights=W, scene=None, provenance_extra=None, peak_pa=1e6, warnings=()):
    """A toy sweep (A ∝ W^0.8 and W^(2/3)) fingerprinted as a simulation of ``scene`` (the test scene when None)."""
    from tests.analysis.sessions import write_toy_sweep

    return write_toy_sweep(path, weights, scene=scene or _scene(), peak_pa=peak_pa, warnings=warnings,
                           provenance_extra=provenance_extra)  # fmt: skip


def _session(path, weights=W, repeats=3, scene_text="", last_repeats=None, seed=0):
    """A session file (no stop record) with ``repeats`` blocks per weight, R = 0.2 mΩ + 5e-10/A(W) with 1 % scatter;
    the last weight gets ``last_repeats`` blocks when given (a partial last weight)."""
    from tests.analysis.sessions import model_resistance, write_session

    rng = np.random.default_rng(seed)
    last = len(weights) - 1
    blocks = (
        (w, rep, model_resistance(w, rng, 0.01))
        for rep in range(repeats)
        for i, w in enumerate(weights)
        if not (last_repeats is not None and i == last and rep >= last_repeats)
    )
    write_session(path, blocks, scene_text=scene_text)
    return path


def _shown(markdown):
    """What a Markdown renderer shows: the backslash escapes of text from files resolved, entities decoded."""
    import html
    import re

    return html.unescape(re.sub(r"\\([!-/:-@\[-`{-~])", r"\1", markdown))


def _leftovers(root):
    return [p for p in root.rglob("*") if p.name.endswith((".partial", ".part", ".tmp"))]


# ---- Files are never lost --------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", "--weights", "5,10", "--models", "greenwood_tripp", "-o", "{target}"],
        ["database", "--models", "greenwood_tripp", "-o", "{target}"],
        ["database", "--models", "greenwood_tripp", "-o", "{tmp}/new-db.h5", "--plot", "{target}"],
    ],
)
def test_an_existing_file_is_never_replaced_without_force(tmp_path, capsys, argv):
    measured = _session(tmp_path / "measured.h5")  # a measured session: the worst file to lose
    before = _state(measured)
    rc = _run([a.format(target=measured, tmp=tmp_path) for a in argv])
    err = _one_line_error(capsys, rc)
    assert err.endswith(f"{measured} exists; use --force to overwrite it"), err
    assert _state(measured) == before
    assert not (tmp_path / "new-db.h5").exists()  # refused before any work: nothing else written either


def test_demo_refuses_a_folder_holding_an_earlier_session_and_force_replaces_it(tmp_path, capsys):
    out = tmp_path / "demo"
    out.mkdir()
    measured = _session(out / "session.h5")
    before = _state(measured)
    err = _one_line_error(capsys, _run(["demo", "-o", out, "--bootstrap", "0"]))
    assert f"{measured} exists; use --force to overwrite it" in err
    assert _state(measured) == before and sorted(p.name for p in out.iterdir()) == ["session.h5"]


def test_the_refusal_reads_like_acquire_and_import(tmp_path, capsys):
    # the same sentence as the session writer's own refusal (daq.session_file), which acquire and import use
    from daq.session_file import SessionFile

    existing = _session(tmp_path / "s.h5")
    with pytest.raises(FileExistsError) as caught:
        SessionFile.create(existing)
    assert str(caught.value).startswith(f"{existing} exists; use --force to overwrite it")
    err = _one_line_error(capsys, _run(["simulate", "--weights", "5,10", "-o", existing]))
    assert f"{existing} exists; use --force to overwrite it" in err
    err = _one_line_error(capsys, _run(["import", "--tab1", "-o", existing]))
    assert f"{existing} exists; use --force to overwrite it" in err


def test_force_replaces_and_the_write_is_atomic(tmp_path, capsys):
    from daq.sweep_file import load_sweep

    target = tmp_path / "sim.h5"
    target.write_text("an older file\n")
    argv = ["simulate", "--weights", "5,10", "--models", "greenwood_tripp", "-o", target, "--force"]
    assert _run(argv) == 0
    back = load_sweep(target)
    assert list(back.models) == ["greenwood_tripp"] and back.models["greenwood_tripp"].weight_kg.tolist() == [5, 10]
    assert _leftovers(tmp_path) == []


def test_simulate_into_a_folder_is_a_one_line_error_and_leaves_nothing(tmp_path, capsys):
    folder = tmp_path / "somedir"
    folder.mkdir()
    err = _one_line_error(capsys, _run(["simulate", "--weights", "5,10", "-o", folder]))
    assert str(folder) in err and "folder" in err
    assert _leftovers(tmp_path) == [] and list(folder.iterdir()) == []


def test_a_failed_write_leaves_neither_a_temporary_file_nor_a_half_written_target(tmp_path):
    from contactrig.core.files import atomic_write

    target = tmp_path / "out.h5"
    target.write_text("old contents\n")
    with pytest.raises(RuntimeError, match="disk full"), atomic_write(target, force=True) as tmp:
        tmp.write_text("half of the new contents")
        raise RuntimeError("disk full")
    assert target.read_text() == "old contents\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.h5"]


def test_output_folders_are_created_and_a_file_in_their_place_is_refused(tmp_path, capsys):
    sim = _sweep_file(tmp_path / "sim.h5")
    session = _session(tmp_path / "s.h5")
    nested = tmp_path / "new" / "deeper"
    assert _run(["report", session, "--sim", sim, "-o", nested, "--bootstrap", "0", "--no-compare-models"]) == 0
    assert (nested / "report.md").is_file()
    # the same command again would replace the report: refused, unchanged
    before = _state(nested / "report.md")
    capsys.readouterr()
    err = _one_line_error(capsys, _run(["report", session, "--sim", sim, "-o", nested, "--bootstrap", "0"]))
    assert "report.md exists; use --force to overwrite it" in err and _state(nested / "report.md") == before
    err = _one_line_error(capsys, _run(["figures", session, "--sim", sim, "-o", sim, "--bootstrap", "0"]))
    assert "a file of that name exists" in err
    assert _leftovers(tmp_path) == []


# ---- Results are never silently mixed up -----------------------------------------------------------------------
def test_a_simulation_of_another_scene_is_refused_naming_what_differs(tmp_path, capsys):
    session = _session(tmp_path / "s.h5", scene_text=_scene_text("20e-6"))
    sim = _sweep_file(tmp_path / "other.h5", scene=_scene("25e-6"))
    states = [_state(session), _state(sim)]
    for command in (["fit"], ["figures", "-o", tmp_path / "figs"], ["report", "-o", tmp_path / "rep"]):
        err = _one_line_error(capsys, _run([command[0], session, "--sim", sim, *command[1:], "--bootstrap", "0"]))
        assert "[rig] clearance_m differs: session 2e-05, simulation 2.5e-05" in err, err
        assert "--allow-mismatch" in err
    assert [_state(session), _state(sim)] == states
    assert not (tmp_path / "figs" / "fig09_measured.png").exists() and not (tmp_path / "rep" / "report.md").exists()
    # the same scene passes
    same = _sweep_file(tmp_path / "same.h5", scene=_scene("20e-6"))
    assert _run(["fit", session, "--sim", same, "--bootstrap", "0"]) == 0


def test_allow_mismatch_goes_on_and_the_report_records_it(tmp_path, capsys):
    session = _session(tmp_path / "s.h5", scene_text=_scene_text("20e-6"))
    sim = _sweep_file(tmp_path / "other.h5", scene=_scene("25e-6"))
    argv = ["report", session, "--sim", sim, "-o", tmp_path / "rep", "--bootstrap", "0", "--allow-mismatch",
            "--no-compare-models"]  # fmt: skip
    assert _run(argv) == 0
    assert "scene mismatch allowed" in capsys.readouterr().err
    text = _shown((tmp_path / "rep" / "report.md").read_text())
    assert "SCENE MISMATCH ALLOWED (--allow-mismatch)" in text and "[rig] clearance_m differs" in text
    assert _run(["fit", session, "--sim", sim, "--json", "--bootstrap", "0", "--allow-mismatch"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["scene_mismatch"]["allowed"] is True and any(
        "clearance_m" in x for x in d["scene_mismatch"]["differences"]
    )


def test_a_simulation_without_a_fingerprint_cannot_be_checked_and_is_refused(tmp_path, capsys):
    from daq.sweep_file import save_sweep
    from sims.rig import ModelSweep, SweepResult

    n = W.size
    m = ModelSweep(
        name="hertz", weight_kg=W, contact_area_m2=1e-7 * W, min_separation_m=np.ones(n), force_n=W,
        peak_pressure_pa=np.ones(n), contact_width_m=np.ones(n), n_nodes=np.ones(n, int), converged=np.ones(n, bool),
    )  # fmt: skip
    sim = save_sweep(SweepResult(models={"hertz": m}, warnings=[], provenance={}), tmp_path / "old.h5")
    err = _one_line_error(capsys, _run(["fit", _session(tmp_path / "s.h5"), "--sim", sim, "--bootstrap", "0"]))
    assert "records no fingerprint" in err


def test_sweep_and_database_files_record_their_fingerprint(tmp_path, capsys):
    from daq.sweep_file import config_fingerprint
    from sims.config import SimConfig

    assert _run(["simulate", "--weights", "5,10", "--models", "hertz", "-o", tmp_path / "sim.h5"]) == 0
    assert _run(["database", "--models", "hertz", "-o", tmp_path / "db.h5"]) == 0
    expected = config_fingerprint(SimConfig.from_scene(_scene()))["tables"]
    with h5py.File(tmp_path / "sim.h5") as f:
        sweep_fp = json.loads(f["fingerprint_json"][()])
    with h5py.File(tmp_path / "db.h5") as f:
        db_fp = json.loads(f.attrs["fingerprint"])
    assert {k: v["sha256"] for k, v in sweep_fp["tables"].items()} == {k: v["sha256"] for k, v in expected.items()}
    for table in ("materials", "surfaces", "database"):
        assert db_fp["tables"][table]["sha256"] == expected[table]["sha256"]
    assert sweep_fp["tables"]["rig"]["values"]["clearance_m"] == 40e-6


def test_model_validity_warnings_travel_into_the_sweep_file_the_fit_and_the_report(tmp_path, capsys):
    # an elastic-only model at plasticity index 1.8, nominal pressure 1 MPa above a hardness of 0.5 MPa, and the
    # solver's own σ·R/b² warning: each must reach every output
    extra = {"database": {"plasticity_index": 1.8, "materials": {"H_pa": 5e5}}}
    alpha = "weight 20 kg: roughness parameter σ·R_eff/b² = 3.4 < 5: bulk elastic deformation …"
    sim = _sweep_file(tmp_path / "sim.h5", provenance_extra=extra, peak_pa=1e6, warnings=[alpha])
    with h5py.File(sim) as f:
        stored = [w.decode() if isinstance(w, bytes) else w for w in f["validity_warnings"][()]]
    assert any("Greenwood–Tripp: plasticity index ψ = 1.8 > 1" in w for w in stored), stored
    assert any("exceeds the softer body's hardness H = 0.5 MPa" in w for w in stored), stored
    session = _session(tmp_path / "s.h5")
    assert _run(["fit", session, "--sim", sim, "--bootstrap", "0"]) == 0
    err = capsys.readouterr().err
    assert "plasticity index ψ = 1.8" in err and "hardness" in err and "σ·R_eff/b²" in err
    assert _run(["fit", session, "--sim", sim, "--bootstrap", "0", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert any("plasticity index" in w for w in d["warnings"]) and alpha in d["warnings"]
    assert (
        _run(["report", session, "--sim", sim, "-o", tmp_path / "rep", "--bootstrap", "0", "--no-compare-models"]) == 0
    )
    text = _shown((tmp_path / "rep" / "report.md").read_text())
    assert "plasticity index ψ = 1.8" in text and "hardness" in text and "σ·R_eff/b²" in text


def test_an_unphysical_fit_is_flagged_and_never_silently_best():
    from analysis.fit import compare_models
    from analysis.measured import MeasuredCurve

    rng = np.random.default_rng(3)
    h, s = 1e-5, 1e-4
    w = np.linspace(5.0, 26.0, 8)
    a_neg = 1e-7 * (w / 5.0) ** 0.8  # the data follow this shape with R_s = −2 mΩ: a perfect, unphysical fit
    a_pos = 1e-7 * (w / 5.0) ** 2.0  # a much worse shape whose R_s comes out positive
    truth = -2e-3 + s * h / a_neg
    curve = MeasuredCurve(w, truth[:, None] * (1 + 0.01 * rng.normal(size=(8, 6))), paired=True)
    cmp = compare_models(curve, {"greenwood_tripp": a_neg, "hertz": a_pos}, height_m=h, n_boot=0)
    neg, pos = cmp.fits["greenwood_tripp"], cmp.fits["hertz"]
    assert neg.goodness.aic < pos.goodness.aic  # by AIC alone it would be best
    assert neg.intervals.t.R_series_ohm[1] < 0 and not neg.physical and pos.physical
    assert "significantly below zero" in neg.unphysical[0]
    assert cmp.ranking == ("hertz", "greenwood_tripp") and cmp.best.model == "hertz"
    assert "UNPHYSICAL" in cmp.statement and "Greenwood–Tripp" in cmp.statement
    assert cmp.as_dict()["models"]["greenwood_tripp"]["unphysical"]


def test_fit_tab1_with_holm_flags_the_negative_series_resistance(capsys):
    # Holm's −0.5 log slope cannot follow Tab. 1's −0.92: R_s comes out ≈ −4 mΩ for every model. With the 3
    # independent series (M4–M6 are copies) the t-interval has 2 dof and reaches above zero, so the fits are not
    # called unphysical, but every one carries the warning in the JSON.
    assert _run(["fit", "tab1", "--conversion", "holm", "--bootstrap", "0", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["n_repeats"] == 3 and d["series_notes"]
    for fit in d["models"].values():
        assert fit["estimate"]["R_series_ohm"] < 0
        assert any("negative series resistance" in w for w in fit["diagnostics"]["warnings"])


def test_bootstrap_intervals_with_three_series_are_not_available_and_say_why():
    from analysis.fit import fit_model
    from analysis.measured import MeasuredCurve

    # independent count: multisets of 3 out of 3 series
    distinct = len(list(itertools.combinations_with_replacement(range(3), 3)))
    assert distinct == 10
    rng = np.random.default_rng(5)
    area = 1e-7 * (W / 5) ** 0.8
    truth = 1e-4 + 4e-7 * 1e-5 / area

    def fit(r):
        curve = MeasuredCurve(W, truth[:, None] * (1 + 0.05 * rng.normal(size=(W.size, r))), paired=True)
        return fit_model(curve, area, height_m=1e-5, n_boot=500).intervals.bootstrap

    b3 = fit(3)
    assert not b3.available and all(math.isnan(x) for x in (*b3.R_series_ohm, *b3.scale))
    assert b3.note.startswith("not available with 3 series") and f"only {distinct} distinct resamples" in b3.note
    b6 = fit(6)  # 462 distinct resamples, 1/6^5 of them degenerate
    assert b6.available and b6.note == "" and all(math.isfinite(x) for x in (*b6.R_series_ohm, *b6.scale))
    assert b6.R_series_ohm[0] < b6.R_series_ohm[1]


def test_the_demo_report_says_not_available_instead_of_absurd_bounds(tmp_path, capsys):
    from analysis.pipeline import analyse_tab1

    a = analyse_tab1(series=["M1", "M2", "M3"], n_boot=300)
    from analysis.report import write_report

    text = write_report([a], tmp_path / "rep").read_text()
    assert "not available with 3 series" in text and "e+15" not in text and "inf" not in text.lower().split("info")[0]


# ---- Sessions (analysis side) ----------------------------------------------------------------------------------
def test_a_partial_last_weight_is_left_out_of_the_fit_and_said_so(tmp_path, capsys):
    weights = np.array([5.0, 10.0, 15.0, 20.0, 25.0])
    sim = _sweep_file(tmp_path / "sim.h5", weights=weights)
    session = _session(tmp_path / "partial.h5", weights=weights, last_repeats=1)
    before = _state(session)
    assert (
        _run(["report", session, "--sim", sim, "-o", tmp_path / "rep", "--bootstrap", "0", "--no-compare-models"]) == 0
    )
    err = capsys.readouterr().err
    assert "left out: 25 kg has 1 repeat" in err
    text = (tmp_path / "rep" / "report.md").read_text()
    assert "25 kg has 1 repeat: left out of the fit" in text and "| 25 | 1 |" in text
    assert _run(["figures", session, "--sim", sim, "-o", tmp_path / "figs", "--bootstrap", "0"]) == 0
    assert (tmp_path / "figs" / "fig09_measured.png").is_file() and (tmp_path / "figs" / "fit_residuals.png").is_file()
    capsys.readouterr()
    assert _run(["fit", session, "--sim", sim, "--bootstrap", "0", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["n_weights"] == 4 and any("25 kg" in n for n in d["left_out"])
    assert _state(session) == before


def test_two_weights_draw_fig9_and_say_there_is_no_fit(tmp_path, capsys):
    sim = _sweep_file(tmp_path / "sim.h5")
    session = _session(tmp_path / "two.h5", weights=W[:2])
    assert _run(["figures", session, "--sim", sim, "-o", tmp_path / "figs", "--bootstrap", "0"]) == 0
    err = capsys.readouterr().err
    assert (tmp_path / "figs" / "fig09_measured.png").is_file() and not (
        tmp_path / "figs" / "fit_residuals.png"
    ).exists()
    assert "fit_residuals: not drawn" in err and "no fit: 2 weight(s) usable" in err
    assert (
        _run(["report", session, "--sim", sim, "-o", tmp_path / "rep", "--bootstrap", "0", "--no-compare-models"]) == 0
    )
    text = (tmp_path / "rep" / "report.md").read_text()
    assert "No fit: 2 weight(s) usable" in text and "![Measured resistance" in text
    capsys.readouterr()
    err = _one_line_error(capsys, _run(["fit", session, "--sim", sim, "--bootstrap", "0"]))
    assert "no fit: 2 weight(s) usable" in err


@pytest.mark.parametrize(("ohm", "unit", "factor"), [(3e-6, "µΩ", 1e6), (4e-3, "mΩ", 1e3), (2.5, "Ω", 1.0)])
def test_resistance_prefix_is_chosen_from_the_data_in_figures_and_report(tmp_path, ohm, unit, factor):
    from analysis import figures as F
    from analysis.measured import MeasuredCurve
    from analysis.resistance import resistance_unit

    assert resistance_unit(np.array([ohm, 2 * ohm])) == (factor, unit)
    rng = np.random.default_rng(1)
    curve = MeasuredCurve(W, ohm * (W[:, None] / 5) ** -0.8 * (1 + 0.02 * rng.normal(size=(4, 3))), paired=True)
    ax = F.figure_measured(curve).axes[0]
    assert f"[{unit}]" in ax.get_ylabel()
    assert np.allclose(ax.containers[0].lines[0].get_ydata(), curve.mean_ohm * factor)
    from types import SimpleNamespace

    from analysis.pipeline import analyse
    from analysis.report import write_report
    from daq.sweep_file import config_fingerprint
    from sims.config import SimConfig

    scene = _scene()
    sweep = SimpleNamespace(
        models={"hertz": SimpleNamespace(weight_kg=W, contact_area_m2=1e-7 * (W / 5) ** 0.8)}, warnings=[],
        provenance={"fingerprint": config_fingerprint(SimConfig.from_scene(scene))},
    )  # fmt: skip
    text = write_report([analyse(curve, sweep, scene, title="units", n_boot=0)], tmp_path / "rep").read_text()
    assert f"mean R [{unit}]" in text and f"R_s ± SE [{unit}]" in text


def test_the_verdict_names_models_by_their_labels():
    from analysis.fit import compare_models
    from analysis.measured import MeasuredCurve
    from sims.models import model_label

    rng = np.random.default_rng(2)
    area = 1e-7 * (W / 5) ** 0.8
    curve = MeasuredCurve(W, (1e-4 + 4e-12 / area)[:, None] * (1 + 0.05 * rng.normal(size=(4, 6))), paired=True)
    cmp = compare_models(curve, {"greenwood_tripp": area, "pasaribu_schipper": area**0.9}, height_m=1e-5, n_boot=50)
    for key in ("greenwood_tripp", "pasaribu_schipper"):
        assert model_label(key) in cmp.statement and key not in cmp.statement
