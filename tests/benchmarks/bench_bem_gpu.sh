#!/usr/bin/env bash
# Issue 28: the BEM solver on one NVIDIA H100/H200 against the CPU, in ≤ 5 minutes, from the repository alone.
#
# Needs python3 with numpy, scipy and cupy (h5py is not used); nothing of ours is installed: the repository root goes
# on PYTHONPATH (sims and contactrig.core import without pyvisa, matplotlib or any other package of ours).
# Prints and keeps (beside this script, or in $OUT when set, e.g. on the lent device machine):
#   bench_bem_gpu.results.txt   the whole output (card, date, load; fields CPU = GPU; FFT limits; per-iteration
#                                times 1024²–8192²; the CPU table with 1 and every core)
#   bench_bem_gpu.results.json  every figure
# Usage: tests/benchmarks/bench_bem_gpu.sh [--budget SECONDS]   (default 270: parts left over are skipped, named)
#        [--parts 1,2,3,4,5]  (1 fields CPU = GPU, 2 FFT limits, 3 GPU solver, 4 CPU table, 5 compare-models' BEM
#                              work on a profilometer-sized rectangle, 968 × 1126 and 1024 × 2048)
#        --quick [--shrink K]  ≤ 90 s: the GPU path before and after cutting its host synchronisations, side by side
#                              (1024², 4096², 8192²; grids divided by K); kept as bench_bem_gpu.quick.{txt,json}.
#                              On the CPU, with the CuPy stand-in: PYTHONPATH=tests/sims/fake_cupy ... --quick --shrink 16
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
dest="${OUT:-$here}"
mkdir -p "$dest"
cd "$root"
export PYTHONPATH="$root${PYTHONPATH:+:$PYTHONPATH}"
# BLAS single-threaded (the solver's dot products use einsum, not BLAS). OMP_NUM_THREADS is left alone: SciPy's FFT
# takes it as the most workers it may use (measured: OMP_NUM_THREADS=1 makes workers=16 as slow as workers=1).
unset OMP_NUM_THREADS
export OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}"
python3 -c "import cupy, numpy, scipy; cupy.cuda.runtime.getDeviceCount()" || {
    echo "bench_bem_gpu.sh: needs python3 with numpy, scipy and cupy, and a CUDA device" >&2
    exit 2
}
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader 2>/dev/null || true
name=results limit=480
for arg in "$@"; do [[ "$arg" == --quick ]] && name=quick limit=120; done
PYTHONUNBUFFERED=1 timeout "$limit" python3 "$here/bench_bem_gpu.py" --json "$dest/bench_bem_gpu.$name.json" "$@" \
    2>&1 | tee "$dest/bench_bem_gpu.$name.txt"
