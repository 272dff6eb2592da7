"""``contactrig surface``: what a file holds, roughness before/after form removal and filtering, the figure."""

from __future__ import annotations

import json

import numpy as np
import pytest

from contactrig.cli.main import main
from tests import surface_maker as mk

pytest.importorskip("SurfaceTopography", reason="SurfaceTopography (extra 'surfaces') reads the X3P file")


def test_surface_reports_the_file_and_the_roughness(tmp_path, capsys):
    path = mk.write(tmp_path / "liner.x3p", mk.liner(n=96), 8e-6)
    plot = tmp_path / "liner.png"
    args = [
        "surface", str(path), "--form", "cylinder", "--lambda-s-m", "25e-6", "--lambda-c-m", "250e-6",
        "--plot", str(plot), "--json",
    ]  # fmt: skip
    assert main(args) == 0
    out = json.loads(capsys.readouterr().out)
    info = out["info"]
    assert info["points"] == [96, 96] and info["pixel_m"] == pytest.approx(8e-6, rel=1e-12)
    assert info["missing_points"] == int(np.isnan(mk.liner(n=96)).sum()) > 0
    assert out["conditioning"]["lambda_c_m"] == 250e-6 and out["conditioning"]["form"] == "cylinder"
    assert out["after"]["Sq_m"] < out["before"]["Sq_m"]  # the bore's sagitta is not roughness
    assert plot.stat().st_size > 10_000
    assert main(["surface", str(path), "--plot", str(plot)]) == 2  # an existing figure is not replaced
    assert "exists" in capsys.readouterr().err


def test_surface_errors_are_one_line(tmp_path, capsys):
    (tmp_path / "a.csv").write_text("1 2 3\n" * 10)
    assert main(["surface", str(tmp_path / "a.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert "pixel size is missing" in err and "\n" not in err
