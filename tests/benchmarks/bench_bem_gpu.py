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

Run: PYTHONPATH=. python3 tests/benchmarks/bench_bem_gpu.py [--budget 270] [--json FILE]
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
    return res, seconds, sum(counts.values()) / 2 / max(res.nit, 1)


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


FFTS: list[dict[str, int]] = []  # the counters of _count_ffts (installed by main)
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


def _parts(run: _Run, parts: set[int], cores: int) -> None:
    """The benchmark's parts 1–4 (module docstring), those in ``parts``; 2 (FFT limits) always: 3, 4 use it."""
    cases = ("elastic", "capped")
    heads = {
        1: "1. CPU and GPU fields (max |Δp| / max p must be ≤ 1e-6)",
        2: "2. FFT pair (rfft2 + irfft2, float64)",
        3: "3. GPU solver (targets: ≤ 2× the cuFFT pair per iteration; 4096² ≤ 1 s, 8192² ≤ 5 s; it(4096²) ≤ 93)",
        4: f"4. CPU solver, 1 thread and {cores} threads",
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
    for k, head in heads.items():
        if k in parts or k == 2:
            print("\n" + head, flush=True)
            for name, need, body in tasks[k]:
                run.part(name, need, body)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=float, default=270.0, help="seconds for everything (parts left are skipped)")
    ap.add_argument("--json", default=None, help="also write every figure to this JSON file")
    ap.add_argument("--shrink", type=int, default=1, help="divide every grid by this (a quick check of the script)")
    ap.add_argument("--parts", default="1,2,3,4", help="which parts to run, comma-separated (default 1,2,3,4)")
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
    run = _Run(args.budget, cores, card)
    _parts(run, parts, cores)
    print(f"\ndone in {time.perf_counter() - T0:.0f} s; skipped: {', '.join(run.out['skipped']) or 'nothing'}")
    if args.json:
        Path(args.json).write_text(json.dumps(run.out, indent=1), encoding="utf-8")


if __name__ == "__main__":
    main()
