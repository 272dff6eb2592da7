"""Contact models against the boundary-element reference, over surface realisations, as independent tasks.

One surface realisation is one sample: realisation k of a scene regenerates both surfaces with seeds derived from the
scene's own (k = 0 is the scene as written, the surface pair of its contact database; k ≥ 1 takes
``SeedSequence([seed, k])``). For every realisation the work is split into independent tasks:

* ``(k, "bem", p̄)`` — one mean pressure p̄ (Pa) on the composite surface z_liner + z_piston
  (:func:`sims.bem.solve_load_path`, elastic–perfectly-plastic with the softer body's hardness unless
  ``plastic=False``): real-area fraction (perimeter-corrected or counted), mean gap ū (m), separation of the mean
  planes h = max z − mean z − δ (m), interfacial stiffness K = −dp̄/dū (Pa/m: by default the tangent, one linear solve
  on the contact set, :mod:`sims.bem_stiffness`; or the centred difference at p̄(1 ± step), ``stiffness="centred"``),
  contact spots, iterations;
* ``(k, model, all p̄)`` — an asperity or statistical model's curve from :func:`sims.database.build_database` on the
  same realisation, inverted at each p̄: h(p̄) (its "mean gap", the database's separation of the mean planes — the
  asperity models have no bulk deformation, so this is the separation they predict at p̄), A/A₀ at h and
  K = −dp/dh (Pa/m, the curve's analytic slope). A pressure beyond the curve's tabulated range rebuilds it deeper
  (``h_min_sigma`` down to −3); what still lies beyond is kept (tangent extrapolation, finite) with ``in_range``
  False and left out of every summary.

Tasks run in this process (``jobs=1``), on local processes (default: one per core, each with one FFT thread), or on
a Dask cluster (``scheduler="tcp://host:port"``, the optional extra ``dask``). Each task is a pure function of
(configuration, settings, task), so the same seeds give the same numbers on every executor.

Physics only: arrays in, results out; no files.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field, replace
from functools import partial
from itertools import pairwise
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray
from scipy import optimize

from contactrig.core.validation import SettingError, check_choice, check_int, check_range
from sims.budget import check_comparison

#: ``progress(done, total)`` of long work (the command draws it: contactrig.cli.progress); library code never prints.
Progress = Callable[[int, int], None]

if TYPE_CHECKING:
    from sims.config import SimConfig
    from sims.database import ContactCurve

__all__ = [
    "CompareSettings",
    "Comparison",
    "Task",
    "TaskResult",
    "geometric_pressures",
    "make_tasks",
    "realisation_config",
    "run_comparison",
    "run_task",
]

BEM = "bem"
#: BEM's stiffness schemes in a comparison (:func:`sims.bem.solve_load_path`): the tangent first, the default.
STIFFNESS_METHODS = ("tangent", "centred")
_H_MIN_SIGMA_STEPS = (-0.5, -1.0, -1.5, -2.0, -3.0)
_Array = NDArray[np.float64]


@dataclass(frozen=True)
class CompareSettings:
    """What to compare. ``pressures_pa``: mean nominal pressures, Pa, strictly increasing, > 0. ``models``:
    registered model keys to rank (not ``"bem"``, the reference). ``realisations``: surface realisations (1…1000).
    ``plastic``: BEM with the hardness cap. ``area``: BEM area ``"corrected"`` (perimeter correction, Yastrebov et
    al. 2017) or ``"counted"``. ``stiffness``: how BEM's K = −dp̄/dū is found, ``"tangent"`` (default: one linear solve
    on the contact set, :mod:`sims.bem_stiffness`) or ``"centred"`` (two more nonlinear solves at p̄(1 ± step)).
    ``step``: relative pressure step of the centred stiffness (0…0.5). ``refine``:
    Fourier refinement factor of the composite surface for BEM (1…8). ``tol``, ``max_iter``: BEM solver settings."""

    pressures_pa: tuple[float, ...]
    models: tuple[str, ...]
    realisations: int = 1
    plastic: bool = True
    area: str = "corrected"
    stiffness: Literal["tangent", "centred"] = "tangent"
    step: float = 5e-3
    refine: int = 1
    tol: float = 1e-6
    max_iter: int = 5000

    def __post_init__(self) -> None:
        from sims.database import check_models

        p = tuple(
            float(check_range(f"pressures[{i}]", v, 0.0, None, lo_open=True, unit="Pa"))
            for i, v in enumerate(self.pressures_pa)
        )
        if not p or any(b <= a for a, b in pairwise(p)):
            raise SettingError("pressures", list(p), "expected strictly increasing mean pressures in Pa")
        object.__setattr__(self, "pressures_pa", p)
        models = check_models("--models", self.models)
        if BEM in models:
            raise SettingError("--models", BEM, "is the reference; list the models to compare with it")
        object.__setattr__(self, "models", models)
        check_int("--realisations", self.realisations, 1, 1000)
        check_choice("area", self.area, ("corrected", "counted"))
        check_choice("stiffness", self.stiffness, STIFFNESS_METHODS)
        check_range("step", self.step, 0.0, 0.5, lo_open=True)
        check_int("refine", self.refine, 1, 8)


@dataclass(frozen=True)
class Task:
    """One independent piece of work: realisation ``realisation``, model ``model`` (``"bem"`` or a registered
    key), at the mean pressures ``pressures_pa`` (Pa; one for BEM)."""

    realisation: int
    model: str
    pressures_pa: tuple[float, ...]


@dataclass(frozen=True, eq=False)
class TaskResult:
    """What a task returns (arrays over its pressures). ``separation_m``: separation of the mean planes h (m);
    ``mean_gap_m``: ū (m; = h for the models); ``area_fraction``: A/A₀; ``stiffness_pa_per_m``: K = −dp/dū;
    ``in_range``: inside the model's tabulated curve (always True for BEM); ``info``: solver record; ``seconds``:
    wall time of the task."""

    realisation: int
    model: str
    pressure_pa: _Array
    separation_m: _Array
    mean_gap_m: _Array
    area_fraction: _Array
    stiffness_pa_per_m: _Array
    in_range: NDArray[np.bool_]
    info: dict[str, Any] = field(default_factory=dict)
    seconds: float = 0.0


@dataclass(frozen=True, eq=False)
class Comparison:
    """Every task's result, gathered: ``quantity(model, name)`` → array (realisations × pressures) of
    ``"area_fraction"``, ``"mean_gap_m"``, ``"separation_m"``, ``"stiffness_pa_per_m"`` or ``"in_range"``."""

    settings: CompareSettings
    results: tuple[TaskResult, ...]
    provenance: dict[str, Any] = field(default_factory=dict)

    @property
    def pressures_pa(self) -> _Array:
        return np.asarray(self.settings.pressures_pa)

    @property
    def models(self) -> tuple[str, ...]:
        return self.settings.models

    def quantity(self, model: str, name: str) -> NDArray[Any]:
        """(realisations × pressures) array of ``name`` for ``model`` (``"bem"`` or a compared model)."""
        st = self.settings
        index = {p: j for j, p in enumerate(st.pressures_pa)}
        first = getattr(self.results[0], name)
        out = np.zeros((st.realisations, len(st.pressures_pa)), dtype=first.dtype)
        for r in self.results:
            if r.model != model:
                continue
            for p, v in zip(r.pressure_pa, getattr(r, name), strict=True):
                out[r.realisation, index[float(p)]] = v
        return out


# ---------------------------------------------------------------------------------------------------------------
# Realisations and tasks.


def _derived_seed(seed: int, k: int) -> int:
    return seed if k == 0 else int(np.random.SeedSequence([seed, k]).generate_state(1)[0])


def realisation_config(config: SimConfig, k: int) -> SimConfig:
    """The scene with both surfaces regenerated for realisation ``k`` (0: the scene itself)."""
    k = check_int("realisation", k, 0, 10**6)
    if k == 0:
        return config
    for spec in (config.liner, config.piston):
        if spec.kind == "file":
            raise SettingError("--realisations", k + 1, f"{spec.section} is a measured map: it has one realisation")
    return config.with_changes(
        liner=replace(config.liner, seed=_derived_seed(config.liner.seed, k)),
        piston=replace(config.piston, seed=_derived_seed(config.piston.seed, k)),
    )


def make_tasks(settings: CompareSettings) -> list[Task]:
    """Every task: per realisation one BEM task per pressure (highest first: the costliest start first) and one task
    per compared model."""
    tasks: list[Task] = []
    for k in range(settings.realisations):
        tasks += [Task(k, BEM, (p,)) for p in reversed(settings.pressures_pa)]
        tasks += [Task(k, m, settings.pressures_pa) for m in settings.models]
    return tasks


# ---------------------------------------------------------------------------------------------------------------
# One task.


def _bem_task(config: SimConfig, st: CompareSettings, task: Task, workers: int) -> TaskResult:
    from sims import bem
    from sims.bem_database import composite_from_config

    z, pixel = composite_from_config(config)
    if st.refine > 1:
        z, pixel = bem.refine(z, st.refine), pixel / st.refine
    hardness = config.materials.H if st.plastic else None
    peak = float(z.max() - z.mean())
    path = bem.solve_load_path(
        z, pixel, config.materials.E_star, list(task.pressures_pa), hardness,
        stiffness=st.stiffness, step=st.step, tol=st.tol, max_iter=st.max_iter, workers=workers, keep_fields=False,
    )  # fmt: skip
    res = path.results
    area = [s.area_fraction_corrected if st.area == "corrected" else s.area_fraction for s in res]
    info = {
        "nit": path.nit,
        "success": path.success,
        "area_counted": [s.area_fraction for s in res],
        "area_corrected": [s.area_fraction_corrected for s in res],
        "n_spots": [s.n_spots for s in res],
        "mean_spot_area_m2": [float(s.spot_areas.mean()) if s.n_spots else 0.0 for s in res],
        "plastic_fraction": [s.plastic_fraction for s in res],
        "residual": [s.residual for s in res],
        "n": int(z.shape[1]),
        "shape": [int(k) for k in z.shape],
        "pixel_m": pixel,
    }
    return TaskResult(
        task.realisation, BEM, np.asarray(task.pressures_pa), np.array([peak - s.approach for s in res]),
        np.asarray(path.mean_gap), np.asarray(area), np.asarray(path.stiffness), np.ones(len(res), dtype=bool), info,
    )  # fmt: skip


def _curve_covering(config: SimConfig, model: str, p_max: float) -> ContactCurve:
    """The model's curve on this realisation, rebuilt deeper while ``p_max`` is beyond its tabulated range."""
    from sims.database import build_database

    curve = build_database(config, [model])[model]
    for h_min_sigma in _H_MIN_SIGMA_STEPS:
        if curve.pressure_pa[0] >= p_max:
            break
        if h_min_sigma >= config.database.h_min_sigma:
            continue
        deeper = config.with_changes(database=replace(config.database, h_min_sigma=h_min_sigma))
        try:
            curve = build_database(deeper, [model])[model]
        except SettingError:  # an independent-asperity model's area exceeds 1 there: keep the last one
            break
    return curve


def _separation_at(curve: ContactCurve, p: float) -> float:
    """h (m) with curve.pressure(h) = p (Pa); below h_min the tangent extrapolation (caller checks in_range)."""
    lo, hi = curve.h_min, curve.h_max
    span = hi - lo
    for _ in range(200):  # GT's log-linear tail: p > 0 above h_max
        if float(curve.pressure(hi)) <= p:
            break
        hi += span
    for _ in range(200):
        if float(curve.pressure(lo)) >= p:
            break
        lo -= span
    return float(optimize.brentq(lambda h: float(curve.pressure(h)) - p, lo, hi, xtol=1e-12 * span, rtol=1e-13))


def _model_task(config: SimConfig, st: CompareSettings, task: Task) -> TaskResult:
    import warnings

    p = np.asarray(task.pressures_pa)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # validity notes are in the database provenance
        curve = _curve_covering(config, task.model, float(p.max()))
    h = np.array([_separation_at(curve, float(v)) for v in p])
    area = np.clip(curve.area_fraction_at(h), 0.0, 1.0)
    stiff = -curve.dpressure_dh(h)
    info = {"h_min_m": curve.h_min, "h_max_m": curve.h_max}
    return TaskResult(task.realisation, task.model, p, h, h.copy(), area, stiff, curve.in_range(h), info)


def run_task(
    config: SimConfig, settings: CompareSettings, task: Task, workers: int = 1, device: str | None = None
) -> TaskResult:
    """Run one task on realisation ``task.realisation`` of ``config`` with ``workers`` FFT threads; BEM on
    ``device`` (``"cpu"``/``"gpu"``, :mod:`sims.bem_backend`; None: this process's default)."""
    from sims.bem_backend import use_device

    t0 = time.perf_counter()
    cfg = realisation_config(config, task.realisation)
    with use_device(device):
        out = _bem_task(cfg, settings, task, workers) if task.model == BEM else _model_task(cfg, settings, task)
    return replace(out, seconds=time.perf_counter() - t0)


# ---------------------------------------------------------------------------------------------------------------
# Executors.


def _counted(results: Iterable[TaskResult], total: int, progress: Progress | None) -> list[TaskResult]:
    """The results, ``progress(done, total)`` called as each arrives."""
    out = []
    for r in results:
        out.append(r)
        if progress is not None:
            progress(len(out), total)
    return out


def _run_local(
    fn: Callable[[Task], TaskResult], tasks: Sequence[Task], jobs: int, progress: Progress | None = None
) -> list[TaskResult]:
    if jobs == 1:
        return _counted((fn(t) for t in tasks), len(tasks), progress)
    import multiprocessing

    from contactrig.core.budget import set_process_limit

    # run_comparison checked the memory of all workers together: a worker's own check must not count its siblings
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(jobs, mp_context=context, initializer=set_process_limit, initargs=(math.inf,)) as pool:
        return _counted(pool.map(fn, tasks), len(tasks), progress)


def _run_dask(
    fn: Callable[[Task], TaskResult], tasks: Sequence[Task], scheduler: str, timeout_s: float | None, gpu: bool = False
) -> list[TaskResult]:
    try:
        from distributed import Client
    except ImportError:
        raise SettingError(
            "--scheduler", scheduler, "needs Dask: pip install 'contactrig[dask]' (dask[distributed])"
        ) from None
    with Client(scheduler, timeout=30 if timeout_s is None else timeout_s, set_as_default=False) as client:
        # On the GPU every task asks for one unit of the workers' resource "GPU" (dask-worker --resources GPU=1):
        # one realisation's solve per card at a time, on workers that have one.
        futures = client.map(fn, list(tasks), pure=False, resources={"GPU": 1} if gpu else None)
        return list(client.gather(futures))


def run_comparison(
    config: SimConfig,
    settings: CompareSettings,
    *,
    scheduler: str | None = None,
    jobs: int | None = None,
    timeout_s: float | None = None,
    progress: Progress | None = None,
) -> Comparison:
    """Run every task of ``settings`` on ``config`` and gather them (see the module doc).

    ``scheduler``: address of a Dask scheduler (``"tcp://127.0.0.1:8786"``); None: local. ``jobs``: local processes
    (default ``os.cpu_count()``; 1 runs in this process with every core as FFT threads). Local processes and Dask
    tasks use one FFT thread each. ``progress(done, total)``: called as tasks finish (local runs; a Dask run
    reports once, when gathered).
    """
    from sims.bem_backend import default_device

    device = default_device()  # the caller's (use_device): handed to every task, in any process
    cores = os.cpu_count() or 1
    # one GPU: its solves run one after another in this process unless --jobs says otherwise
    jobs = (1 if device == "gpu" else cores) if jobs is None else check_int("--jobs", jobs, 1, 1024)
    tasks = make_tasks(settings)
    jobs = min(jobs, len(tasks))
    if scheduler is None:  # a cluster's memory is its own
        check_comparison(config, settings.models, settings.refine, jobs, len(settings.pressures_pa), device=device)
    workers = cores if (jobs == 1 and scheduler is None) else 1
    fn = partial(run_task, config, settings, workers=workers, device=device)
    t0 = time.perf_counter()
    if scheduler is not None:
        results = _counted(_run_dask(fn, tasks, scheduler, timeout_s, gpu=device == "gpu"), len(tasks), progress)
        executor = f"dask {scheduler}"
    else:
        results = _run_local(fn, tasks, jobs, progress)
        executor = "this process" if jobs == 1 else f"{jobs} local processes"
    prov = {
        "executor": executor,
        "fft_threads_per_task": workers,
        "device": device,
        "tasks": len(tasks),
        "wall_s": time.perf_counter() - t0,
        "task_s": float(sum(r.seconds for r in results)),
        "scene_name": config.name,
        "E_star_pa": config.materials.E_star,
        "H_pa": config.materials.H if settings.plastic else None,
        "seeds": [
            (realisation_config(config, k).liner.seed, realisation_config(config, k).piston.seed)
            for k in range(settings.realisations)
        ],
    }
    return Comparison(settings, tuple(results), prov)


def geometric_pressures(lo_pa: float, hi_pa: float, count: int) -> tuple[float, ...]:
    """``count`` mean pressures spaced geometrically from ``lo_pa`` to ``hi_pa`` (Pa)."""
    lo = check_range("pressure_min", lo_pa, 0.0, None, lo_open=True, unit="Pa")
    hi = check_range("pressure_max", hi_pa, lo, None, lo_open=True, unit="Pa")
    count = check_int("pressure_count", count, 1, 1000)
    if count == 1:
        return (math.sqrt(lo * hi),)
    return tuple(float(v) for v in np.geomspace(lo, hi, count))
