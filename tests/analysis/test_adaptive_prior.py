"""``acquire --adaptive --noise-from SESSION.h5`` (issue 27, the prior of the sequential design): the prior noise is
what ``design --noise-from`` estimates from that session — the same estimator, checked against a two-way analysis of
ln R written out here —, recorded with the file's name and content id, said on the screen as "noise from NAME",
replayed from the record alone (the other file gone); bad input is a one-line error naming the option and the value,
exit 2, and no session file."""

from __future__ import annotations

import math
import re
from pathlib import Path

import h5py
import numpy as np
import pytest

from analysis.simulated_session import SimulatedRigBench
from contactrig.cli.main import main
from contactrig.core.scene import parse_scene
from daq import load_session
from daq.acquire import acquire

PRESS = Path(__file__).resolve().parents[2] / "contactrig" / "scenes" / "press.toml"


def _scene_text(sd: float, repeats: int) -> str:
    """The packaged press scene (two models) with iid re-seating of SD ``sd`` and ``repeats`` per weight."""
    text = PRESS.read_text()
    text = re.sub(r"^models\s*=.*$", 'models = ["greenwood_tripp", "pasaribu_schipper"]', text, count=1, flags=re.M)
    text = re.sub(r'^sim_noise = "tab1"', 'sim_noise = "iid"', text, count=1, flags=re.M)
    text = re.sub(r"^sim_repeat_sd = 0.15", f"sim_repeat_sd = {sd}", text, count=1, flags=re.M)
    return re.sub(r"^repeats = 6", f"repeats = {repeats}", text, count=1, flags=re.M)


@pytest.fixture(scope="module")
def earlier(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fixed-plan session of a quieter bench (iid re-seating 5 %, 8 weights × 3 repeats): the earlier session."""
    folder = tmp_path_factory.mktemp("prior")
    path = folder / "earlier.h5"
    acquire(parse_scene(_scene_text(0.05, 3), "press, 5 %"), path, bench=SimulatedRigBench(math.inf), yes=True,
            quiet=True)  # fmt: skip
    (folder / "scene.toml").write_text(_scene_text(0.15, 6))
    return path


def test_the_prior_comes_from_the_earlier_session_and_replays_without_it(earlier: Path, tmp_path: Path,
                                                                         capsys) -> None:  # fmt: skip
    from analysis.adaptive_session import replay_suggestions
    from contactrig.cli.design import _noise
    from daq.run_index import content_id

    out = tmp_path / "adaptive.h5"
    scene = earlier.parent / "scene.toml"
    args = ["acquire", str(scene), "--sim", "--sim-speed", "inf", "--yes", "--adaptive", "--budget-min", "10"]
    assert main([*args, "--noise-from", str(earlier), "-o", str(out)]) in (0, 1)
    err = capsys.readouterr().err
    assert "noise from earlier.h5" in err
    s = load_session(out)
    settings = s.start["adaptive"]
    assert settings["noise_from"] == {"file": "earlier.h5", "content_id": content_id(load_session(earlier).start)}
    prior = settings["noise"]
    assert prior["source"] == "noise from earlier.h5"
    design = _noise(str(earlier), 0.15)  # what `design --noise-from earlier.h5` simulates with: the same numbers
    assert [prior[k] for k in ("series_sd", "reseat_sd", "lack_sd")] == [design.series_sd, design.reseat_sd,
                                                                         design.lack_sd]  # fmt: skip
    # the estimate itself, from the earlier file's blocks: re-seating = residual mean square of ln R (weights ×
    # repeats, two-way), a 5 % bench, not Tab. 1's 13 % nor this scene's simulated 15 %
    rows = load_session(earlier).summary
    lv = np.log(rows.pivot(index="weight_kg", columns="repeat", values="mean_ohm").to_numpy())
    m, r = lv.shape
    resid = lv - lv.mean(1, keepdims=True) - lv.mean(0, keepdims=True) + lv.mean()
    assert prior["reseat_sd"] == pytest.approx(math.sqrt(float(np.sum(resid**2)) / ((m - 1) * (r - 1))), rel=1e-12)
    assert 0.02 < prior["reseat_sd"] < 0.09
    # replay: the suggestions from the recorded prior alone (the earlier file moved away)
    earlier_copy = earlier.read_bytes()
    earlier.unlink()
    try:
        same, text = replay_suggestions(str(out))
        assert same, text
        assert main(["replay", str(out)]) == 0
    finally:
        earlier.write_bytes(earlier_copy)


def _few(folder: Path) -> Path:
    """A session of 3 weights × 2 repeats (too few to estimate a lack of fit: ≥ 4 weights are needed)."""
    table = folder / "few.csv"
    table.write_text("weight_kg,M1,M2\n5,4.0,4.2\n10,3.0,3.3\n20,2.0,2.1\n")
    assert main(["import", str(table), "--unit", "mohm", "-o", str(folder / "few.h5")]) == 0
    return folder / "few.h5"


def _damaged(earlier: Path, folder: Path) -> Path:
    """A copy of the earlier session with one block's mean edited: its seal no longer holds."""
    copy = folder / "damaged.h5"
    copy.write_bytes(earlier.read_bytes())
    with h5py.File(copy, "r+") as h5:
        h5["entry/summary/mean_ohm"][0] *= 1.5
    return copy


@pytest.mark.parametrize(
    "case, extra, says",
    [
        ("missing", ["--adaptive"], "no such session file"),
        ("text", ["--adaptive"], "not a readable HDF5 session file"),
        ("damaged", ["--adaptive"], "altered or damaged"),
        ("few", ["--adaptive"], "≥ 4 weights"),
        ("earlier", [], "only applies to --adaptive"),
        ("earlier", ["--adaptive", "--resume"], "does not resume"),
    ],
)
def test_bad_noise_from_is_a_one_line_error_and_writes_nothing(case, extra, says, earlier: Path, tmp_path: Path,
                                                              capsys) -> None:  # fmt: skip
    value = {
        "missing": lambda: tmp_path / "none.h5",
        "text": lambda: (tmp_path / "notes.h5", (tmp_path / "notes.h5").write_text("not a session"))[0],
        "damaged": lambda: _damaged(earlier, tmp_path),
        "few": lambda: _few(tmp_path),
        "earlier": lambda: earlier,
    }[case]()
    capsys.readouterr()
    out = tmp_path / "x.h5"
    assert main(["acquire", "--sim", *extra, "--noise-from", str(value), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert "--noise-from" in err and str(value) in err and says in err, err
    assert not out.exists()


def test_acquire_help_names_the_option() -> None:
    import subprocess
    import sys

    text = subprocess.run([sys.executable, "-m", "contactrig", "acquire", "--help"], capture_output=True, text=True,
                          cwd=Path(__file__).resolve().parents[2], check=True).stdout  # fmt: skip
    assert "--noise-from SESSION.h5" in text
