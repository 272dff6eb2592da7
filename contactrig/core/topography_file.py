"""Profilometer files: any format SurfaceTopography reads (X3P, SDF, SUR, DATX, PLU, OPD, GWY, NetCDF, …), bounded.

:func:`read_topography_file` turns the bytes of a measured file into a :class:`Measured`: the heights as numbers in
the file's own height unit (rows = y, columns = x; NaN where the instrument recorded no point), the file's pixel
size and height unit in metres (None when the file does not say), the instrument's name and the format.

The guarantees of :mod:`contactrig.core.inputs` hold for every format:

* the file is read once, by :func:`~contactrig.core.inputs.read_input_bytes` (a regular file, at most
  ``HEIGHT_MAP_MAX_BYTES``, within ``READ_TIMEOUT_S``), *before* the library sees anything; the library parses
  those bytes from memory, never the path;
* the library parses in a forked child process with a deadline (:data:`PARSE_TIMEOUT_S`): a damaged file that makes
  a reader loop or crash is a one-line error, and the child is killed; it never outlives this process
  (:mod:`contactrig.core.child_process`);
* the grid size the file declares is checked against ``HEIGHT_MAP_MAX_SIDE`` before the heights are decoded.

SurfaceTopography (the optional extra ``surfaces``) is imported only here and only in that child, so
``contactrig.core`` stays light. Every refusal is a :class:`SettingError` naming the scene key.
"""

from __future__ import annotations

import io
import pickle
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from contactrig.core.child_process import ChildDied, ChildTimeout, run_in_child
from contactrig.core.inputs import HEIGHT_MAP_MAX_SIDE
from contactrig.core.validation import SettingError

__all__ = [
    "PARSE_TIMEOUT_S",
    "PIP_HINT",
    "Measured",
    "has_metadata_header",
    "read_topography_file",
    "surfaces_library_available",
]

#: Longest time the library may take to parse one file, s.
PARSE_TIMEOUT_S = 60.0

#: What to run when the library is missing.
PIP_HINT = "pip install 'contactrig[surfaces]' (or: pip install SurfaceTopography)"

#: Longest line profile, points (a stylus trace of 50 mm at 0.1 µm is 500 000).
PROFILE_MAX_POINTS = HEIGHT_MAP_MAX_SIDE * 256


@dataclass(frozen=True)
class Measured:
    """A measured topography as its file holds it.

    ``heights``: the file's numbers in its height unit (2-D rows = y × columns = x, or 1-D for a line profile; NaN
    where no point was measured); ``pixel_m``: the grid pitch in m (along x, the columns; None: the file gives none);
    ``pixel_y_m``: the pitch along y (the rows) when it differs from ``pixel_m`` (non-square pixels), else None;
    ``height_unit_m``: metres per unit of ``heights`` (None: the file gives no unit); ``instrument`` and
    ``file_format`` as named by the file and the library.
    """

    heights: NDArray[np.float64] = field(repr=False, compare=False)
    pixel_m: float | None
    height_unit_m: float | None
    instrument: str | None
    file_format: str
    pixel_y_m: float | None = None


def surfaces_library_available() -> bool:
    """Whether SurfaceTopography can be imported (without importing it)."""
    import importlib.util

    return importlib.util.find_spec("SurfaceTopography") is not None


def _instrument(info: dict[str, Any]) -> str | None:
    inst = info.get("instrument") if isinstance(info, dict) else None
    if isinstance(inst, dict) and inst.get("name"):
        return str(inst["name"])
    return None


def _pixel(sizes: Any, pts: tuple[int, ...], factor: float | None) -> tuple[float | None, float | None]:
    """The pitch in m along x and, for non-square pixels, along y (else None); (None, None): no sizes or no unit."""
    if sizes is None or factor is None:
        return None, None
    pitch = [float(s) / n * factor for s, n in zip(sizes, pts, strict=False)]
    if len(pitch) == 2 and abs(pitch[0] - pitch[1]) > 1e-6 * max(pitch):
        return pitch[0], pitch[1]
    return pitch[0], None


def has_metadata_header(text: str) -> bool:
    """Whether a plain-text grid names its metadata in ``#`` lines before the numbers (``# Width: 10.00 µm``, as
    Gwyddion and other programs export): such a file is the library's to read, so its pixel size and unit count."""
    for line in text.splitlines():
        stripped = line.strip()
        if not stripped:
            continue
        if not stripped.startswith("#"):
            return False
        name, colon, value = stripped.lstrip("#").partition(":")
        if colon and name.strip() and value.strip():
            return True
    return False


class _Named(bytes):
    """A file's bytes with the suffix of its name (``"nms"``): the format hint the library takes from a path."""

    suffix: str = ""


def _open(raw: bytes) -> Any:
    """The library's reader for ``raw``: detected from the content; where that finds no reader or one that gives no
    channel (a format without magic bytes, such as NanoFocus NMS, can be taken for another), the readers of the
    file's suffix are tried, as the library does for a path."""
    from SurfaceTopography.IO import open_topography, readers

    try:
        reader = open_topography(io.BytesIO(raw))
        if reader.channels:
            return reader
        problem: Exception = ValueError(f"the {type(reader).name()} reader finds no data channel in it")
    except Exception as exc:  # the suffix's readers get their chance; this one is re-raised
        problem = exc
    suffix = getattr(raw, "suffix", "").lower()
    for cls in readers:
        if suffix and suffix in (cls.file_extensions() or ()):
            try:
                reader = open_topography(io.BytesIO(raw), format=cls.format())
            except Exception:  # not this reader
                continue
            if reader.channels:
                return reader
    raise problem


def _parse(raw: bytes) -> Measured:
    """Runs in the child: the library parses ``raw`` (size checked before the heights are decoded)."""
    from SurfaceTopography.Support.UnitConversion import get_unit_conversion_factor

    reader = _open(raw)
    channel = reader.default_channel
    pts = tuple(int(n) for n in channel.nb_grid_pts)
    limit = HEIGHT_MAP_MAX_SIDE if len(pts) == 2 else PROFILE_MAX_POINTS
    if max(pts) > limit:
        raise ValueError(f"the file declares {pts} points; expected at most {limit} per side")
    unit = channel.unit
    factor = float(get_unit_conversion_factor(unit, "m")) if unit else None
    sizes = channel.physical_sizes
    kwargs: dict[str, Any] = {}
    if sizes is None:  # decode anyway (the scene may give the pixel); nothing from these dummies is kept
        kwargs["physical_sizes"] = tuple(float(n) for n in pts)
    if not unit:
        kwargs["unit"] = "m"
    topo = reader.topography(channel_index=channel.index, **kwargs)
    h = np.ma.filled(np.ma.masked_invalid(topo.heights()).astype(np.float64), np.nan)
    heights = np.ascontiguousarray(h.T if h.ndim == 2 else h)  # the library's [x, y] → rows = y
    pixel_x, pixel_y = _pixel(sizes, pts, factor)
    return Measured(heights, pixel_x, factor, _instrument(channel.info), type(reader).name(), pixel_y)


def _answer(raw: bytes) -> bytes:
    """Runs in the child: the parsed file or its error, pickled."""
    try:
        result: tuple[str, Any] = ("ok", _parse(raw))
    except BaseException as exc:  # untrusted content: any failure is one line
        text = str(exc).strip().splitlines()
        name = type(exc).__name__
        detail = f"{name}: {text[0] if text else ''}"
        result = ("error", "format not recognised" if name == "CannotDetectFileFormat" else detail)
    return pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL)


def read_topography_file(raw: bytes, *, key: str, path: str, timeout_s: float = PARSE_TIMEOUT_S) -> Measured:
    """Parse the bytes ``raw`` of the file ``path`` with SurfaceTopography in a child process within ``timeout_s``.

    Errors (library missing, unknown format, a damaged file, too many points) are a :class:`SettingError` naming
    ``key`` and ``path``. The suffix of ``path`` is the library's format hint where the content does not decide.
    """
    named, name = _Named(raw), path.rpartition("/")[2]
    named.suffix = name.rpartition(".")[2] if "." in name else ""
    raw = named
    if not surfaces_library_available():
        raise SettingError(
            key, path, f"is not a plain-text grid; reading profilometer formats needs SurfaceTopography: {PIP_HINT}"
        )
    try:
        payload = run_in_child(_answer, (raw,), timeout=timeout_s)
    except ChildTimeout:
        raise SettingError(key, path, f"parsing it took longer than {timeout_s:g} s (a damaged file?)") from None
    except ChildDied:
        raise SettingError(key, path, "the reader crashed on it (a damaged file?)") from None
    status, value = pickle.loads(payload)
    if status == "error":
        raise SettingError(key, path, f"not a height map SurfaceTopography can read ({value})")
    assert isinstance(value, Measured)
    return value
