"""Where one GPU solve of sims.bem spends its time (cProfile; run with CUDA_LAUNCH_BLOCKING=1 so each kernel's time
falls on the Python call that launched it). Usage: PYTHONPATH=. python3 tests/benchmarks/profile_bem_gpu.py N CASE"""

import cProfile
import pstats
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_bem import E_STAR, PRESSURE, self_affine

from sims import bem

n, case = int(sys.argv[1]), sys.argv[2]
hard = None if case == "elastic" else 0.03 * E_STAR
z = self_affine(n)
bem.solve_contact(z[:256, :256].copy(), 1 / 256, E_STAR, PRESSURE, hardness=hard, tol=1e-8, device="gpu")
pr = cProfile.Profile()
t = time.perf_counter()
pr.enable()
res = bem.solve_contact(z, 1 / n, E_STAR, PRESSURE, hardness=hard, tol=1e-8, device="gpu")
pr.disable()
print(f"{n}² {case}: {time.perf_counter() - t:.3f} s, {res.nit} it", flush=True)
try:
    import cupy as cp

    pool = cp.get_default_memory_pool()  # CuPy's pool keeps what it held (cuFFT work areas included): the peak
    held, used = pool.total_bytes(), pool.used_bytes()
    print(f"GPU memory held by CuPy's pool after the solves: {held / n**2:.0f} B per grid point "
          f"({held / 2**20:.0f} MiB; in use now {used / 2**20:.0f} MiB)", flush=True)  # fmt: skip
except Exception as exc:  # no CuPy (a stand-in): nothing to say
    print(f"GPU memory: not read ({type(exc).__name__})")
st = pstats.Stats(pr)
st.sort_stats("tottime").print_stats(22)
st.sort_stats("cumulative").print_stats("bem.py", 18)
