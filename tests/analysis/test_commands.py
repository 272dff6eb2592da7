"""The analysis subcommands end to end: circuit, fit --json, figures, report (incomplete-session banner), demo."""

import json

import numpy as np
import pytest

from contactrig.cli.main import main

W = np.array([5.0, 10.0, 15.0, 20.0])


def _sweep_file(path, weights=W, scene=None):
    """A toy sweep file, fingerprinted as a simulation of ``scene`` (the packaged default scene when None, which is
    what a session without a recorded scene is analysed with)."""
    from contactrig.core.scene import load_scene
    from daq.sweep_file import config_fingerprint, save_sweep
    from sims.config import SimConfig
    from sims.rig import ModelSweep, SweepResult

    models = {}
    for name, expo in (("greenwood_tripp", 0.8), ("hertz", 2 / 3)):
        n = weights.size
        models[name] = ModelSweep(
            name=name, weight_kg=weights, contact_area_m2=1e-7 * (weights / 5) ** expo,
            min_separation_m=np.full(n, 1e-6),
            force_n=weights * 9.80665, peak_pressure_pa=np.full(n, 1e6), contact_width_m=np.full(n, 1e-3),
            n_nodes=np.full(n, 10), converged=np.ones(n, bool),
        )  # fmt: skip
    fingerprint = config_fingerprint(SimConfig.from_scene(scene if scene is not None else load_scene()))
    provenance = {"software_version": "test", "fingerprint": fingerprint}
    return save_sweep(SweepResult(models=models, warnings=[], provenance=provenance), path)


def _incomplete_session(path):
    from tests.analysis.sessions import model_resistance, write_session

    rng = np.random.default_rng(0)
    write_session(path, ((w, rep, model_resistance(w, rng, 0.01)) for rep in range(3) for w in W))
    return path


def test_circuit_prints_the_paper_example(capsys):
    assert main(["circuit", "--paper"]) == 0
    out = capsys.readouterr()
    assert "120 mA" in out.out and "13.42 nV" in out.out
    assert "105" in out.err  # the 6221 cannot source it
    # the default scene: its own ζ (fitted to Tab. 1), same 120 mA; U_c scales with ζ: 13.42 nV · ζ / 1e-7
    assert main(["circuit", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    i = d["inputs"]
    r_t = i["resistivity_ohm_m"] * i["contact_height_m"] / i["contact_area_m2"]
    assert i["resistivity_ohm_m"] != 1e-7
    assert d["result"]["contact_voltage_v"] == pytest.approx(r_t * 12.0 / (100.0 + r_t), rel=1e-12)


def test_circuit_json_and_bad_value(capsys):
    assert main(["circuit", "--current", "0.1", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["result"]["current_a"] == 0.1
    assert main(["circuit", "--area", "-1"]) == 2
    assert "[circuit] contact_area_m2" in capsys.readouterr().err


def test_fit_json_on_an_incomplete_session(tmp_path, capsys):
    sim = _sweep_file(tmp_path / "sim.h5")
    session = _incomplete_session(tmp_path / "inc.h5")
    assert main(["fit", str(session), "--sim", str(sim), "--json", "--bootstrap", "200"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert set(d["models"]) == {"greenwood_tripp", "hertz"}
    assert d["ranking"][0] == "greenwood_tripp"
    for group, key in (
        ("estimate", "R_series_ohm"), ("estimate", "R_series_se"), ("estimate", "scale"), ("estimate", "scale_se"),
        ("goodness", "aic"), ("goodness", "rmse_ohm"),
    ):  # fmt: skip
        assert isinstance(d["models"]["hertz"][group][key], float)
    assert d["measured"]["complete"] is False
    gt = d["models"]["greenwood_tripp"]["estimate"]
    assert abs(gt["scale"] - 1e-7) < 5 * gt["scale_se"]
    # what the text output shows is in the JSON too: intervals by both methods, goodness of fit, solver diagnostics
    fit = d["models"]["greenwood_tripp"]
    assert fit["intervals"]["bootstrap"]["n_boot"] == 200 and len(fit["intervals"]["t"]["R_series_ohm"]) == 2
    assert fit["goodness"]["reference"] and fit["diagnostics"]["nfev"] >= 1 and "delta_aic" in d


def test_report_has_banner_tables_and_figures(tmp_path, capsys):
    sim = _sweep_file(tmp_path / "sim.h5")
    session = _incomplete_session(tmp_path / "inc.h5")
    out = tmp_path / "rep"
    assert main(["report", str(session), "--sim", str(sim), "-o", str(out), "--bootstrap", "100"]) == 0
    text = (out / "report.md").read_text()
    assert text.count("INCOMPLETE SESSION") >= 1
    assert "| weight [kg] |" in text and "ΔAIC" in text and "Provenance" in text
    # the toy simulation's fingerprint records the default scene's surfaces: the BEM comparison runs by default
    assert "BEM favours" in text and "model_ranking.png" in text and "BEM favours" in capsys.readouterr().out
    assert (out / "report.html").read_text().count("data:image/png;base64,") == text.count("![")
    for ref in [line.split("](")[1].split(")")[0] for line in text.splitlines() if line.startswith("![")]:
        assert (out / ref).is_file()


def test_figures_command_writes_png_and_pdf(tmp_path, capsys):
    sim = _sweep_file(tmp_path / "sim.h5")
    session = _incomplete_session(tmp_path / "inc.h5")
    out = tmp_path / "figs"
    rc = main(["figures", str(session), "--sim", str(sim), "-o", str(out), "--format", "pdf", "--bootstrap", "0"])
    assert rc == 0
    names = {p.name for p in out.iterdir()}
    assert {"fig09_measured.png", "fig09_measured.pdf", "fig12_normalised.png", "fit_residuals.pdf"} <= names
    assert "fig02_database: not drawn" in capsys.readouterr().err


def _run(entry, argv):
    """The exit code of the ``contactrig`` entry point, whether it returns it or argparse exits with it."""
    try:
        return entry(argv)
    except SystemExit as exc:
        return exc.code


def _empty_session(path):
    from daq.records import now_iso
    from daq.session_file import SessionFile

    with SessionFile.create(path) as sf:
        sf.write_start({"started": now_iso(), "operator": "tester"}, "")
    return path


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["fit", "{tmp}/nope.h5", "--sim", "{sim}"], "nope.h5"),
        (["fit", "{garbage}", "--sim", "{sim}"], "garbage.h5"),
        (["fit", "{session}", "--sim", "{tmp}/nope-sim.h5"], "nope-sim.h5"),
        (["fit", "{session}", "--sim", "{session}"], "not a contactrig sweep file"),
        (["fit", "{session}", "--sim", "{garbage}"], "garbage.h5"),
        (["fit", "{sim}", "--sim", "{sim}"], "not a contactrig session"),
        (["fit", "{empty}", "--sim", "{sim}"], "no measurement block"),
        (["fit", "{empty}"], "incomplete session"),
        (["fit", "{session}", "--sim", "{sim}", "--bootstrap", "-5"], "n_boot = -5"),
        (["fit", "{session}", "--sim", "{sim}", "--seed", "-1"], "seed = -1"),
        (["fit", "{session}", "--sim", "{sim}", "--models", "nomodel"], "nomodel"),
        (["fit", "{session}", "--sim", "{narrow}"], "outside the simulated range"),
        (["figures", "{session}", "--sim", "{sim}", "-o", "{garbage}"], "a file of that name exists"),
        (["report", "{tmp}/nope.h5", "--sim", "{sim}", "-o", "{tmp}/rep"], "nope.h5"),
        (["report", "{session}", "--sim", "{sim}", "-o", "{garbage}"], "a file of that name exists"),
        (["demo", "-o", "{garbage}"], "a file of that name exists"),
        (["demo", "-o", "{tmp}/demo", "--bootstrap", "-1"], "bootstrap = -1"),
        (["circuit", "--area", "nan"], "[circuit] contact_area_m2"),
        (["circuit", "--resistivity", "0"], "[circuit] resistivity_ohm_m"),
        (["circuit", "--current", "-0.1"], "current_a"),
        (["circuit", "--scene", "{tmp}/nope.toml"], "nope.toml"),
    ],
)
def test_bad_input_is_a_one_line_error(tmp_path, capsys, argv, expected):
    files = {
        "tmp": str(tmp_path),
        "sim": str(_sweep_file(tmp_path / "sim.h5")),
        "session": str(_incomplete_session(tmp_path / "inc.h5")),
        "empty": str(_empty_session(tmp_path / "empty.h5")),
        "garbage": str(tmp_path / "garbage.h5"),
        "narrow": str(_sweep_file(tmp_path / "narrow.h5", W[:-1])),
    }
    (tmp_path / "garbage.h5").write_text("not HDF5\n")
    capsys.readouterr()
    rc = _run(main, [a.format(**files) for a in argv])
    err = capsys.readouterr().err.strip()
    assert rc == 2
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert expected in err, err
    assert not (tmp_path / "demo").exists()  # rejected before any work


@pytest.mark.slow
def test_demo_end_to_end(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "-o", str(out), "--bootstrap", "100"]) == 0
    printed = capsys.readouterr().out
    assert "report:" in printed
    text = (out / "report.md").read_text()
    assert "Simulated session" in text and "Seed paper Tab. 1" in text
    assert (out / "session.h5").is_file() and (out / "sim.h5").is_file()
    assert "every block reproduced identically" in text
    assert "BEM favours" in text and "BEM favours" in printed and (out / "report.html").is_file()
    assert text.count("#### Resistance model") == 3 and "this session is R = R_s + σ_f/A" in text
    assert text.count("model_ranking.png") == 1  # one comparison (one scene), in the first section
