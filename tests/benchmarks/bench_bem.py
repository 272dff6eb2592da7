"""Benchmark: one load step of the periodic FFT-BEM contact solver (``sims.bem``) against tamaas and ContactMechanics,
measured fairly.

Surface (the contact-mechanics benchmark of the reference notes): self-affine, Hurst 0.8, box 1, power spectrum flat
below the roll-off wavenumber 4·2π and ∝ q^(−2(1+H)) up to the cut-off N/8·2π (zero above), random phases, scaled to
rms slope 0.1; E* = 1; mean pressure 0.025·E*·h′rms (contact ≈ 6 %). The capped case adds a hardness H (default
0.03·E*, below the mean pressure over the elastic contact, ≈ 0.04·E*: a good share of the contact is capped).

Fairness (issue 21 §5):

* **Same accuracy, same error measure.** Every code's pressure field is judged here by one measure, computed with
  numpy from the pressure alone: displacement from E*|q|/2, gap g = u − z + h₀ with h₀ the mean over the free
  contact points, error = the largest violation of the contact conditions (|g| where 0 < p < H, −g where p = 0) in
  units of rms(z). Each code runs at tolerance ``--tol`` (its own measure) and, if the error is still above the
  target, at 10× tighter tolerances until it is not (the ladder is printed). At tolerance t the three codes give
  errors of 0.4–0.9·t on this surface, so one tolerance nearly always suffices.
* **Iterations and convergence status with every time.** A run that hit its iteration limit (ours: status 1;
  tamaas: returned error above its tolerance; ContactMechanics: ``success`` False) is flagged LIMIT and its time is
  never tabulated (a time from such a run measures the limit, not the solver).
* **Equal threads.** Each (grid, case, code) runs in a fresh child process with OMP/MKL/OpenBLAS threads and our FFT
  workers set to the same count: the main table is single-threaded, ``--threads 1,2`` adds the two-thread table.
* **Best of three** for every code (``--repeats``), at the tolerance that reached the target.
* **Peak memory of the whole process**: VmHWM of the child at the end (imports, surface, solver — everything), and the
  growth during the solves (VmHWM reset through /proc/self/clear_refs before them).
* **The FFT limit** (issue 28): each child also times one ``scipy.fft`` rfft2 + irfft2 pair at its grid and thread
  count (best of 7, before and after the solves); our rows print the time per iteration, its ratio to that pair, the
  FFT pairs our solver spent per iteration (counted) and the time per iteration over that many pairs; the time per
  iteration spent inside the solver's own FFT calls (timed around each) and outside them (the element-wise passes
  and the work on the contact set: what "every core" must make small and parallel, whatever the FFT count); and the
  ratio in CPU time (``time.process_time``, every thread of the child summed; best timed run against the best pair):
  with one thread a measure of the work that other jobs on a shared machine barely move. ``ours`` is the default
  (Fourier-preconditioned) solver, ``ours-pk`` the plain Polonsky–Keer directions (``precondition=False``). The load
  average is printed before and after: on a shared machine, compare only rows of one run.

Run: .venv/bin/python tests/benchmarks/bench_bem.py [--sizes 256,512,1024] [--threads 1,2]
     [--codes ours,ours-pk,tamaas,cm] [--hardness 0.03] [--tol 1e-8] [--target 1e-8] [--repeats 3] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

E_STAR = 1.0
RMS_SLOPE = 0.1
HURST = 0.8
PRESSURE = 0.025 * E_STAR * RMS_SLOPE

# reference-mechanics.md, "Measured here" + corrections (single-threaded, min of repeats, tamaas at tolerance 1e-8):
# grid → (tamaas s, it, CM s, it). A baseline only: the table's own peer columns are what the ratio uses.
REFERENCE = {
    256: (0.21, 53, 0.12, 33),
    512: (1.69, 95, 1.52, 70),
    1024: (12.3, 147, 10.0, 82),
    2048: (159, 345, 196, 286),
}


def self_affine(n: int, seed: int = 1, fft: Any = np.fft) -> np.ndarray:
    """Heights on an n×n grid of the unit box (pixel 1/n): the benchmark's self-affine surface, rms slope 0.1.

    ``fft``: the module of ``rfft2``/``irfft2`` (NumPy's; the GPU benchmark passes SciPy's with every worker)."""
    box = 1.0
    q_roll = 4.0 * 2.0 * math.pi / box
    q_cut = n / 8.0 * 2.0 * math.pi / box
    qx = 2.0 * math.pi * np.fft.fftfreq(n, d=box / n)
    qy = 2.0 * math.pi * np.fft.rfftfreq(n, d=box / n)
    q = np.hypot(qx[:, None], qy[None, :])
    psd = np.maximum(q, q_roll) ** (-2.0 * (1.0 + HURST))
    psd[q > q_cut] = 0.0
    psd[0, 0] = 0.0
    rng = np.random.default_rng(seed)
    spectrum = np.sqrt(psd) * np.exp(2j * math.pi * rng.random(q.shape))
    z = fft.irfft2(spectrum, s=(n, n))
    zq = fft.rfft2(z)
    gx = fft.irfft2(1j * qx[:, None] * zq, s=(n, n))
    gy = fft.irfft2(1j * qy[None, :] * zq, s=(n, n))
    slope = float(np.sqrt(np.mean(gx**2 + gy**2)))
    return z * (RMS_SLOPE / slope)


def contact_error(pressure: np.ndarray, z: np.ndarray, hardness: float | None) -> float:
    """The one error measure (module docstring): largest contact-condition violation / rms(z), from p alone."""
    n = z.shape[0]
    qx = 2.0 * math.pi * np.fft.fftfreq(n, d=1.0 / n)
    qy = 2.0 * math.pi * np.fft.rfftfreq(n, d=1.0 / n)
    q = np.hypot(qx[:, None], qy[None, :])
    q[0, 0] = 1.0
    uq = 2.0 * np.fft.rfft2(pressure) / (E_STAR * q)
    uq[0, 0] = 0.0
    r = np.fft.irfft2(uq, s=(n, n)) - z
    free = pressure > 0 if hardness is None else (pressure > 0) & (pressure < hardness * (1 - 1e-9))
    if not free.any():
        return math.nan
    g = r - float(np.mean(r[free]))
    off = pressure <= 0
    worst = float(np.max(np.abs(g[free])))
    if off.any():
        worst = max(worst, float(np.max(-g[off])))
    return worst / float(np.std(z))


# ---------------------------------------------------------------------------------------------------------------
# The codes: each returns (pressure field, iterations, converged, hit_limit).


def _ours(
    z: np.ndarray, hardness: float | None, tol: float, threads: int, count: bool = True, precondition: bool = True
) -> tuple[np.ndarray, int, bool, bool]:
    from sims import bem

    n = z.shape[0]
    res = bem.solve_contact(
        z, 1.0 / n, E_STAR, PRESSURE, hardness=hardness, tol=tol, workers=threads, precondition=precondition
    )
    limit = res.status == bem.STATUS_MAX_ITERATIONS
    return np.asarray(res.pressure), int(res.nit), res.status == bem.STATUS_CONVERGED, limit


def _ours_pk(
    z: np.ndarray, hardness: float | None, tol: float, threads: int, count: bool = True
) -> tuple[np.ndarray, int, bool, bool]:
    """Ours without the Fourier preconditioner: the plain Polonsky–Keer directions (the solver before issue 28)."""
    return _ours(z, hardness, tol, threads, count, precondition=False)


def _tamaas(
    z: np.ndarray, hardness: float | None, tol: float, threads: int, count: bool = True
) -> tuple[np.ndarray, int, bool, bool]:
    import tamaas as tm  # type: ignore[import-not-found, import-untyped, unused-ignore]

    if hardness is not None:
        raise NotImplementedError("no capped Polonsky–Keer solver (its saturated solver is another algorithm)")
    n = z.shape[0]
    model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [1.0, 1.0], [n, n])
    model.E = E_STAR  # with nu = 0, tamaas' E* = E / (1 - nu²) = E
    model.nu = 0.0
    solver = tm.PolonskyKeerRey(model, np.ascontiguousarray(z), tol)
    if not count:  # timed runs: no per-iteration output
        converged = float(solver.solve(PRESSURE)) <= tol
        return np.array(model.traction).reshape(n, n), -1, converged, not converged
    solver.dump_freq = 1  # one line per iteration on stderr: the only way tamaas tells its iteration count
    log = tempfile.TemporaryFile()
    saved = os.dup(2)
    os.dup2(log.fileno(), 2)
    try:
        err = solver.solve(PRESSURE)
    finally:
        os.dup2(saved, 2)
        os.close(saved)
    log.seek(0)
    lines = log.read().decode(errors="replace").splitlines()
    its = [int(line.split()[0]) for line in lines if line[:8].strip().isdigit()]
    nit = max(its) if its else -1
    converged = float(err) <= tol
    return np.array(model.traction).reshape(n, n), nit, converged, not converged


def _contact_mechanics(
    z: np.ndarray, hardness: float | None, tol: float, threads: int, count: bool = True
) -> tuple[np.ndarray, int, bool, bool]:
    # The solver function itself: ContactMechanics 1.8.3's make_system fails with SurfaceTopography 1.27
    # (missing ``local_topography_subdomain_slices``); the function is what make_system would call.
    from ContactMechanics import PeriodicFFTElasticHalfSpace  # type: ignore[import-not-found, import-untyped, unused-ignore]
    from ContactMechanics.Optimization.ConstrainedConjugateGradients import (  # type: ignore[import-not-found, import-untyped, unused-ignore]
        constrained_conjugate_gradients,
    )
    from ContactMechanics.Tools.Logger import quiet  # type: ignore[import-not-found, import-untyped, unused-ignore]
    from SurfaceTopography import Topography  # type: ignore[import-not-found, import-untyped, unused-ignore]

    n = z.shape[0]
    substrate = PeriodicFFTElasticHalfSpace((n, n), E_STAR, physical_sizes=(1.0, 1.0))
    topography = Topography(z, physical_sizes=(1.0, 1.0))
    cap = None if hardness is None else hardness / (n * n)  # its hardness caps the force per pixel
    sol = constrained_conjugate_gradients(
        substrate, topography, external_force=PRESSURE, hardness=cap, pentol=tol * float(np.std(z)), logger=quiet
    )
    return np.asarray(sol.jac) * (n * n), int(sol.nit), bool(sol.success), not bool(sol.success)


CODES: dict[str, Callable[..., tuple[np.ndarray, int, bool, bool]]] = {
    "ours": _ours,
    "ours-pk": _ours_pk,
    "tamaas": _tamaas,
    "cm": _contact_mechanics,
}


# ---------------------------------------------------------------------------------------------------------------
# One child process per (grid, case, code, threads).


def _status_kib(key: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1])
    return 0


def _hwm_reset() -> bool:
    try:
        Path("/proc/self/clear_refs").write_text("5")
        return True
    except OSError:
        return False


def fft_pair_seconds(n: int, threads: int, repeats: int = 7, clock: Callable[[], float] = time.perf_counter) -> float:
    """The FFT limit: best time of one ``scipy.fft`` rfft2 + irfft2 pair, float64, n×n, ``threads`` workers.

    ``clock``: wall time (default) or ``time.process_time`` (CPU time of every thread of the process)."""
    import scipy.fft as sfft

    x = np.random.default_rng(0).random((n, n))
    best = math.inf
    for _ in range(repeats):
        t0 = clock()
        sfft.irfft2(sfft.rfft2(x, workers=threads), s=(n, n), workers=threads)
        best = min(best, clock() - t0)
    return best


def _count_ffts() -> dict[str, float]:
    """Count our solver's real FFTs (forward and inverse) from now on: the pairs it spends per iteration, and the
    wall and CPU time spent inside them (``"wall"``, ``"cpu"``: what the solver does outside its FFTs is the rest)."""
    from sims.bem_backend import Backend

    counts = {"rfft2": 0.0, "irfft2": 0.0, "wall": 0.0, "cpu": 0.0}
    for name in ("rfft2", "irfft2"):
        original = getattr(Backend, name)

        def counted(self: Any, *a: Any, _f: Any = original, _k: str = name) -> Any:
            counts[_k] += 1
            t0, c0 = time.perf_counter(), time.process_time()
            out = _f(self, *a)
            counts["wall"] += time.perf_counter() - t0
            counts["cpu"] += time.process_time() - c0
            return out

        setattr(Backend, name, counted)
    return counts


def child(n: int, case: str, code: str, threads: int, opts: dict[str, Any]) -> dict[str, Any]:
    """Run ``code``'s ladder of tolerances until the error reaches the target, then best of ``repeats``."""
    z = self_affine(n)
    pair = fft_pair_seconds(n, threads)
    pair_cpu = fft_pair_seconds(n, threads, clock=time.process_time)
    ffts = _count_ffts() if code.startswith("ours") else None
    hardness = opts["hardness"] * E_STAR if case == "capped" else None
    run = CODES[code]
    rss0 = _status_kib("VmRSS")
    grew = _hwm_reset()
    ladder = []
    tol = opts["tol"]
    while True:
        if ffts is not None:
            ffts.update(rfft2=0, irfft2=0)
        t0 = time.perf_counter()
        p, nit, ok, limit = run(z, hardness, tol, threads, count=True)  # untimed: counts iterations
        counting_s = time.perf_counter() - t0
        spent = (ffts["rfft2"] + ffts["irfft2"]) / 2 if ffts is not None else math.nan
        err = contact_error(p, z, hardness)
        ladder.append({"tol": tol, "error": err, "nit": nit, "converged": ok, "limit": limit})
        if limit or err <= opts["target"] or tol <= 1e-14 * 1.01:
            break
        tol /= 10.0
    times, cpu_times, fft_times = [], [], []
    if not limit:
        for _ in range(opts["repeats"]):
            if ffts is not None:
                ffts.update(wall=0.0, cpu=0.0)
            t0, c0 = time.perf_counter(), time.process_time()
            run(z, hardness, tol, threads, count=False)
            times.append(time.perf_counter() - t0)
            cpu_times.append(time.process_time() - c0)
            fft_times.append((ffts["wall"], ffts["cpu"]) if ffts is not None else (math.nan, math.nan))
    pair = min(pair, fft_pair_seconds(n, threads))  # timed again after the solves: the quieter moment counts
    pair_cpu = min(pair_cpu, fft_pair_seconds(n, threads, clock=time.process_time))
    last = ladder[-1]
    best = min(times) if times else (counting_s if code.startswith("ours") else math.nan)
    per_it = best / nit if nit > 0 else math.nan
    per_it_cpu = min(cpu_times) / nit if cpu_times and nit > 0 else math.nan
    pairs_it = spent / nit if nit > 0 else math.nan
    # outside the FFTs (the run with the best wall time): the element-wise passes and the work on the contact set
    i_best = times.index(best) if times else -1
    fft_wall, fft_cpu = fft_times[i_best] if times else (math.nan, math.nan)
    outside = (best - fft_wall) / nit if nit > 0 else math.nan
    outside_cpu = (cpu_times[i_best] - fft_cpu) / nit if times and nit > 0 else math.nan
    return {
        **last,
        "time": best,
        "timed": bool(times),
        "pair_ms": pair * 1e3,
        "per_iteration_ms": per_it * 1e3,
        "ratio_to_pair": per_it / pair,
        "fft_pairs_per_iteration": pairs_it,
        "ratio_to_pairs_spent": per_it / (pairs_it * pair),
        "fft_ms_per_iteration": fft_wall / nit * 1e3 if nit > 0 else math.nan,
        "outside_fft_ms_per_iteration": outside * 1e3,
        "outside_fft_ratio_to_pair": outside / pair,
        "outside_fft_cpu_ms_per_iteration": outside_cpu * 1e3,
        "cpu_pair_ms": pair_cpu * 1e3,
        "cpu_per_iteration_ms": per_it_cpu * 1e3,
        "cpu_ratio_to_pair": per_it_cpu / pair_cpu,
        "times": times,
        "ladder": ladder,
        "area": float(np.mean(p > 0)),
        "threads": threads,
        "peak_rss_mb": _status_kib("VmHWM") / 1024.0,
        "growth_mb": (_status_kib("VmHWM") - rss0) / 1024.0 if grew else math.nan,
        "at_target": bool(last["error"] <= opts["target"]),
    }


def _spawn(n: int, case: str, code: str, threads: int, args: argparse.Namespace) -> dict[str, Any]:
    env = dict(os.environ)
    for var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
        env[var] = str(threads)
    opts = {"hardness": args.hardness, "tol": args.tol, "target": args.target, "repeats": args.repeats}
    cmd = [sys.executable, __file__, "--child", json.dumps([n, case, code, threads, opts])]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False, env=env)
    if proc.returncode != 0:
        tail = (proc.stderr.strip().splitlines() or ["?"])[-1]
        return {"failed": tail}
    out: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    return out


def _cell(r: dict[str, Any]) -> str:
    if "failed" in r:
        return f"not run ({r['failed'][:70]})"
    conv = "LIMIT" if r["limit"] else ("conv" if r["converged"] else "no-conv")
    t = "— (hit its limit: no time)" if r["limit"] else f"{r['time']:8.3f} s" + ("" if r["timed"] else "*")
    flag = "" if r["at_target"] else "  ABOVE TARGET"
    per_it = ""
    if math.isfinite(r["per_iteration_ms"]):
        per_it = f" {r['per_iteration_ms']:7.1f} ms/it = {r['ratio_to_pair']:.2f}× pair ({r['pair_ms']:.1f} ms)"
        if math.isfinite(r["fft_pairs_per_iteration"]):
            per_it += f" = {r['ratio_to_pairs_spent']:.2f}× the {r['fft_pairs_per_iteration']:.2f} FFT pairs/it spent"
        if math.isfinite(r.get("outside_fft_ms_per_iteration", math.nan)):
            per_it += (
                f"; in its FFTs {r['fft_ms_per_iteration']:.1f} ms/it, outside them"
                f" {r['outside_fft_ms_per_iteration']:.1f} ms/it = {r['outside_fft_ratio_to_pair']:.2f}× pair"
                f" (CPU time {r['outside_fft_cpu_ms_per_iteration']:.1f} ms/it, every thread)"
            )
        if math.isfinite(r.get("cpu_ratio_to_pair", math.nan)):
            per_it += f"; CPU time {r['cpu_ratio_to_pair']:.2f}× pair"
    return (
        f"{t} it {r['nit']:>4} {conv:>5} tol {r['tol']:.0e} err {r['error']:.1e} area {r['area']:.5f}{per_it} "
        f"peak RSS {r['peak_rss_mb']:5.0f} MB (+{r['growth_mb']:.0f}){flag}"
    )


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="256,512,1024", help="comma-separated grid sizes (2048 takes minutes per code)")
    ap.add_argument("--threads", default="1", help="thread counts, comma-separated (1: the main table; 1,2: both)")
    ap.add_argument("--codes", default="ours,tamaas,cm", help=f"codes among {', '.join(CODES)}")
    ap.add_argument("--cases", default="elastic,capped")
    ap.add_argument("--hardness", type=float, default=0.03, help="hardness of the capped case, in units of E*")
    ap.add_argument("--tol", type=float, default=1e-8, help="first tolerance tried, each code's own measure")
    ap.add_argument("--target", type=float, default=1e-8, help="error every code must reach (common measure)")
    ap.add_argument("--repeats", type=int, default=3, help="timed runs per code (best; 0: time the counting run, *)")
    ap.add_argument("--json", default=None, help="also write every result to this JSON file")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        n, case, code, threads, opts = json.loads(args.child)
        print(json.dumps(child(n, case, code, threads, opts)))
        return
    print(f"load average before: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    print(
        f"cores: {os.cpu_count()}; target error {args.target:g}·rms(z) (one measure for every code); capped "
        f"H = {args.hardness}·E*; best of {args.repeats}; LIMIT = hit its iteration limit (never a time)"
    )
    results = []
    for threads in [int(t) for t in args.threads.split(",")]:
        print(f"\n== {threads} thread(s) per code ==")
        for n in [int(s) for s in args.sizes.split(",")]:
            for case in args.cases.split(","):
                row: dict[str, Any] = {}
                for code in args.codes.split(","):
                    row[code] = _spawn(n, case, code, threads, args)
                    results.append({"n": n, "case": case, "code": code, "threads": threads, **row[code]})
                    print(f"{n:5d} {case:>7} {code:>6}  {_cell(row[code])}", flush=True)
                ours = row.get("ours", {})
                peers = [r["time"] for c, r in row.items() if c != "ours" and "time" in r and not r["limit"]]
                if peers and "time" in ours and not ours["limit"]:
                    print(f"{'':20}ours / fastest peer = {ours['time'] / min(peers):.2f}")
                ref = REFERENCE.get(n)
                if ref and case == "elastic" and threads == 1:
                    print(f"{'':20}reference notes: tamaas {ref[0]} s [{ref[1]} it]; CM {ref[2]} s [{ref[3]} it]")
    print(f"\nload average after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
