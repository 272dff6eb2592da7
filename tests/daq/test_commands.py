"""``contactrig acquire --sim``, ``replay`` and ``import`` through the dispatcher, and a killed ``--sim`` process."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import warnings

import numpy as np
import pytest

from contactrig.cli.main import main
from daq.session_file import load_session
from daq.table_import import tab1_path

from .conftest import ROOT, sim_scene_text

# Tab. 1 of the seed paper, the "Avg" column [mΩ], typed from the paper (not shipped in tab1.csv)
TAB1_AVG_MOHM = [8.0913, 7.5237, 5.9488, 4.7583, 3.9734, 3.4037, 2.2916, 1.8456]
TAB1_WEIGHTS_KG = [5.44, 7.44, 10.526, 13.616, 16.708, 19.795, 22.882, 25.966]


def test_import_tab1_reproduces_the_papers_averages(tmp_path):
    out = tmp_path / "tab1.h5"
    assert main(["import", "--tab1", "-o", str(out)]) == 0
    s = load_session(out)
    assert s.imported and s.complete and s.start["source"]["unit"] == "mohm"
    # issue 26 item 13: the paper's data were not measured by whoever imports them
    from contactrig.core.provenance import login_name

    assert s.start["operator"] == "" and s.start["operator_source"] == "unknown"
    assert "Raffai, Maršálek & Nečasová" in s.start["measured_by"] and s.start["imported_by"] == login_name()
    assert len(s.summary) == 48 and set(s.summary.repeat) == set(range(1, 7))
    avg = s.summary.groupby("weight_kg").mean_ohm.mean()
    assert list(avg.index) == TAB1_WEIGHTS_KG
    np.testing.assert_allclose(avg.to_numpy() * 1e3, TAB1_AVG_MOHM, atol=5.1e-5)  # the paper rounds to 1e-4 mΩ
    assert s.summary.n.eq(1).all() and s.summary.sd_ohm.isna().all()  # one value per repeat: SD undefined


def test_import_units_and_force(tmp_path):
    table = tmp_path / "t.csv"
    table.write_text("weight_kg,A,B\n1.0,0.15,0.25\n2.0,0.1,0.125\n")  # plausible in µΩ and in Ω
    out = tmp_path / "t.h5"
    assert main(["import", str(table), "--unit", "uohm", "-o", str(out)]) == 0
    s = load_session(out)
    np.testing.assert_allclose(s.summary.mean_ohm, [1.5e-7, 2.5e-7, 1.0e-7, 1.25e-7], rtol=1e-15)
    assert main(["import", str(table), "--unit", "ohm", "-o", str(out)]) == 2  # exists, no --force
    assert main(["import", str(table), "--unit", "ohm", "-o", str(out), "--force"]) == 0
    assert load_session(out).summary.mean_ohm.iloc[0] == 0.15


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("weight_kg,M1,Avg\n1,2,2\n", "looks like an average"),
        ("weight_kg,M1,M2\n1,2,\n", "row 2, column 'M2'"),
        ("weight_kg,M1\n1,abc\n", "expected a number"),
        ("weight_kg,M1\n-1,2\n", "weight in [0, 10000] kg"),
        ("weight_kg,M1\n1,inf\n", "finite"),
        ("weight_kg\n1\n", "repeat column"),
        ("weight_kg,M1\n", "at least one row"),
    ],
)
def test_import_rejects_bad_tables_with_one_message(tmp_path, capsys, text, message):
    table = tmp_path / "bad.csv"
    table.write_text(text)
    assert main(["import", str(table), "--unit", "mohm", "-o", str(tmp_path / "o.h5")]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not (tmp_path / "o.h5").exists()


def test_import_needs_a_unit(tmp_path, capsys):
    assert main(["import", str(tab1_path()), "-o", str(tmp_path / "o.h5")]) == 2
    assert "--unit is required" in capsys.readouterr().err


def _scene(tmp_path, repeat_sd=None):
    path = tmp_path / "scene.toml"
    path.write_text(sim_scene_text(repeat_sd))
    return path


def _sim_session(tmp_path, capsys, repeat_sd):
    out = tmp_path / "sim.h5"
    code = main(["acquire", str(_scene(tmp_path, repeat_sd)), "--sim", "--yes", "--sim-speed", "inf", "-o", str(out)])
    assert code == 0, capsys.readouterr().err
    s = load_session(out)
    sim = s.start["simulation"]
    assert s.start["sim"] and sim["model"] == "greenwood_tripp" and sim["time_scale"] == 0.0
    import tomllib

    table = tomllib.loads(sim_scene_text())["circuit"]
    c = sim["circuit"]
    assert all(c[k] == table[k] for k in ("resistivity_ohm_m", "contact_height_m", "series_resistance_ohm"))
    # the physical model by hand from the recorded areas and clean-metal terms: contact term ζ·h/A + R_clean
    clean = np.sum([np.array(v) for v in sim["clean_terms_ohm"].values()], axis=0)
    assert set(sim["clean_terms_ohm"]) == {"barber", "macro"} and np.all(clean > 0)
    contact = c["resistivity_ohm_m"] * c["contact_height_m"] / np.array(sim["contact_area_m2"]) + clean
    return out, s, c["series_resistance_ohm"], contact


def test_simulated_session_follows_eq23_from_the_rig(tmp_path, capsys):
    """--sim without re-seating scatter: mean R at each weight = R_s + ζ·h/A(W) + R_clean(W) within the noise."""
    out, s, r_s, contact = _sim_session(tmp_path, capsys, 0.0)
    means = s.summary.groupby("weight_kg").mean_ohm.mean()
    assert list(means.index) == s.start["simulation"]["weights_kg"]
    np.testing.assert_allclose(means.to_numpy(), r_s + contact, rtol=1e-3)
    assert np.all(np.diff(means.to_numpy()) < 0)  # falls with weight, as Tab. 1
    assert np.all((means > 1e-4) & (means < 1e-1))  # mΩ scale, as Tab. 1
    # replay through the dispatcher, as JSON
    capsys.readouterr()
    assert main(["replay", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["identical"] is True and report["blocks_replayed"] == 6


def test_simulated_repeats_scatter_by_a_seeded_lognormal_contact_factor(tmp_path, capsys):
    """Each block's contact term is multiplied by f_b = exp(σ z_b − σ²/2), z_b the documented seeded normals;
    the series resistance stays fixed; the repeats then scatter far beyond the instrument noise, and replay
    still reproduces every block exactly."""
    out, s, r_s, contact = _sim_session(tmp_path, capsys, 0.3)
    import tomllib

    sigma, seed = 0.3, tomllib.loads(sim_scene_text())["session"]["sim_seed"]
    z = np.random.default_rng([seed, 0x5EA7]).standard_normal(6)  # the generator analysis.simulated_session documents
    expected = r_s + np.repeat(contact, 2) * np.exp(sigma * z - sigma**2 / 2)
    np.testing.assert_allclose(s.summary.mean_ohm.to_numpy(), expected, rtol=1e-3)
    np.testing.assert_allclose(s.start["simulation"]["block_resistance_ohm"], expected, rtol=1e-12)
    between = s.summary.groupby("weight_kg").mean_ohm.std(ddof=1)
    within = s.summary.groupby("weight_kg").sem_ohm.max()
    assert (between > 20 * within).sum() >= 2  # repeat scatter dominates the noise (unless two z_b nearly agree)
    capsys.readouterr()
    assert main(["replay", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["identical"] is True


def test_cli_argument_errors(tmp_path, capsys):
    out = str(tmp_path / "o.h5")
    assert main(["acquire", "--sim-speed", "10", "--yes", "-o", out]) == 2
    assert "--sim-speed only applies to --sim" in capsys.readouterr().err
    assert main(["acquire", "--sim", "--resume", "--force", "-o", out]) == 2
    assert "contradict" in capsys.readouterr().err
    assert main(["acquire", "--sim", "--sim-speed", "0", "-o", out]) == 2  # a usage error, returned as its code
    assert main(["acquire", "--sim", "--yes", "--resume", "-o", out]) == 2
    assert "no session file" in capsys.readouterr().err


def test_malformed_scene_is_one_error(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("[session\nrepeats = 2\n")
    assert main(["acquire", str(bad), "--sim", "--yes", "-o", str(tmp_path / "o.h5")]) == 2
    err = capsys.readouterr().err
    assert "malformed TOML" in err and err.count("\n") == 1
    assert not (tmp_path / "o.h5").exists()


def test_killed_sim_process_via_the_cli(tmp_path):
    """`python -m contactrig acquire --sim` killed with SIGKILL: the file opens and holds every reported block."""
    out = tmp_path / "k.h5"
    proc = subprocess.Popen(
        [sys.executable, "-m", "contactrig", "acquire", str(_scene(tmp_path)), "--sim", "--yes", "--sim-speed", "4",
         "-o", str(out)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )  # fmt: skip
    seen = []
    for line in proc.stdout:
        seen.append(line)
        if line.startswith("block 2/"):
            break
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=10)
    assert any(ln.startswith("block 2/") for ln in seen), "".join(seen)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        s = load_session(out)
    assert not s.complete and len(s.summary) >= 2
    assert any("INCOMPLETE" in str(w.message) for w in caught)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["replay", "{tmp}/missing.h5"], "no such session file: {tmp}/missing.h5"),
        (["import", "{tmp}/missing.csv", "--unit", "ohm", "-o", "{tmp}/o.h5"], "no such table: {tmp}/missing.csv"),
        (["acquire", "--sim", "--yes", "--resume", "-o", "{tmp}/missing.h5"], "no session file {tmp}/missing.h5"),
        (["import", "--tab1", "--unit", "ohm", "-o", "{tmp}/o.h5"], "Tab. 1 is in mΩ"),
        (["import", "--tab1", "{tmp}/t.csv", "-o", "{tmp}/o.h5"], "either TABLE or --tab1"),
    ],
)
def test_file_errors_are_one_plain_line(tmp_path, capsys, argv, message):
    """Exit 2, one line naming the file and what is wrong, no traceback and no ``[Errno N]`` prefix."""
    assert main([a.format(tmp=tmp_path) for a in argv]) == 2
    err = capsys.readouterr().err
    assert message.format(tmp=tmp_path) in err and "[Errno" not in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o.h5").exists()


def test_simulated_session_resumes_with_sim_and_only_with_sim(tmp_path, capsys):
    """A --sim session stopped after its first weight resumes with `acquire --sim --resume` to the same blocks an
    uninterrupted one has (the bench's R_b is indexed by block number), replays identically, and refuses to be
    resumed on the real bench."""
    import math
    import tomllib

    from analysis.simulated_session import SimulatedRigBench
    from daq.acquire import acquire
    from daq.errors import SessionStateError
    from daq.link import VisaBench

    scene, out = _scene(tmp_path, 0.3), tmp_path / "resume.h5"
    answers = iter(["go", "quit"])
    first = acquire(scene, out, bench=SimulatedRigBench(math.inf), prompter=lambda step: next(answers), quiet=True)
    assert first.status == "aborted" and first.blocks_done == 2
    with pytest.raises(SessionStateError, match="recorded with --sim"):
        acquire(None, out, resume=True, yes=True, quiet=True, bench=VisaBench())
    code = main(["acquire", "--sim", "--yes", "--resume", "--sim-speed", "inf", "-o", str(out)])
    assert code == 0, capsys.readouterr().err
    s = load_session(out)
    assert s.complete and list(s.summary.block) == list(range(6)) and list(s.summary.run) == [0, 0, 1, 1, 1, 1]
    sim = s.start["simulation"]
    sigma, seed = 0.3, tomllib.loads(sim_scene_text())["session"]["sim_seed"]
    z = np.random.default_rng([seed, 0x5EA7]).standard_normal(6)
    c = sim["circuit"]
    clean = np.sum([np.array(v) for v in sim["clean_terms_ohm"].values()], axis=0)
    contact = c["resistivity_ohm_m"] * c["contact_height_m"] / np.array(sim["contact_area_m2"]) + clean
    expected = c["series_resistance_ohm"] + np.repeat(contact, 2) * np.exp(sigma * z - sigma**2 / 2)
    np.testing.assert_allclose(s.summary.mean_ohm.to_numpy(), expected, rtol=1e-3)
    capsys.readouterr()
    assert main(["replay", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["identical"] is True


def test_simulated_session_with_tab1_noise_records_its_factors_and_replays(tmp_path, capsys):
    """The default ``sim_noise = "tab1"``: each block is R_s + f_b·(ζh/A + R_clean) with f_b the seeded factors of the
    design's noise model (analysis.noise_model), recorded with its parameters; replay reproduces every block."""
    import tomllib

    from analysis.noise_model import tab1_noise
    from analysis.simulated_session import session_factors

    out, s, r_s, contact = _sim_session(tmp_path, capsys, None)
    sim = s.start["simulation"]
    assert sim["noise"]["name"] == "tab1" and sim["noise"]["lack_sd"] == tab1_noise().lack_sd
    seed = tomllib.loads(sim_scene_text())["session"]["sim_seed"]
    f = session_factors(tab1_noise(), 3, 2, seed)
    np.testing.assert_array_equal(sim["contact_factor"], f)
    expected = r_s + np.repeat(contact, 2) * f
    np.testing.assert_allclose(sim["block_resistance_ohm"], expected, rtol=1e-12)
    np.testing.assert_allclose(s.summary.mean_ohm.to_numpy(), expected, rtol=1e-3)
    capsys.readouterr()
    assert main(["replay", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["identical"] is True
