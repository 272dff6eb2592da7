"""Issue 28, the GPU's per-iteration overhead: the solver's decisions on the device, read on the host in groups.

Without a GPU the GPU path runs here over two stand-ins: NumPy itself (``xp=np``: the same code, the speculative
groups and their roll-backs included, with NumPy's arithmetic, so the fields must be bit-identical to the decisions
taken one by one) and ``tests/sims/fake_cupy`` (NumPy arrays that behave like CuPy's where it matters here: reductions
give 0-d arrays, every read on the host is counted). References: the CPU solver (``sims.bem`` on NumPy with
``scipy.fft``), which the tests in test_bem.py / test_bem_backend.py check against closed forms and an independent
quadratic program.
"""

from __future__ import annotations

import collections
import importlib.util
import sys
import types
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from sims import bem, bem_backend

from .test_bem import rough_surface

FAKE = Path(__file__).with_name("fake_cupy")


def _fake_cupy() -> types.ModuleType:
    """The stand-in, loaded under its own name (never as ``cupy``: a real CuPy may be installed)."""
    spec = importlib.util.spec_from_file_location("contactrig_fake_cupy", FAKE / "cupy" / "__init__.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


fake = _fake_cupy()
P_MEAN = 0.0025


@pytest.fixture(scope="module")
def surface() -> np.ndarray:
    return rough_surface(128, seed=3)


def _solve(z: np.ndarray, hardness: float | None, mode: str, **kw: Any) -> bem.ContactResult:
    n = z.shape[0]
    if mode == "pressure":
        return bem.solve_contact(z, 1 / n, 1.0, P_MEAN, hardness=hardness, tol=1e-8, workers=1, **kw)
    return bem.solve_contact(z, 1 / n, 1.0, mean_gap=0.5 * float(np.std(z)), hardness=hardness, tol=1e-8, **kw)


def _fields(r: bem.ContactResult) -> list[np.ndarray]:
    return [r.pressure, r.gap, r.displacement] + ([r.plastic_depth] if r.plastic_depth is not None else [])


def _assert_same(a: bem.ContactResult, b: bem.ContactResult) -> None:
    names = ("nit", "status", "residual", "approach", "mean_gap", "area_fraction")
    assert [getattr(a, k) for k in names] == [getattr(b, k) for k in names]
    for x, y in zip(_fields(a), _fields(b), strict=True):
        assert x.tobytes() == y.tobytes()


@pytest.mark.parametrize("hardness", [None, 0.03])
@pytest.mark.parametrize("mode", ["pressure", "gap"])
@pytest.mark.parametrize("max_iter", [2000, 7])
def test_speculative_groups_give_bit_identical_results_to_host_decisions(surface, monkeypatch, hardness, mode,
                                                                         max_iter):  # fmt: skip
    # the GPU's code path on NumPy: groups of 4 iterations decided on the device, against every decision on the host
    grouped = _solve(surface, hardness, mode, xp=np, max_iter=max_iter)
    monkeypatch.setattr(bem_backend, "DEVICE_DECISIONS", False)
    one_by_one = _solve(surface, hardness, mode, xp=np, max_iter=max_iter)
    assert one_by_one.status == (0 if max_iter > 100 else 1)
    _assert_same(grouped, one_by_one)


@pytest.mark.parametrize("every", [1, 3, 5])
def test_group_size_and_rare_branch_roll_backs_change_nothing(surface, monkeypatch, every):
    """Groups of other sizes, and a rare branch noted in every third speculative iteration (each sends the host back
    to the group's start): the same iterations, fields and diagnostics."""
    monkeypatch.setattr(bem_backend, "DEVICE_DECISIONS", False)
    reference = _solve(surface, 0.03, "pressure", xp=np)
    monkeypatch.setattr(bem_backend, "DEVICE_DECISIONS", True)
    monkeypatch.setattr(bem, "_CHECK_EVERY", every)
    original = bem._Solver.step
    speculative_steps = collections.Counter[str]()

    def step(self: bem._Solver, m: Any) -> bool:
        ok = original(self, m)
        if self.lazy:
            speculative_steps["all"] += 1
            if self.nit % 3 == 0:
                self._rare(lambda: True)
                speculative_steps["rolled back"] += 1
        return ok

    monkeypatch.setattr(bem._Solver, "step", step)
    _assert_same(_solve(surface, 0.03, "pressure", xp=np), reference)
    assert speculative_steps["rolled back"] > 0


def test_a_stall_and_its_bracketing_fallback_are_the_same_in_groups(surface, monkeypatch):
    # a stall rule made hair-trigger: the load-controlled run stalls and the offset bracketing (many inner runs) takes
    # over; the group's stall check on the host must stop at the same iteration as the one-by-one check
    monkeypatch.setattr(bem, "_STALL_ITERATIONS", 1)
    grouped = _solve(surface, 0.03, "pressure", xp=np)
    assert grouped.success and "stalled" in grouped.message
    monkeypatch.setattr(bem_backend, "DEVICE_DECISIONS", False)
    _assert_same(grouped, _solve(surface, 0.03, "pressure", xp=np))


@pytest.mark.parametrize("hardness", [None, 0.03])
def test_gpu_path_on_a_cupy_stand_in_equals_the_cpu_solution(surface, hardness):
    cpu = _solve(surface, hardness, "pressure")
    gpu = _solve(surface, hardness, "pressure", xp=fake)
    assert gpu.device == "gpu" and gpu.success and cpu.success
    assert gpu.nit == cpu.nit
    scale = float(cpu.pressure.max())
    assert float(np.abs(gpu.pressure - cpu.pressure).max()) <= 1e-10 * scale
    assert gpu.area_fraction == cpu.area_fraction
    assert isinstance(gpu.residual, float) and isinstance(gpu.approach, float)


def _syncs_per_iteration(z: np.ndarray, hardness: float | None) -> float:
    """Host reads per iteration on the stand-in: the difference between 16 and 8 iterations (fixed costs cancel)."""
    counts = []
    for k in (8, 16):
        fake.SYNCS.clear()
        res = _solve(z, hardness, "pressure", xp=fake, max_iter=k)
        assert res.nit == k
        counts.append(sum(fake.SYNCS.values()))
    return (counts[1] - counts[0]) / 8


def test_gpu_path_reads_the_host_at_most_three_times_per_iteration(surface):
    # e5ddcc8: 15.3 reads per iteration (4 dot products, the curvature, the residual's max/min, the load's sum, the
    # mean gap, the overlap search and its filter, the clipping test, the support's mask); now the overlap search and
    # the support's size, a clipping test when no point joins, and the group's residuals once per 4 iterations
    assert _syncs_per_iteration(surface, None) <= 3.0


def test_capped_gpu_path_reads_the_host_less_than_before(surface):
    # e5ddcc8: 22.3 per iteration (now 9.5); the capped load balance (a Newton iteration on the capped sum) still
    # reads at each step
    assert _syncs_per_iteration(surface, 0.03) <= 11.0


def test_the_device_decisions_are_taken_on_the_generic_path_only():
    assert not bem_backend.get_backend("cpu", 1).defer and bem_backend.get_backend(workers=1, xp=fake).defer


def test_quick_gpu_benchmark_runs_end_to_end_on_the_stand_in(tmp_path):
    """``tests/benchmarks/bench_bem_gpu.sh --quick``, the one run on a lent card, on the CPU with the stand-in as
    ``cupy`` (grids divided by 32): every grid and case gives its row, the fields agree, and both files are kept."""
    import json
    import os
    import shutil
    import subprocess

    root = Path(__file__).resolve().parents[2]
    bindir = tmp_path / "bin"
    bindir.mkdir()
    (bindir / "python3").symlink_to(sys.executable)  # the script calls python3: this interpreter
    env = dict(os.environ, OUT=str(tmp_path / "out"), PYTHONPATH=str(FAKE), PATH=f"{bindir}:{os.environ['PATH']}")
    script = root / "tests" / "benchmarks" / "bench_bem_gpu.sh"
    bash = shutil.which("bash") or "/bin/bash"
    done = subprocess.run([bash, str(script), "--quick", "--shrink", "32"], env=env, cwd=root, capture_output=True,
                          text=True, timeout=120)  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    out = json.loads((tmp_path / "out" / "bench_bem_gpu.quick.json").read_text(encoding="utf-8"))
    assert out["errors"] == [] and out["skipped"] == []
    assert [(r["n"], r["case"]) for r in out["rows"]] == [(32, "elastic"), (32, "capped"), (128, "elastic"),
                                                          (128, "capped"), (256, "elastic")]  # fmt: skip
    assert all(f["ok"] for f in out["fields"]) and len(out["fields"]) == 4
    for r in out["rows"]:
        assert r["old"]["nit"] == r["new"]["nit"] and r["new"]["syncs_per_it"] < r["old"]["syncs_per_it"]
        assert r["new"]["computed"] - r["new"]["nit"] <= bem._CHECK_EVERY
    assert "max|Δp|/max p" in (tmp_path / "out" / "bench_bem_gpu.quick.txt").read_text(encoding="utf-8")
