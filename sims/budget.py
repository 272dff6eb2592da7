"""Memory and time of the simulation stages, from the settings alone: the estimators of :mod:`contactrig.core.budget`.

Each stage's peak memory [bytes] above the process's own is a sum of per-item costs measured once (peak resident
memory of a child process, ``tests/contactrig/test_budget.py`` checks every estimate against the measured peak,
within a factor of 2, at a few moderate sizes); nothing is allocated to estimate. Registered stages:

==============  ==============================================================  ======================================
stage           memory                                                          keys named
==============  ==============================================================  ======================================
``surfaces``    ~26 B per grid point and surface (spectrum, phases, the map)    ``[surfaces.*] n`` (or a map's size)
``database``    statistics-only models (Greenwood–Tripp): ~16 B per grid        ``[surfaces.*] n``, ``[database]
                point; models summed over summits: ~56 B per point (both maps,  models``
                the composite, its summits) + at most ``PAIR_CHUNK`` pairs
``rig``         ~64 B per mesh node and weight + 64 B per node; a variable      ``[rig] mesh, n_theta, n_axial,
                mesh counts its node budget (``max_nodes``, or the first level  max_nodes``, the weights
                when larger): an upper bound
``press``       ~48 B per ring pair (influence matrix, Jacobian)                ``[press] n_rings``
``bem``         ~200 B per point of the refined grid, per concurrent task,      ``[surfaces.*] n``, ``--refine``,
                plus ~100 MB for each worker process                            ``--jobs``
``bem_gpu``     device memory of one solve on the GPU: ~224 B per point,        ``[surfaces.*] n``, ``--refine``,
                against the card's free memory (:func:`check_bem_gpu`)          ``--device gpu``
==============  ==============================================================  ======================================

:func:`check_specimen`, :func:`check_database` and :func:`check_comparison` check the work of the entry points
(:func:`sims.database.build_database`, :func:`sims.rig.sweep`, :func:`sims.press.press_sweep`,
:func:`sims.ensemble.run_comparison`), which call them first; commands call them before anything else.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import TYPE_CHECKING

from contactrig.core.budget import STAGES, Estimate, Stage, check

if TYPE_CHECKING:
    from sims.config import SimConfig
    from sims.surface import SurfaceSpec

__all__ = ["bem_gpu", "check_bem_gpu", "check_comparison", "check_database", "check_specimen"]

_SURFACE_B = 26.0  # generation of one map (spectrum, phases, the map), held while the other is made
_STATISTICS_B = 16.0  # spectral moments on the half spectrum
_SUMMED_B = 56.0  # both maps, the composite, derivatives and summit masks
_PAIR_B = 100.0  # one (separation, summit) pair of asperity_sums
_NODE_WEIGHT_B = 64.0  # gap, law values and slopes per node and weight (rig batch solve)
_NODE_B = 64.0  # the mesh: areas, angles, cos·area per node
_RING_PAIR_B = 48.0  # press: influence matrix and bordered Jacobian
_BEM_B = 200.0  # FFT-BEM: surface, pressures, gaps, FFT work arrays, per refined point
_PROCESS_B = 100e6  # a spawned worker: interpreter, numpy, scipy
_POINT_S = 0.2e-6  # database: seconds per grid point (all models; 12 s at n = 8192)
_NODE_WEIGHT_S = 1.0e-6  # rig: seconds per node and weight (all Newton steps)
_BEM_POINT_S = 2.0e-6  # BEM: seconds per refined point and pressure (order of magnitude)


def _grid_shape(spec: SurfaceSpec) -> tuple[tuple[int, int], str]:
    """(ny, nx) of a surface's grid (rows × columns; a measured map's mirrored edges double each side) and the scene
    key that sets it."""
    if spec.kind == "file" and spec.measured is not None:
        mirrored = (spec.conditioning or {}).get("edges") == "mirror"  # 2× each side
        ny, nx = (1, *spec.measured.shape) if spec.measured.ndim == 1 else spec.measured.shape  # a profile: 1 row
        shape = (2 * ny, 2 * nx) if mirrored else (int(ny), int(nx))
        return shape, f"[{spec.section}] path = {spec.path!r} ({' × '.join(map(str, shape))})"
    n = int(spec.n or 0)
    return (n, n), f"[{spec.section}] n = {n}"


def _largest_shape(config: SimConfig) -> tuple[tuple[int, int], str]:
    """(ny, nx) of the larger of the two surfaces' grids and the keys of both."""
    (a, ka), (b, kb) = _grid_shape(config.liner), _grid_shape(config.piston)
    return max(a, b, key=math.prod), f"{ka}, {kb}"


def _grids(config: SimConfig) -> tuple[int, str]:
    """The larger grid of the two surfaces [points] and the keys of both."""
    shape, keys = _largest_shape(config)
    return math.prod(shape), keys


def surfaces(config: SimConfig) -> Estimate:
    """Generating (or levelling) both surfaces of ``config``: the larger grid, twice (both maps are held)."""
    points, keys = _grids(config)
    return Estimate("surface generation", keys, _SURFACE_B * points * 2, _POINT_S * points * 2)


def database(config: SimConfig, models: Sequence[str] | None = None, n_separations: int | None = None) -> Estimate:
    """Building the contact curves of ``models`` (default: the scene's): the costliest model decides."""
    from sims.database import PAIR_CHUNK
    from sims.models import get_model

    names = list(models) if models is not None else list(config.database.models)
    summed = any(get_model(m).needs_surface for m in names)
    measured = config.liner.kind == "file" or config.piston.kind == "file"
    points, keys = _grids(config)
    n_sep = int(n_separations or config.database.n_separations)
    per_point = _SUMMED_B if summed or measured else _STATISTICS_B
    pairs = min(PAIR_CHUNK, n_sep * points) if summed else 0
    seconds = _POINT_S * points
    what = f"contact database ({', '.join(names)})"
    return Estimate(what, f"{keys}, [database] models", per_point * points + _PAIR_B * pairs, seconds)


def _rig_nodes(config: SimConfig) -> tuple[int, str]:
    """Most nodes the rig's mesh can have and the keys that set it."""
    s = config.rig
    if s.mesh == "uniform":
        return s.n_theta * s.n_axial, f"[rig] mesh = 'uniform', n_theta = {s.n_theta}, n_axial = {s.n_axial}"
    axial = 1 if s.crown_m == 0 else s.n_axial + 16
    first = (s.n_theta + 16) * axial  # the fine zone plus the graded tail (a few cells)
    keys = f"[rig] mesh = 'variable', n_theta = {s.n_theta}, n_axial = {s.n_axial}, max_nodes = {s.max_nodes}"
    return max(first, s.max_nodes), keys


def rig(config: SimConfig, weights_kg: Sequence[float] | None = None) -> Estimate:
    """The batch equilibrium of one model on the rig's mesh, every weight at once (models are solved in turn)."""
    weights = len(weights_kg) if weights_kg is not None else len(config.rig.weights_kg)
    nodes, keys = _rig_nodes(config)
    bytes_ = _NODE_WEIGHT_B * nodes * weights + _NODE_B * nodes
    return Estimate("rig mesh", f"{keys} ({weights} weights)", bytes_, _NODE_WEIGHT_S * nodes * weights)


def press(config: SimConfig) -> Estimate:
    """The press's layer solve on its rings (one load at a time)."""
    rings = config.press.n_rings if config.press is not None else 0
    return Estimate("press rings", f"[press] n_rings = {rings}", _RING_PAIR_B * rings * rings)


def bem(config: SimConfig, refine: int = 1, jobs: int = 1, pressures: int = 1) -> Estimate:
    """The boundary-element reference: one task per pressure on the refined composite grid, ``jobs`` at once."""
    points, keys = _grids(config)
    grid = points * refine * refine
    per_task = max(_BEM_B * grid, _SUMMED_B * points)
    workers = _PROCESS_B * jobs if jobs > 1 else 0.0
    seconds = _BEM_POINT_S * grid * pressures / max(jobs, 1)
    where = f"{keys}, --refine {refine}, --jobs {jobs}"
    return Estimate("boundary-element reference", where, per_task * jobs + workers, seconds)


for _stage in (
    Stage("surfaces", surfaces, "generating (or levelling) both surfaces"),
    Stage("database", database, "the contact database, per model"),
    Stage("rig", rig, "the rig's batch equilibrium on its mesh"),
    Stage("press", press, "the press's layer solve on its rings"),
    Stage("bem", bem, "the boundary-element reference"),
):
    STAGES.register(_stage, replace=True)


# ---------------------------------------------------------------------------------------------------------------
# The checks of the entry points.


def check_database(config: SimConfig, models: Sequence[str] | None = None, n_separations: int | None = None) -> None:
    """Refuse building the database when it cannot fit (:func:`contactrig.core.budget.check`); with the ``bem``
    model on the GPU (:func:`sims.bem_backend.use_device`), also its solves' device memory."""
    check([database(config, models, n_separations)])
    from sims.bem_backend import default_device

    names = list(models) if models is not None else list(config.database.models)
    if "bem" in names and default_device() == "gpu":
        shape, keys = _largest_shape(config)
        check_bem_gpu(shape, keys)


def check_specimen(
    config: SimConfig, models: Sequence[str] | None = None, weights_kg: Sequence[float] | None = None,
    *, build_database: bool = True,
) -> None:  # fmt: skip
    """Refuse a load sweep of the scene's specimen (its database, then its rig or press) that cannot fit."""
    stages = [database(config, models)] if build_database else []
    stages.append(press(config) if config.press is not None else rig(config, weights_kg))
    check(stages)


def check_comparison(
    config: SimConfig, models: Sequence[str], refine: int, jobs: int, pressures: int, device: str = "cpu"
) -> None:
    """Refuse a boundary-element comparison that cannot fit: ``jobs`` tasks at once, each a BEM solve or a model's
    database on one realisation; on the GPU also one solve's device memory (:func:`check_bem_gpu`)."""
    if device == "gpu":
        (ny, nx), keys = _largest_shape(config)
        check_bem_gpu((ny * refine, nx * refine), f"{keys}, --refine {refine}")
    tasks = [bem(config, refine, jobs, pressures)]
    if models:
        db = database(config, models)
        tasks.append(Estimate(db.what, db.keys, db.peak_bytes * jobs + (_PROCESS_B * jobs if jobs > 1 else 0.0)))
    check(tasks)


# ---------------------------------------------------------------------------------------------------------------
# The GPU's memory (boundary elements on CuPy, issue 28).

#: Device memory of one FFT-BEM solve per grid point [bytes], measured on an H200: CuPy's memory pool held 154 B per
#: point after a 4096² solve (2026-11-27, ``tests/benchmarks/profile_bem_gpu.py``), and 142–188 B (host decisions)
#: and 178–220 B (the iterations in groups, with fused kernels since taken out) after the solves of one grid at
#: 1024²–8192² (``tests/benchmarks/bench_bem_gpu.sh --quick``, ``gpu_runs/2026-11-27_h200_4_quick.txt``). The pool
#: keeps what it held, so these are peaks: z, p, w, t, the contact mask, the half spectra (float64 and the float32
#: filter's), the interleaved symbols, the support's index arrays, a group's kept pressures and cuFFT's plans and
#: work areas. The largest, rounded up. (Before: 128 B, not measured; then 160 B, from the 4096² figure alone.)
_BEM_GPU_B = 224.0


def bem_gpu(n: int | tuple[int, int], key: str = "[surfaces.*] n") -> Estimate:
    """One boundary-element solve of an ny×nx grid (``n``: the shape, or one int for n×n) on the GPU (device
    memory, proportional to ny·nx)."""
    ny, nx = (int(n), int(n)) if isinstance(n, numbers.Integral) else tuple(n)  # type: ignore[arg-type]
    return Estimate("boundary-element solve on the GPU", f"{key} (grid {ny}×{nx})", _BEM_GPU_B * ny * nx)


def check_bem_gpu(n: int | tuple[int, int], key: str = "[surfaces.*] n", free_bytes: float | None = None) -> Estimate:
    """Refuse (:class:`~contactrig.core.budget.BudgetError`) an ny×nx solve (``n``: the shape, or one int for n×n)
    that cannot fit the GPU's free memory (``free_bytes``, default :func:`sims.bem_backend.gpu_memory_bytes`; nothing
    is refused when unknown)."""
    from contactrig.core.budget import BudgetError
    from sims.bem_backend import gpu_memory_bytes

    est = bem_gpu(n, key)
    free = gpu_memory_bytes() if free_bytes is None else free_bytes
    if free is not None and est.peak_bytes > free:
        raise BudgetError(est, float(free), "free on the GPU")
    return est


STAGES.register(Stage("bem_gpu", bem_gpu, "one boundary-element solve on the GPU (device memory)"), replace=True)
