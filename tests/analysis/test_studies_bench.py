"""``contactrig bench --quick`` as CI runs it: every study reports, and the numbers say what the methods are."""

import json
import math
import subprocess
import sys

import pytest

from analysis.studies.rows import study_names


@pytest.fixture(scope="module")
def quick_bench(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    proc = subprocess.run(
        [sys.executable, "-m", "contactrig", "bench", "--quick", "--json", "-o", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout), out


def _rows(data, study, method_prefix=""):
    return [r for r in data["rows"] if r["study"] == study and r["method"].startswith(method_prefix)]


def test_every_study_reports_finite_rows_and_the_report_is_written(quick_bench):
    data, out = quick_bench
    assert {r["study"] for r in data["rows"]} == set(study_names())
    for r in data["rows"]:
        assert r["error"] is not None and math.isfinite(r["error"]) and r["error"] >= 0, r
        assert r["seconds"] > 0, r
    assert all(a["ok"] for a in data["atlas"]), [a for a in data["atlas"] if not a["ok"]]
    text = (out / "report.md").read_text()
    for name in study_names():
        assert f"## {name}" in text
        assert (out / f"{name}.png").stat().st_size > 1000


def test_gaussian_integrals_table_meets_its_accuracy_and_the_paper_polynomial_does_not(quick_bench):
    data, _ = quick_bench
    table = {r["setting"].rsplit(", ", 1)[0]: r for r in _rows(data, "gaussian_integrals", "table")}
    assert table["t in [-8, 10]"]["error"] <= 1e-9
    (paper,) = _rows(data, "gaussian_integrals", "paper_polynomial")
    assert paper["error"] > 1.0  # several-fold wrong between t = 3 and 4 (reference note)
    assert 3.0 <= paper["worst_t"] <= 4.0


def test_stiff_damping_costs_explicit_rk45_far_more_evaluations_than_implicit(quick_bench):
    data, _ = quick_bench
    stiff = {r["method"]: r for r in _rows(data, "integrator") if "(stiff)" in r["setting"]}
    assert stiff["RK45"]["nfev"] > 10 * stiff["BDF"]["nfev"]
    for r in _rows(data, "integrator"):
        assert r["settled"] and r["error"] < 1e-4


def test_acquisition_error_falls_with_measuring_time(quick_bench):
    data, _ = quick_bench
    for nplc in ("0.1", "1", "5"):
        rows = sorted(_rows(data, "acquisition", f"delta NPLC {nplc}"), key=lambda r: r["seconds"])
        # 10 → 1000 readings: white noise predicts a factor 10; allow for the spread of 8 blocks
        assert rows[-1]["error"] < rows[0]["error"] / 3
    allan = sorted(_rows(data, "acquisition", "allan"), key=lambda r: r["seconds"])
    assert allan[-1]["error"] < allan[0]["error"] / 5


def test_variable_mesh_reaches_1e_3_and_summit_statistics_converge(quick_bench):
    data, _ = quick_bench
    for r in _rows(data, "mesh", "variable"):
        assert r["error"] < 1e-3, r
    by_res = {r["method"]: r["error"] for r in _rows(data, "surface", "summit statistics") if "box" in r["setting"]}
    assert by_res["summit statistics, 8 px/λ"] < 0.05 < by_res["summit statistics, 2 px/λ"]
