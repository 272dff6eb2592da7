"""Where the boundary-element solver's arrays live: NumPy on the CPU or CuPy on an NVIDIA GPU.

One solver (:mod:`sims.bem`) runs over an *array namespace* ``xp`` (NumPy or CuPy: the same function names,
``xp.flatnonzero``, ``xp.vdot``, …) and the few operations that differ between them, gathered here in a
:class:`Backend`:

* the real FFT pair ``rfft2`` / ``irfft2`` — on the CPU ``scipy.fft`` with ``workers`` threads (the inverse axis by
  axis, faster with several workers); on the GPU cuFFT through ``cupyx.scipy.fft`` with plans made once per grid
  (the inverse overwriting its input spectrum, as on the CPU);
* the copies between host and device (``asarray``, ``to_host``);
* the element-wise passes over the ny×nx fields and their half spectra (:meth:`Backend.rows`): on the CPU in
  cache-sized blocks of rows, spread over the ``workers`` threads (NumPy's ufuncs release the GIL), so that several
  operations on one block read memory once and every core takes part; on the GPU one call over the whole array
  (CuPy's element-wise operations are device kernels already; three passes fused into custom CuPy kernels made the
  solve 2–4× slower on an H200 and were taken out: docs, Benchmarks);
* whether the solver may take its decisions on the device (:attr:`Backend.defer`): on the GPU reading a value on the
  host waits for the card, so the solver keeps its scalars there and checks its iterations in groups
  (:mod:`sims.bem`); on the CPU every decision is taken at once, as it costs nothing.

A backend built from any other module passed as ``xp`` (NumPy itself, in the tests) uses the generic path the GPU
uses, ``xp.fft`` and plain array expressions, so the code the GPU runs is exercised on the CPU.

The device is ``"cpu"`` (default) or ``"gpu"``; :func:`use_device` sets the default for the solves inside a block
(the commands' ``--device`` and the scene key ``[scene] device``). The GPU needs CuPy (the optional extra ``gpu``,
``cupy-cuda12x``) and a CUDA device: without them :func:`get_backend` raises a :class:`SettingError` naming
``--device`` (one line, exit 2). Float64 throughout, but for the solver's float32 preconditioner filter.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from contextvars import ContextVar
from types import ModuleType
from typing import Any, TypeVar

import numpy as np
import scipy.fft as sfft

from contactrig.core.validation import SettingError, check_choice

__all__ = [
    "DEVICES",
    "DEVICE_DECISIONS",
    "Backend",
    "check_device",
    "default_device",
    "get_backend",
    "gpu_memory_bytes",
    "scene_device",
    "use_device",
]

DEVICES = ("cpu", "gpu")
_DEVICE: ContextVar[str] = ContextVar("contactrig_bem_device", default="cpu")
_BLOCK_BYTES = 1 << 18  # one block of rows of a complex half spectrum: 256 KiB, inside a core's L2 cache
_POOLS: dict[tuple[int, int], ThreadPoolExecutor] = {}
_T = TypeVar("_T")
#: False: on the GPU every decision of the solver is taken on the host as it comes, the behaviour before the
#: synchronisations were cut (kept to measure against: ``tests/benchmarks/bench_bem_gpu.py``).
DEVICE_DECISIONS = True
_GPU_HINT = "needs CuPy and an NVIDIA GPU: pip install 'contactrig[gpu]' (cupy-cuda12x)"


def check_device(device: str, key: str = "--device") -> str:
    """``device`` if it is one of :data:`DEVICES`, else a :class:`SettingError` naming ``key``."""
    return check_choice(key, device, DEVICES)


def scene_device(option: str | None, scene: Any) -> str:
    """The device of a command: its ``--device`` if given, else the scene's ``[scene] device``, else ``"cpu"``."""
    if option is not None:
        return check_device(option)
    table = getattr(scene, "data", {}).get("scene", {})
    return check_device(table.get("device", "cpu"), "[scene] device")


def default_device() -> str:
    """The device of solves that name none (``"cpu"`` unless inside :func:`use_device`)."""
    return _DEVICE.get()


@contextmanager
def use_device(device: str | None, key: str = "--device") -> Iterator[None]:
    """Within the block, solves that name no device run on ``device`` (None keeps the current default).

    The GPU is checked on entry (:func:`get_backend`), so a missing CuPy or card is refused before any work."""
    if device is None:
        yield
        return
    device = check_device(device, key)
    if device == "gpu":
        _cupy(key)
    token = _DEVICE.set(device)
    try:
        yield
    finally:
        _DEVICE.reset(token)


def _cupy(key: str = "--device") -> ModuleType:
    """CuPy with at least one CUDA device, or a :class:`SettingError` naming ``key``."""
    try:
        import cupy  # type: ignore[import-not-found, import-untyped, unused-ignore]
    except ImportError:
        raise SettingError(key, "gpu", _GPU_HINT) from None
    try:
        count = int(cupy.cuda.runtime.getDeviceCount())
    except Exception:  # CUDA errors come in many classes (no driver, no device)
        count = 0
    if count < 1:
        raise SettingError(key, "gpu", "found no CUDA device (CuPy is installed; is the driver loaded?)")
    return cupy  # type: ignore[no-any-return, unused-ignore]


def gpu_memory_bytes() -> int | None:
    """Free memory of the current CUDA device [bytes]; None without CuPy or a device."""
    try:
        cupy = _cupy()
        free, _total = cupy.cuda.runtime.memGetInfo()
    except Exception:  # no CuPy, no device, no driver
        return None
    return int(free)


class Backend:
    """The array namespace ``xp`` and the operations that differ between NumPy and CuPy (see module doc).

    ``name`` is ``"cpu"`` or ``"gpu"``; ``workers`` the FFT threads on the CPU; ``fast`` is True for NumPy with
    ``scipy.fft`` (the default CPU path), False for the generic namespace path.
    """

    def __init__(self, xp: ModuleType, name: str, workers: int, fast: bool) -> None:
        self.xp = xp
        self.name = name
        self.workers = workers
        self.fast = fast
        self.cufft = _cufft_module() if name == "gpu" and xp is not np else None
        #: decisions on the device, checked on the host in groups of iterations (:mod:`sims.bem`); the generic path
        #: only (NumPy itself in the tests), and not when :data:`DEVICE_DECISIONS` is False
        self.defer = not fast and DEVICE_DECISIONS

    def rfft2(self, x: Any) -> Any:
        """The half spectrum of a real ny×nx array (a new complex array)."""
        if self.fast:
            return sfft.rfft2(x, workers=self.workers)
        if self.cufft is not None:
            plan = _cufft_plan(self.cufft, x, "R2C", x.shape)
            if plan is not None:
                return self.cufft.rfft2(x, plan=plan)
        return self.xp.fft.rfft2(x)

    def irfft2(self, spectrum: Any, shape: tuple[int, int]) -> Any:
        """The real ny×nx array (``shape``) of a half spectrum; ``spectrum`` may be overwritten.

        On the CPU the inverse is done axis by axis (complex ``ifft`` in place along axis 0, then ``irfft`` along
        axis 1): with several workers markedly faster than ``irfft2`` in SciPy 1.11–1.17 (1.7× at 1024², 2 threads).
        """
        if self.fast:
            spectrum = sfft.ifft(spectrum, axis=0, workers=self.workers, overwrite_x=True)
            return sfft.irfft(spectrum, n=shape[1], axis=1, workers=self.workers)
        if self.cufft is not None:
            plan = _cufft_plan(self.cufft, spectrum, "C2R", shape)
            if plan is not None:
                return self.cufft.irfft2(spectrum, s=shape, plan=plan, overwrite_x=True)
        return self.xp.fft.irfft2(spectrum, s=shape)

    def rows(self, fn: Callable[[slice], _T], n: int, width: int | None = None) -> list[_T]:
        """``fn(rows)`` over blocks of the ``n`` rows of the solver's n × ``width`` arrays (default ``width`` = n)
        and their half spectra; results in row order.

        On the CPU the blocks are cache-sized (256 KiB of a half spectrum), so the operations ``fn`` does on one block
        (in place, ``out=``) read and write memory once, as one fused pass would; consecutive blocks are split into
        ``workers`` equal groups, the first run by the calling thread, the others by a pool of ``workers − 1`` threads
        (an exception in ``fn`` is raised here). The blocks depend on the shape only, so results summed over them
        do not depend on the thread count. Generic namespace path: one call, ``fn(slice(None))``.
        """
        if not self.fast:
            return [fn(slice(None))]
        step = max(1, _BLOCK_BYTES // (8 * ((n if width is None else width) + 2)))
        blocks = [slice(i, min(i + step, n)) for i in range(0, n, step)]
        k = min(self.workers, len(blocks))
        if k == 1:
            return [fn(b) for b in blocks]
        groups = [blocks[j * len(blocks) // k : (j + 1) * len(blocks) // k] for j in range(k)]

        def run(group: list[slice]) -> list[_T]:
            return [fn(b) for b in group]

        pool = _pool(k - 1)
        others = [pool.submit(run, group) for group in groups[1:]]
        first = run(groups[0])
        return first + [r for task in others for r in task.result()]

    def asarray(self, x: Any) -> Any:
        """``x`` as a float64 array of this backend (a copy on the GPU)."""
        return self.xp.asarray(x, dtype=self.xp.float64)

    def to_host(self, x: Any) -> np.ndarray:
        """``x`` as a NumPy array (a copy from the GPU; the array itself on the CPU)."""
        if self.xp is np:
            return np.asarray(x)
        return self.xp.asnumpy(x)  # type: ignore[no-any-return, unused-ignore]


def _pool(workers: int) -> ThreadPoolExecutor:
    """A pool of ``workers`` started threads for :meth:`Backend.rows`, one per process (a forked child makes its own).

    The threads are started at once (each held at a barrier until all exist): a pool that starts its threads lazily
    may run quick tasks one after another on the one thread it has."""
    key = (os.getpid(), workers)
    pool = _POOLS.get(key)
    if pool is None:
        pool = ThreadPoolExecutor(workers, thread_name_prefix="contactrig-bem")
        barrier = threading.Barrier(workers)
        for task in [pool.submit(barrier.wait) for _ in range(workers)]:
            task.result()
        _POOLS[key] = pool
    return pool


def _cufft_module() -> ModuleType | None:
    """``cupyx.scipy.fft`` (cuFFT with explicit plans), or None where it cannot be imported."""
    try:
        import cupyx.scipy.fft as cufft  # type: ignore[import-not-found, import-untyped, unused-ignore]
    except Exception:  # an older or partial CuPy: the plain cupy.fft path (plans from CuPy's own cache)
        return None
    return cufft  # type: ignore[no-any-return, unused-ignore]


_PLANS: dict[tuple[str, str, tuple[int, ...], tuple[int, ...]], Any] = {}
_PLAN_LIMIT = 8  # plans kept (each holds its cuFFT work area on the card): two grids' forward and inverse, 2 dtypes


def _cufft_plan(cufft: ModuleType, a: Any, kind: str, out_shape: tuple[int, ...]) -> Any:
    """The cuFFT plan of one real 2-D transform (``"R2C"`` or ``"C2R"``) of arrays shaped like ``a``, made once.

    Handing the plan to the transform skips CuPy's per-call plan lookup, which measured 1.6 ms per transform on an
    H200 at 4096² (``tests/benchmarks/profile_bem_gpu.py``; the transform itself is 0.3 ms). None if CuPy cannot
    make one (then the caller uses ``cupy.fft``, which plans on its own)."""
    key = (kind, str(a.dtype), tuple(a.shape), tuple(out_shape))
    plan = _PLANS.get(key)
    if plan is None:
        try:
            plan = cufft.get_fft_plan(a, shape=out_shape, axes=(0, 1), value_type=kind)
        except Exception:  # CuPy's plan API differs between versions: the plain path is always right
            return None
        while len(_PLANS) >= _PLAN_LIMIT:
            _PLANS.pop(next(iter(_PLANS)))
        _PLANS[key] = plan
    return plan


def get_backend(device: str | None = None, workers: int | None = None, xp: ModuleType | None = None) -> Backend:
    """The backend of ``device`` (default :func:`default_device`) with ``workers`` FFT threads (default: every core).

    ``xp``: use this array namespace on the generic path instead (NumPy in the tests: the GPU's code on the CPU).
    """
    threads = workers if workers is not None else (os.cpu_count() or 1)
    if xp is not None:
        return Backend(xp, "gpu" if xp is not np else "cpu", threads, fast=False)
    name = check_device(device if device is not None else default_device(), "device")
    if name == "gpu":
        return Backend(_cupy("device"), "gpu", threads, fast=False)
    return Backend(np, "cpu", threads, fast=True)
