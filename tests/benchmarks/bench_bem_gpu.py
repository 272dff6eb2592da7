"""Issue 28 on a GPU machine: the BEM solver (``sims.bem``) on CuPy against the CPU, and its cost against the FFT limit.

Needs numpy, scipy and cupy only (h5py is not used); run from the repository root with ``PYTHONPATH=.`` (nothing of
ours installed) — ``tests/benchmarks/bench_bem_gpu.sh`` does that and keeps the output. Surface, load and error
measure are ``bench_bem.py``'s (self-affine, rms slope 0.1, p̄ = 0.0025 E*, capped case H = 0.03 E*, target 1e-8).
Parts, each skipped with a note once the time budget (``--budget``, s) is spent:

1. **CPU = GPU**: the same problem on both, max |Δp| / max p ≤ 1e-6 (512², 1024², elastic and capped).
2. **FFT limits**: one rfft2 + irfft2 pair, float64: scipy.fft with 1 and every worker (1024²–4096²), CuPy/cuFFT
   (1024²–8192²).
3. **GPU solver**: time, iterations, time per iteration and its ratio to the cuFFT pair, FFT pairs per iteration,
   1024²–8192², elastic and capped (issue targets: ≤ 2× the pair per iteration, 4096² ≤ 1 s, 8192² ≤ 5 s, iterations
   at 4096² ≤ 93).
4. **CPU table**: the same on the CPU with 1 thread (1024², 2048²) and every core (1024²–4096²).
5. **A profilometer-sized map**: what ``compare-models`` runs on a measured map, on a rectangle of the shape of
   SurfaceTopography's ``sur-2.sur`` mirrored (968 × 1126; 1126 = 2·563, a prime factor for the FFT) and on
   1024 × 2048: the load path at three pressures with the tangent stiffness (compare-models' default: a solve and
   one linear solve on its contact set a pressure, warm-started),
   capped, CPU (every core) against GPU: time, iterations, max |Δp|/max p between them.

``--quick`` (≤ 90 s on an H200): instead of parts 1–4, the solver's GPU path before and after the host
synchronisations were cut, side by side (``old``: every decision read on the host as it comes,
``sims.bem_backend.DEVICE_DECISIONS = False``; ``new``: the default), at 1024², 4096² and 8192² (elastic; capped at
1024² and 4096²): time per iteration of the loop and its ratio to the cuFFT pair, iterations, iterations computed
(the new path computes up to 3 in vain), host synchronisations per iteration where they can be counted (on the
CuPy stand-in ``tests/sims/fake_cupy``; not on a real card), CuPy's memory pool after the solves per grid point
(their peak: ``sims.budget``'s GPU estimate is 224 B), the largest |Δp|/max p between the two paths and, at 1024²,
between the CPU and each GPU path. Each grid and case in its own try/except; the text and the JSON are
written as they come.

Run: PYTHONPATH=. python3 tests/benchmarks/bench_bem_gpu.py [--budget 270] [--json FILE] [--quick] [--shrink K]
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import platform
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_bem import E_STAR, PRESSURE, _count_ffts, contact_error, fft_pair_seconds, self_affine

HARDNESS = 0.03 * E_STAR
TOL = 1e-8
T0 = time.perf_counter()


def _left(budget: float) -> float:
    return budget - (time.perf_counter() - T0)


def gpu_pair_seconds(n: int, repeats: int = 20) -> float:
    """Best time of one CuPy rfft2 + irfft2 pair, float64, n×n (plans cached by the warm-up, device synchronised)."""
    import cupy as cp

    x = cp.random.default_rng(0).random((n, n))
    cp.fft.irfft2(cp.fft.rfft2(x), s=(n, n))
    cp.cuda.Device().synchronize()
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        cp.fft.irfft2(cp.fft.rfft2(x), s=(n, n))
        cp.cuda.Device().synchronize()
        best = min(best, time.perf_counter() - t0)
    del x
    cp.get_default_memory_pool().free_all_blocks()
    return best


def solve(
    z: np.ndarray, device: str, threads: int, hardness: float | None, max_iter: int = 2000
) -> tuple[Any, float, float]:
    """(result, seconds, FFT pairs spent per iteration) of one solve at the benchmark's load and tolerance."""
    from sims import bem

    counts = FFTS[0]
    counts.update(rfft2=0, irfft2=0)
    n = z.shape[0]
    t0 = time.perf_counter()
    res = bem.solve_contact(
        z, 1.0 / n, E_STAR, PRESSURE, hardness=hardness, tol=TOL, workers=threads, device=device, max_iter=max_iter
    )
    seconds = time.perf_counter() - t0
    return res, seconds, (counts["rfft2"] + counts["irfft2"]) / 2 / max(res.nit, 1)


def loop_seconds_per_iteration(
    z: np.ndarray, device: str, threads: int, hardness: float | None, seconds: float, nit: int
) -> float:
    """The iterations' own cost: (t(full solve) − t(solve stopped after 1 iteration)) / (nit − 1), which removes
    the fixed work of a solve (surface to the card, kernel, full-contact field, result fields and spots)."""
    _, one, _ = solve(z, device, threads, hardness, max_iter=1)
    return max(seconds - one, 0.0) / max(nit - 1, 1)


def _row(
    label: str,
    n: int,
    case: str,
    res: Any,
    times: tuple[float, float, float],
    pair: float,
    pairs_it: float,
    z: np.ndarray,
) -> dict[str, Any]:
    """One solver row; ``times`` = (first solve at this grid, warm solve, the warm solve's loop per iteration)."""
    hardness = HARDNESS if case == "capped" else None
    cold, seconds, loop = times
    per_it = seconds / max(res.nit, 1)
    row = {
        "where": label, "n": n, "case": case, "seconds": seconds, "first_seconds": cold, "nit": res.nit,
        "status": res.status, "per_iteration_ms": per_it * 1e3, "loop_per_iteration_ms": loop * 1e3,
        "pair_ms": pair * 1e3, "ratio_to_pair": per_it / pair, "loop_ratio_to_pair": loop / pair,
        "fft_pairs_per_iteration": pairs_it, "area": res.area_fraction,
        "error": contact_error(np.asarray(res.pressure), z, hardness),
    }  # fmt: skip
    print(
        f"  {label:>14} {n:5d}² {case:>7}: {seconds:8.3f} s (first {cold:.3f} s), {res.nit:4d} it, "
        f"{per_it * 1e3:8.2f} ms/it = {per_it / pair:5.2f}× pair; loop {loop * 1e3:8.2f} ms/it = "
        f"{loop / pair:5.2f}× pair ({pair * 1e3:.3f} ms), {pairs_it:.2f} FFT pairs/it, err {row['error']:.1e}, "
        f"area {res.area_fraction:.5f}" + ("" if res.success else f"  NOT CONVERGED ({res.message})"),
        flush=True,
    )
    return row


FFTS: list[dict[str, float]] = []  # the counters of _count_ffts (installed by main)
SHRINK = [1]


class _Run:
    """The figures gathered, the surfaces made once, and the time budget."""

    def __init__(self, budget: float, cores: int, card: str) -> None:
        self.budget = budget
        self.cores = cores
        self.out: dict[str, Any] = {"card": card, "cores": cores, "fields": [], "fft": [], "solver": [], "skipped": []}
        self.surfaces: dict[int, np.ndarray] = {}
        self.pairs: dict[tuple[str, int], float] = {}

    def surface(self, n: int) -> np.ndarray:
        if n not in self.surfaces:
            self.surfaces[n] = self_affine(n // SHRINK[0])
        return self.surfaces[n]

    def part(self, name: str, need: float, body: Callable[[], None]) -> None:
        """Run ``body`` if ``need`` seconds are left, else note it as skipped."""
        if _left(self.budget) < need:
            self.out["skipped"].append(name)
            print(f"  skipped (time budget): {name}", flush=True)
            return
        body()

    def fields(self, n: int, case: str) -> None:
        n = self.surface(n).shape[0]
        h = HARDNESS if case == "capped" else None
        cpu, _, _ = solve(self.surfaces[n * SHRINK[0]], "cpu", self.cores, h)
        gpu, _, _ = solve(self.surfaces[n * SHRINK[0]], "gpu", self.cores, h)
        diff = float(np.abs(gpu.pressure - cpu.pressure).max()) / float(cpu.pressure.max())
        ok = diff <= 1e-6 and gpu.success and cpu.success
        self.out["fields"].append({"n": n, "case": case, "rel_max_dp": diff, "nit_cpu": cpu.nit, "nit_gpu": gpu.nit,
                                   "ok": ok})  # fmt: skip
        print(f"  {n:5d}² {case:>7}: max|Δp|/max p = {diff:.2e} ({'PASS' if ok else 'FAIL'}); it CPU {cpu.nit}, "
              f"GPU {gpu.nit}; area CPU {cpu.area_fraction:.6f}, GPU {gpu.area_fraction:.6f}", flush=True)  # fmt: skip

    def fft(self, n: int) -> None:
        n //= SHRINK[0]
        row: dict[str, Any] = {"n": n, "gpu_ms": gpu_pair_seconds(n) * 1e3}
        self.pairs[("gpu", n)] = row["gpu_ms"] / 1e3
        if n <= 4096:
            for w in (1, self.cores):
                self.pairs[(f"cpu{w}", n)] = fft_pair_seconds(n, w, repeats=3 if n >= 4096 else 5)
                row[f"cpu_{w}_ms"] = self.pairs[(f"cpu{w}", n)] * 1e3
        self.out["fft"].append(row)
        print("  " + ", ".join(f"{k} {v:.3f}" if isinstance(v, float) else f"{k} {v}" for k, v in row.items()),
              flush=True)  # fmt: skip

    def solver(self, device: str, threads: int, n: int, case: str) -> None:
        z = self.surface(n)
        n = z.shape[0]
        h = HARDNESS if case == "capped" else None
        if device == "gpu":
            solve(z[:64, :64].copy(), "gpu", threads, h)  # warm-up: CuPy's kernels are compiled once per process
        res, cold, pit = solve(z, device, threads, h)  # the first solve at this grid (on the GPU: its FFT plans)
        sec = cold
        if device == "gpu" or n <= 2048:  # warm: best of two (the 4096² CPU solves are too long to repeat)
            res, sec, pit = solve(z, device, threads, h)
            sec = min(sec, cold)
        loop = loop_seconds_per_iteration(z, device, threads, h, sec, res.nit)
        key = ("gpu", n) if device == "gpu" else (f"cpu{threads}", n)
        pair = self.pairs.get(key) or (fft_pair_seconds(n, threads, repeats=3) if device == "cpu" else float("nan"))
        label = "GPU" if device == "gpu" else f"CPU {threads} thr"
        self.out["solver"].append(_row(label, n, case, res, (cold, sec, loop), pair, pit, z))


    def load_path(self, shape: tuple[int, int]) -> None:
        """Part 5: ``compare-models``' BEM work (:func:`sims.bem.solve_load_path`, tangent stiffness) on a rectangle."""
        from sims import bem

        ny, nx = (max(4, k // SHRINK[0]) for k in shape)
        ny, nx = ny + ny % 2, nx + nx % 2
        z = np.ascontiguousarray(self_affine(max(ny, nx))[:ny, :nx])  # a window: periodic or not, the same input
        pressures = [PRESSURE * f for f in (0.4, 1.0, 4.0)]
        row: dict[str, Any] = {"shape": [ny, nx], "pressures_over_E": [p / E_STAR for p in pressures]}
        paths = {}
        for device in ("cpu", "gpu"):
            if device == "gpu":
                solve(z[:64, :64].copy(), "gpu", self.cores, HARDNESS)  # CuPy compiles its kernels once
            t0 = time.perf_counter()
            paths[device] = bem.solve_load_path(z, 1.0 / nx, E_STAR, pressures, HARDNESS, workers=self.cores,
                                                device=device, stiffness="tangent")  # fmt: skip
            row[f"{device}_s"], row[f"{device}_nit"] = time.perf_counter() - t0, paths[device].nit
        row["rel_max_dp"] = max(
            float(np.abs(g.pressure - c.pressure).max()) / float(c.pressure.max())
            for c, g in zip(paths["cpu"].results, paths["gpu"].results, strict=True)
        )
        c, g = paths["cpu"], paths["gpu"]
        # what compare-models reports, GPU against CPU (both solved to the path's tolerance, 1e-6: they agree to
        # about that, not to the 1e-8 solves' 1e-6 of part 1)
        row["rel_d_area"], row["rel_d_gap"], row["rel_d_stiffness"] = (
            float(np.max(np.abs(b - a) / np.abs(a)))
            for a, b in ((c.area_fraction, g.area_fraction), (c.mean_gap, g.mean_gap), (c.stiffness, g.stiffness))
        )  # fmt: skip
        row["ok"] = c.success and g.success and row["rel_max_dp"] <= 1e-4
        self.out.setdefault("load_path", []).append(row)
        print(f"  {ny} × {nx}: CPU {self.cores} thr {row['cpu_s']:.2f} s ({row['cpu_nit']} it), GPU "
              f"{row['gpu_s']:.2f} s ({row['gpu_nit']} it), {row['cpu_s'] / row['gpu_s']:.1f}× faster; GPU against "
              f"CPU: max|Δp|/max p {row['rel_max_dp']:.1e} ({'PASS' if row['ok'] else 'FAIL'}: ≤ 1e-4 at tol 1e-6), "
              f"area {row['rel_d_area']:.1e}, mean gap {row['rel_d_gap']:.1e}, stiffness {row['rel_d_stiffness']:.1e}",
              flush=True)  # fmt: skip


def _parts(run: _Run, parts: set[int], cores: int) -> None:
    """The benchmark's parts 1–5 (module docstring), those in ``parts``; 2 (FFT limits) always: 3, 4 use it."""
    cases = ("elastic", "capped")
    heads = {
        1: "1. CPU and GPU fields (max |Δp| / max p must be ≤ 1e-6)",
        2: "2. FFT pair (rfft2 + irfft2, float64)",
        3: "3. GPU solver (targets: ≤ 2× the cuFFT pair per iteration; 4096² ≤ 1 s, 8192² ≤ 5 s; it(4096²) ≤ 93)",
        4: f"4. CPU solver, 1 thread and {cores} threads",
        5: "5. compare-models' BEM work on a profilometer-sized rectangle (3 pressures, tangent stiffness, capped)",
    }
    tasks: dict[int, list[tuple[str, float, Callable[[], None]]]] = {k: [] for k in heads}
    for n, case in itertools.product((512, 1024), cases):
        tasks[1].append((f"fields {n}² {case}", 20.0, lambda n=n, case=case: run.fields(n, case)))
    for n in (1024, 2048, 4096, 8192):
        tasks[2].append((f"FFT pair {n}²", 15.0, lambda n=n: run.fft(n)))
        for case in cases:
            tasks[3].append((f"GPU solve {n}² {case}", 10.0 if n < 8192 else 30.0,
                             lambda n=n, case=case: run.solver("gpu", cores, n, case)))  # fmt: skip
    for threads, sizes in ((1, (1024, 2048)), (cores, (1024, 2048, 4096))):
        for n in sizes:
            for case in cases:
                need = {1024: 10.0, 2048: 30.0, 4096: 60.0}[n] * (4.0 if threads == 1 else 1.0)
                tasks[4].append((f"CPU {threads} threads {n}² {case}", need,
                                 lambda n=n, case=case, t=threads: run.solver("cpu", t, n, case)))  # fmt: skip
    for shape in ((968, 1126), (1024, 2048)):
        tasks[5].append((f"load path {shape[0]}×{shape[1]}", 40.0, lambda shape=shape: run.load_path(shape)))
    _run_parts(run, heads, tasks, parts)


def _run_parts(run: _Run, heads: dict[int, str], tasks: dict[int, list[tuple[str, float, Callable[[], None]]]],
               parts: set[int]) -> None:  # fmt: skip
    """Each part asked for (2, the FFT limits, always: 3 and 4 use it), its tasks in order within the budget."""
    for k, head in heads.items():
        if k in parts or k == 2:
            print("\n" + head, flush=True)
            for name, need, body in tasks[k]:
                run.part(name, need, body)


class _Quick:
    """``--quick``: the GPU path before and after cutting its host synchronisations (module doc)."""

    def __init__(self, cores: int, json_path: str | None, budget: float) -> None:
        from sims import bem

        self.cores = cores
        self.json_path = json_path
        self.budget = budget
        self.out: dict[str, Any] = {"rows": [], "fields": [], "errors": [], "skipped": []}
        self.steps = [0]
        original = bem._Solver.step

        def counted(solver: Any, m: Any) -> bool:  # iterations computed, the speculative ones included
            self.steps[0] += 1
            return original(solver, m)

        bem._Solver.step = counted  # type: ignore[method-assign]
        self.warm: set[bool] = set()

    def save(self) -> None:
        if self.json_path:
            Path(self.json_path).write_text(json.dumps(self.out, indent=1), encoding="utf-8")

    def solve(self, z: np.ndarray, new: bool, h: float | None, max_iter: int = 2000) -> dict[str, Any]:
        """One GPU solve on the old or the new path: result, seconds, iterations computed, host syncs counted."""
        import cupy as cp

        from sims import bem, bem_backend

        bem_backend.DEVICE_DECISIONS = new
        if new not in self.warm:  # CuPy compiles each kernel once per process: not in the timings
            self.warm.add(new)
            for hh in (None, HARDNESS):
                bem.solve_contact(z[:64, :64].copy(), 1 / 64, E_STAR, PRESSURE, hardness=hh, tol=TOL, device="gpu")
        syncs = getattr(cp, "SYNCS", None)  # the stand-in's counter; a real CuPy has none
        if syncs is not None:
            syncs.clear()
        self.steps[0] = 0
        n = z.shape[0]
        cp.cuda.Device().synchronize()
        t0 = time.perf_counter()
        res = bem.solve_contact(z, 1 / n, E_STAR, PRESSURE, hardness=h, tol=TOL, device="gpu", max_iter=max_iter)
        cp.cuda.Device().synchronize()
        seconds = time.perf_counter() - t0
        count = sum(syncs.values()) if syncs is not None else None
        return {"res": res, "seconds": seconds, "steps": self.steps[0], "syncs": count}

    def fields(self, z: np.ndarray, case: str) -> None:
        from sims import bem

        n = z.shape[0]
        h = HARDNESS if case == "capped" else None
        cpu = bem.solve_contact(z, 1 / n, E_STAR, PRESSURE, hardness=h, tol=TOL, device="cpu", workers=self.cores)
        scale = float(cpu.pressure.max())
        for new in (False, True):
            gpu = self.solve(z, new, h)["res"]
            diff = float(np.abs(gpu.pressure - cpu.pressure).max()) / scale
            ok = diff <= 1e-6 and gpu.success and cpu.success
            path = "new" if new else "old"
            self.out["fields"].append({"n": n, "case": case, "path": path, "rel_max_dp": diff, "nit_cpu": cpu.nit,
                                       "nit_gpu": gpu.nit, "ok": ok})  # fmt: skip
            print(f"  fields {n:5d}² {case:>7} CPU vs GPU {path}: max|Δp|/max p = {diff:.2e} "
                  f"({'PASS' if ok else 'FAIL'}); it CPU {cpu.nit}, GPU {gpu.nit}", flush=True)  # fmt: skip

    def timing(self, z: np.ndarray, case: str, pair: float) -> None:
        n = z.shape[0]
        h = HARDNESS if case == "capped" else None
        row: dict[str, Any] = {"n": n, "case": case, "pair_ms": pair * 1e3}
        fields = {}
        import cupy as cp

        pool = cp.get_default_memory_pool()
        for new in (False, True):
            path = "new" if new else "old"
            pool.free_all_blocks()  # what the pool holds after the runs is their peak (CuPy keeps freed blocks)
            runs = [self.solve(z, new, h) for _ in range(2 if n <= 4096 else 1)]
            held = getattr(pool, "total_bytes", lambda: None)()
            best = min(runs, key=lambda r: r["seconds"])
            one = self.solve(z, new, h, max_iter=1)
            res = best["res"]
            loop = max(best["seconds"] - one["seconds"], 0.0) / max(res.nit - 1, 1)
            syncs = None
            if best["syncs"] is not None and one["syncs"] is not None:
                syncs = (best["syncs"] - one["syncs"]) / max(res.nit - 1, 1)
            fields[path] = res.pressure
            row[path] = {"seconds": best["seconds"], "nit": res.nit, "computed": best["steps"],
                         "loop_ms_per_it": loop * 1e3, "loop_ratio_to_pair": loop / pair, "syncs_per_it": syncs,
                         "success": res.success, "residual": res.residual,
                         "pool_bytes_per_point": None if held is None else held / n**2}  # fmt: skip
        row["rel_max_dp_old_new"] = float(np.abs(fields["new"] - fields["old"]).max()) / float(fields["old"].max())
        self.out["rows"].append(row)

        def cell(r: dict[str, Any]) -> str:
            syncs = "n/a" if r["syncs_per_it"] is None else f"{r['syncs_per_it']:.2f}"
            pool = "" if r["pool_bytes_per_point"] is None else f", pool {r['pool_bytes_per_point']:.0f} B/point"
            return (f"{r['loop_ms_per_it']:7.2f} ms/it = {r['loop_ratio_to_pair']:5.2f}× pair, {r['nit']:3d} it "
                    f"({r['computed']} computed), syncs/it {syncs}, solve {r['seconds']:.3f} s{pool}"
                    + ("" if r["success"] else " NOT CONVERGED"))  # fmt: skip

        print(f"  {n:5d}² {case:>7} (pair {pair * 1e3:.3f} ms)  old: {cell(row['old'])}\n"
              f"  {'':15} new: {cell(row['new'])}; max|Δp|/max p old vs new {row['rel_max_dp_old_new']:.1e}",
              flush=True)  # fmt: skip

    def run(self, sizes: list[int]) -> None:
        import cupy as cp
        import scipy.fft as sfft

        fft = type("fft", (), {"rfft2": staticmethod(lambda x, **k: sfft.rfft2(x, workers=-1, **k)),
                               "irfft2": staticmethod(lambda x, **k: sfft.irfft2(x, workers=-1, **k))})  # fmt: skip
        print("\nquick: the GPU path before (old: host decisions) and after (new: iterations in groups)", flush=True)
        for n in sizes:
            cases = ("elastic", "capped") if n <= 4096 // SHRINK[0] else ("elastic",)
            try:
                z = self_affine(n, fft=fft)
                pair = gpu_pair_seconds(n, repeats=10)
            except Exception as exc:  # a grid that cannot be made (memory): the next one
                self._error(f"{n}² setup", exc)
                continue
            if n == sizes[0]:
                for case in cases:
                    self._guard(f"fields {n}² {case}", 10.0, lambda z=z, case=case: self.fields(z, case))
            need = 25.0 if n > 4096 // SHRINK[0] else 10.0
            for case in cases:
                self._guard(f"timing {n}² {case}", need, lambda z=z, case=case, pair=pair: self.timing(z, case, pair))
            del z
            cp.get_default_memory_pool().free_all_blocks()

    def _guard(self, name: str, need: float, body: Callable[[], None]) -> None:
        """``body`` if ``need`` seconds of the budget are left, its failure printed and kept, the JSON saved."""
        if _left(self.budget) < need:
            self.out["skipped"].append(name)
            print(f"  skipped (time budget): {name}", flush=True)
            return
        try:
            body()
        except Exception as exc:  # one grid's failure (memory, a kernel) must not cost the others
            self._error(name, exc)
        self.save()

    def _error(self, name: str, exc: BaseException) -> None:
        self.out["errors"].append({"what": name, "error": f"{type(exc).__name__}: {exc}"})
        print(f"  FAILED {name}: {type(exc).__name__}: {exc}", flush=True)
        self.save()


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=float, default=270.0, help="seconds for everything (parts left are skipped)")
    ap.add_argument("--json", default=None, help="also write every figure to this JSON file")
    ap.add_argument("--shrink", type=int, default=1, help="divide every grid by this (a quick check of the script)")
    ap.add_argument("--parts", default="1,2,3,4,5", help="which parts to run, comma-separated (default all)")
    ap.add_argument("--quick", action="store_true", help="old and new GPU path side by side, ≤ 90 s (module doc)")
    args = ap.parse_args(argv)
    parts = {int(x) for x in args.parts.split(",")}
    SHRINK[0] = args.shrink
    FFTS.append(_count_ffts())
    import cupy as cp
    import scipy

    cores = os.cpu_count() or 1
    props = cp.cuda.runtime.getDeviceProperties(0)
    card = props["name"].decode() if isinstance(props["name"], bytes) else str(props["name"])
    free, total = cp.cuda.runtime.memGetInfo()
    print(f"date (UTC): {time.strftime('%Y-%m-%d %H:%M', time.gmtime())}; card: {card}, {total / 2**30:.0f} GiB "
          f"({free / 2**30:.0f} free); CPU: {platform.processor() or platform.machine()}, {cores} cores, load "
          f"{' '.join(f'{v:.2f}' for v in os.getloadavg())}; numpy {np.__version__}, scipy {scipy.__version__}, "
          f"cupy {cp.__version__}", flush=True)  # fmt: skip
    if args.quick:
        quick = _Quick(cores, args.json, min(args.budget, 80.0))
        quick.out["card"] = card
        quick.run([n // SHRINK[0] for n in (1024, 4096, 8192)])
        print(f"\ndone in {time.perf_counter() - T0:.0f} s; skipped: {', '.join(quick.out['skipped']) or 'nothing'}; "
              f"errors: {len(quick.out['errors'])}", flush=True)  # fmt: skip
        quick.save()
        return
    run = _Run(args.budget, cores, card)
    _parts(run, parts, cores)
    print(f"\ndone in {time.perf_counter() - T0:.0f} s; skipped: {', '.join(run.out['skipped']) or 'nothing'}")
    if args.json:
        Path(args.json).write_text(json.dumps(run.out, indent=1), encoding="utf-8")


if __name__ == "__main__":
    main()
