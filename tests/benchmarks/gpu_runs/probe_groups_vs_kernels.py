"""The probe run on the lent H200 on 2026-11-27 (outputs: 2026-11-27_h200_5_probe_4096.txt, ..._6_probe_8192_1024.txt)
at commit b1801e8, which still had three fused CuPy kernels (``Backend.kernel``, since taken out): one elastic solve
(the second of two, warm) with the decisions on the host, with the iterations in groups and the kernels, and with the
groups but no kernels (``Backend.kernel`` patched to None: the plain array expressions).

Run from the repository root: ``python3 tests/benchmarks/gpu_runs/probe_groups_vs_kernels.py [N] [--no-fused]``.
On today's code the kernels are gone, so the second and third lines time the same path.
"""

import sys
import time

sys.path[:0] = [".", "tests/benchmarks"]

import bench_bem_gpu as g  # noqa: E402
import cupy as cp  # noqa: E402

from sims import bem, bem_backend  # noqa: E402

n = int(sys.argv[1]) if len(sys.argv) > 1 and sys.argv[1].isdigit() else 4096
z = g.self_affine(n)


def run(new: bool, kern: bool, label: str) -> None:
    bem_backend.DEVICE_DECISIONS = new
    if not kern:
        bem_backend.Backend.kernel = lambda self, spec: None  # type: ignore[attr-defined]
    for _ in range(2):
        cp.cuda.Device().synchronize()
        t = time.perf_counter()
        r = bem.solve_contact(z, 1 / n, g.E_STAR, g.PRESSURE, tol=g.TOL, device="gpu")
        cp.cuda.Device().synchronize()
        dt = time.perf_counter() - t
    print(label, f"{dt:.3f} s, {r.nit} it, {1e3 * dt / r.nit:.2f} ms/it", flush=True)


run(False, True, "old (host decisions)")
if "--no-fused" not in sys.argv:
    run(True, True, "new (groups + kernels)")
run(True, False, "groups, no kernels")
