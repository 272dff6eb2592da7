"""A stand-in for CuPy on the CPU: NumPy underneath, CuPy's host synchronisations counted (a test helper).

Not CuPy: ``tests/sims/test_bem_sync.py`` imports it to run the solver's GPU path (``sims.bem`` over the namespace
``xp``) without a GPU, and ``PYTHONPATH=tests/sims/fake_cupy`` makes it ``import cupy`` for the GPU benchmark's
end-to-end check (``tests/benchmarks/bench_bem_gpu.py --quick``). What it imitates:

* arrays are :class:`ndarray`, a NumPy subclass, and reductions return 0-d arrays, not Python or NumPy scalars
  (as CuPy's do), so that reading a value on the host is an explicit act;
* every act that makes CuPy wait for the card and copy to the host is counted in :data:`SYNCS` by kind and by the
  solver's source line: ``float()``/``int()``/``bool()``/``.item()``/``.tolist()``/formatting of an array,
  ``asnumpy``, boolean-mask indexing (its result's size is data-dependent), ``nonzero``/``flatnonzero``/``argwhere``/
  ``unique``;
* ``fuse`` is the identity decorator and ``ElementwiseKernel``/``ReductionKernel`` are absent (the solver uses none:
  fused kernels were measured slower on an H200 and taken out); ``cuda`` has one device with 16 GiB free.
"""

from __future__ import annotations

import collections
import sys
import types
from typing import Any

import numpy

__version__ = "0.0-fake"

#: (kind, "file:line" of the nearest caller in sims/) → count; reset with ``SYNCS.clear()``.
SYNCS: collections.Counter[tuple[str, str]] = collections.Counter()


def _where() -> str:
    frame = sys._getframe(2)
    while frame is not None:
        name = frame.f_code.co_filename
        if "/sims/" in name and "/tests/" not in name:
            return f"{name.rsplit('/sims/', 1)[1]}:{frame.f_lineno} {frame.f_code.co_name}"
        frame = frame.f_back  # type: ignore[assignment]
    return "?"


def _sync(kind: str) -> None:
    SYNCS[(kind, _where())] += 1


def _is_mask(key: Any) -> bool:
    keys = key if isinstance(key, tuple) else (key,)
    return any(isinstance(k, numpy.ndarray) and k.dtype == bool and k.ndim > 0 for k in keys)


class ndarray(numpy.ndarray):
    """A NumPy array that counts CuPy's host synchronisations and keeps 0-d results as arrays."""

    def __array_wrap__(self, obj: Any, context: Any = None, return_scalar: bool = False) -> Any:
        return numpy.asarray(obj).view(ndarray)

    def __float__(self) -> float:
        _sync("float()")
        return float(numpy.asarray(self))

    def __int__(self) -> int:
        _sync("int()")
        return int(numpy.asarray(self))

    def __index__(self) -> int:
        _sync("index()")
        return numpy.asarray(self).__index__()

    def __bool__(self) -> bool:
        _sync("bool()")
        return bool(numpy.asarray(self))

    def __format__(self, spec: str) -> str:
        _sync("format()")
        return format(numpy.asarray(self)[()], spec)

    def item(self, *args: Any) -> Any:
        _sync("item()")
        return numpy.asarray(self).item(*args)

    def tolist(self) -> Any:
        _sync("tolist()")
        return numpy.asarray(self).tolist()

    def nonzero(self) -> Any:
        _sync("nonzero()")
        return tuple(a.view(ndarray) for a in numpy.asarray(self).nonzero())

    def __getitem__(self, key: Any) -> Any:
        if _is_mask(key):
            _sync("mask[]")
        out = super().__getitem__(key)
        return out.view(ndarray) if isinstance(out, numpy.ndarray) else numpy.asarray(out).view(ndarray)

    def __setitem__(self, key: Any, value: Any) -> None:
        if _is_mask(key):
            _sync("mask[]=")
        super().__setitem__(key, value)


def _wrap(x: Any) -> Any:
    if isinstance(x, numpy.ndarray):
        return x if isinstance(x, ndarray) else x.view(ndarray)
    if isinstance(x, numpy.generic):
        return numpy.asarray(x).view(ndarray)
    if isinstance(x, tuple):
        return tuple(_wrap(v) for v in x)
    if isinstance(x, list):
        return [_wrap(v) for v in x]
    return x


def _wrapped(fn: Any, kind: str | None = None) -> Any:
    def call(*args: Any, **kwargs: Any) -> Any:
        if kind is not None:
            _sync(kind)
            args = tuple(numpy.asarray(a) if isinstance(a, ndarray) else a for a in args)
        return _wrap(fn(*args, **kwargs))

    call.__name__ = getattr(fn, "__name__", "fn")
    return call


_SYNCING = {"flatnonzero": "flatnonzero()", "nonzero": "nonzero()", "argwhere": "argwhere()", "unique": "unique()"}


def __getattr__(name: str) -> Any:
    if name in ("ElementwiseKernel", "ReductionKernel", "RawKernel"):
        raise AttributeError(name)  # the solver must fall back to plain array expressions
    value = getattr(numpy, name)
    if isinstance(value, type) or not callable(value):
        return value
    return _wrapped(value, _SYNCING.get(name))


def asnumpy(x: Any) -> numpy.ndarray:
    _sync("asnumpy()")
    return numpy.array(x, copy=True).view(numpy.ndarray)


def asarray(x: Any, dtype: Any = None) -> ndarray:
    return numpy.array(x, dtype=dtype, copy=True).view(ndarray)  # a copy "to the card"


def fuse(*args: Any, **kwargs: Any) -> Any:
    """CuPy's kernel fusion: here the function itself."""
    if len(args) == 1 and callable(args[0]) and not kwargs:
        return args[0]
    return lambda fn: fn


fft = types.SimpleNamespace(**{k: _wrapped(getattr(numpy.fft, k)) for k in ("rfft2", "irfft2", "fftfreq", "rfftfreq")})
random = numpy.random


class _Runtime:
    @staticmethod
    def getDeviceCount() -> int:
        return 1

    @staticmethod
    def getDeviceProperties(i: int) -> dict[str, Any]:
        return {"name": b"FakeGPU (NumPy)"}

    @staticmethod
    def memGetInfo() -> tuple[int, int]:
        return (16 << 30, 16 << 30)


class _Device:
    def synchronize(self) -> None:
        pass


class _Pool:
    def free_all_blocks(self) -> None:
        pass

    def total_bytes(self) -> int:
        return 0  # nothing is held on a card here


cuda = types.SimpleNamespace(runtime=_Runtime, Device=_Device)


def get_default_memory_pool() -> _Pool:
    return _Pool()
