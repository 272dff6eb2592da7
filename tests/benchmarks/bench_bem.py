"""Benchmark: one load step of the periodic FFT-BEM contact solver (``sims.bem``), elastic and capped.

Surface (the contact-mechanics benchmark of the reference notes): self-affine, Hurst 0.8, box 1, power spectrum flat
below the roll-off wavenumber 4·2π and ∝ q^(−2(1+H)) up to the cut-off N/8·2π (zero above), random phases, scaled to
rms slope 0.1; E* = 1; mean pressure 0.025·E*·h′rms (contact ≈ 5 %). The capped case adds a hardness H (default
0.1·E*, about twice the mean pressure over the real contact).

Each (grid, case) runs in a fresh child process so the peak memory growth is its own: resident-set high-water mark
(VmHWM, reset through /proc/self/clear_refs before the solve) and the tracemalloc peak (numpy arrays only; pocketfft's
internal buffers are not traced). Times are the minimum of the repeats (3 below 1024², else 1), the first of which
includes building the grid's kernel. If ``tamaas`` or ``ContactMechanics`` can be imported they are run on the same
surface (their own default tolerances) and printed alongside; they are not installed by this script.

Run: .venv/bin/python tests/benchmarks/bench_bem.py [--big] [--workers N] [--hardness H]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path
from typing import Any

import numpy as np

E_STAR = 1.0
RMS_SLOPE = 0.1
HURST = 0.8

# reference-mechanics.md, "Measured here" (single-threaded, min of repeats): grid → (tamaas s, it, CM s, it)
REFERENCE = {
    256: (0.21, 53, 0.12, 33),
    512: (1.69, 95, 1.52, 70),
    1024: (12.3, 147, 10.0, 82),
    2048: (159, 345, 196, 286),
}


def self_affine(n: int, seed: int = 1) -> np.ndarray:
    """Heights on an n×n grid of the unit box (pixel 1/n): the benchmark's self-affine surface, rms slope 0.1."""
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
    z = np.fft.irfft2(spectrum, s=(n, n))
    zq = np.fft.rfft2(z)
    gx = np.fft.irfft2(1j * qx[:, None] * zq, s=(n, n))
    gy = np.fft.irfft2(1j * qy[None, :] * zq, s=(n, n))
    slope = float(np.sqrt(np.mean(gx**2 + gy**2)))
    return z * (RMS_SLOPE / slope)


def _hwm_reset() -> bool:
    try:
        Path("/proc/self/clear_refs").write_text("5")
        return True
    except OSError:
        return False


def _status_kib(key: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1])
    return 0


def _ours(z: np.ndarray, pressure: float, hardness: float | None, workers: int | None, repeats: int) -> dict[str, Any]:
    from sims import bem

    n = z.shape[0]
    rss0 = _status_kib("VmRSS")
    hwm_ok = _hwm_reset()
    tracemalloc.start()
    t0 = time.perf_counter()
    res = bem.solve_contact(z, 1.0 / n, E_STAR, pressure, hardness=hardness, workers=workers)
    times = [time.perf_counter() - t0]
    _, traced_peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    rss_growth = (_status_kib("VmHWM") - rss0) / 1024.0 if hwm_ok else float("nan")
    for _ in range(repeats - 1):
        t0 = time.perf_counter()
        bem.solve_contact(z, 1.0 / n, E_STAR, pressure, hardness=hardness, workers=workers)
        times.append(time.perf_counter() - t0)
    return {
        "time": min(times),
        "nit": res.nit,
        "area": res.area_fraction,
        "area_corr": res.area_fraction_corrected,
        "plastic": res.plastic_fraction,
        "threads": res.workers,
        "rss_mb": rss_growth,
        "traced_mb": traced_peak / 2**20,
        "status": res.status,
        "residual": res.residual,
    }


def _tamaas(z: np.ndarray, pressure: float) -> dict[str, Any]:
    import tamaas as tm  # type: ignore[import-not-found, import-untyped, unused-ignore]

    n = z.shape[0]
    model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [1.0, 1.0], [n, n])
    model.E = E_STAR  # with nu = 0, tamaas' E* = E / (1 - nu²) = E
    model.nu = 0.0
    solver = tm.PolonskyKeerRey(model, np.ascontiguousarray(z), 1e-12)
    t0 = time.perf_counter()
    solver.solve(pressure)
    dt = time.perf_counter() - t0
    return {"time": dt, "area": float(np.mean(np.asarray(model.traction) > 0.0))}


def _contact_mechanics(z: np.ndarray, pressure: float, hardness: float | None) -> dict[str, Any]:
    # The solver function itself: ContactMechanics 1.8.3's make_system fails with SurfaceTopography 1.27
    # (missing ``local_topography_subdomain_slices``); the function is what make_system would call.
    from ContactMechanics import PeriodicFFTElasticHalfSpace  # type: ignore[import-not-found, import-untyped, unused-ignore]
    from ContactMechanics.Optimization.ConstrainedConjugateGradients import (  # type: ignore[import-not-found, import-untyped, unused-ignore]
        constrained_conjugate_gradients,
    )
    from SurfaceTopography import Topography  # type: ignore[import-not-found, import-untyped, unused-ignore]

    n = z.shape[0]
    substrate = PeriodicFFTElasticHalfSpace((n, n), E_STAR, physical_sizes=(1.0, 1.0))
    topography = Topography(z, physical_sizes=(1.0, 1.0))
    # its hardness caps the force per pixel: H times the pixel area
    cap = None if hardness is None else hardness / (n * n)
    t0 = time.perf_counter()
    sol = constrained_conjugate_gradients(substrate, topography, external_force=pressure * 1.0 * 1.0, hardness=cap)
    dt = time.perf_counter() - t0
    area = float(np.mean(np.asarray(sol.jac) > 0.0))
    return {"time": dt, "nit": int(getattr(sol, "nit", -1)), "area": area}


def _external(name: str, z: np.ndarray, pressure: float, hardness: float | None, ours: float) -> str:
    try:
        if name == "tamaas":
            if hardness is not None:
                return "tamaas: capped solver not run (its saturated solver differs)"
            r = _tamaas(z, pressure)
        else:
            r = _contact_mechanics(z, pressure, hardness)
    except ImportError:
        return f"{name}: absent (not importable; not installed by this benchmark)"
    except Exception as exc:  # an optional package's API drift must not stop the benchmark
        return f"{name}: failed ({type(exc).__name__}: {exc})"
    diff = 100.0 * (r["area"] / ours - 1.0) if ours > 0 else float("nan")
    return f"{name}: {r['time']:.2f} s, it {r.get('nit', '?')}, area {r['area']:.5f} ({diff:+.2f} % vs ours)"


def child(n: int, case: str, workers: int | None, hardness_rel: float, externals: str) -> None:
    z = self_affine(n)
    h_rms = RMS_SLOPE
    pressure = 0.025 * E_STAR * h_rms
    hardness = hardness_rel * E_STAR if case == "capped" else None
    repeats = 3 if n < 1024 else 1
    out = _ours(z, pressure, hardness, workers, repeats)
    out["external"] = [_external(name, z, pressure, hardness, out["area"]) for name in externals.split(",") if name]
    print(json.dumps(out))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--big", action="store_true", help="also run 2048²")
    ap.add_argument("--workers", type=int, default=None, help="FFT threads (default: os.cpu_count())")
    ap.add_argument("--hardness", type=float, default=0.1, help="hardness of the capped case, in units of E*")
    ap.add_argument("--sizes", type=str, default=None, help="comma-separated grid sizes (overrides --big)")
    ap.add_argument(
        "--externals",
        default="tamaas,ContactMechanics",
        help="outside codes to run alongside, comma-separated (empty: none)",
    )
    ap.add_argument("--child", nargs=2, metavar=("N", "CASE"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child(int(args.child[0]), args.child[1], args.workers, args.hardness, args.externals)
        return
    sizes = [int(s) for s in args.sizes.split(",")] if args.sizes else [256, 512, 1024] + ([2048] if args.big else [])
    print(f"cores: {os.cpu_count()}, workers: {args.workers or os.cpu_count()}, capped H = {args.hardness}·E*")
    head = f"{'n':>5} {'case':>7} {'time s':>8} {'it':>4} {'area':>8} {'corr.':>8} {'plast.':>7} {'thr':>3}"
    print(head + f" {'RSS MB':>7} {'traced MB':>9}  status  | reference single-threaded (tamaas; CM)")
    for n in sizes:
        for case in ("elastic", "capped"):
            cmd = [sys.executable, __file__, "--child", str(n), case, "--hardness", str(args.hardness)]
            cmd += ["--externals", args.externals]
            if args.workers:
                cmd += ["--workers", str(args.workers)]
            proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
            if proc.returncode != 0:
                print(f"{n:5d} {case:>7} failed: {proc.stderr.strip().splitlines()[-1:]}")
                continue
            r = json.loads(proc.stdout.strip().splitlines()[-1])
            ref = REFERENCE.get(n)
            ref_txt = f"{ref[0]} s [{ref[1]} it]; {ref[2]} s [{ref[3]} it]" if ref and case == "elastic" else ""
            print(
                f"{n:5d} {case:>7} {r['time']:8.2f} {r['nit']:4d} {r['area']:8.5f} {r['area_corr']:8.5f} "
                f"{r['plastic']:7.4f} {r['threads']:3d} {r['rss_mb']:7.0f} {r['traced_mb']:9.0f}  {r['status']:>6}  | "
                f"{ref_txt}"
            )
            for line in r["external"]:
                print(f"{'':14}{line}")


if __name__ == "__main__":
    main()
