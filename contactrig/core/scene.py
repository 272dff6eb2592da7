"""Scenes: the TOML file that says what to simulate, measure and compare.

A scene is read once (:func:`load_scene`) and handed around as a :class:`Scene`: the exact text (kept for
provenance in every output file) and the parsed tables. Each consumer validates only the tables it owns:

==================  =====================================  ==============================
table               what                                    parsed by
==================  =====================================  ==============================
``[scene]``         name, description, device (BEM)        this module
``[materials.*]``   E, ν, H of liner and piston              ``sims.materials``
``[surfaces.*]``    generated or measured height maps        ``sims.surface``
``[database]``      models, separation grid                  ``sims.database``
``[rig]``           piston/liner geometry, mesh, weights     ``sims.rig``
``[circuit]``       eq. 23–25: resistivity, height, …        ``analysis``
``[instrument]``    VISA address, timeouts                   ``daq``
``[delta]``         Delta-mode settings                      ``daq`` → ``instruments.delta``
``[session]``       repeats, operator, sample, simulated bench ``daq``
==================  =====================================  ==============================

An unknown top-level table is an error naming it; unknown keys inside a table are errors raised by its owner.
The default scene ships with the package (``contactrig/scenes/default.toml``).

This module is the edge where a scene's files are read. A ``[surfaces.<body>]`` table of ``kind = "file"`` names a
measured height map (``path``, relative to the scene file's folder); :func:`load_scene` reads it when the scene is
loaded and keeps the numbers, exactly as written in the file, on :attr:`Scene.height_maps` (section →
:class:`HeightMap`, the resolved path kept for provenance). ``sims.surface`` builds the surface from the table and that
array; it reads no file. :func:`parse_scene` reads height maps only when given ``base_dir`` (a scene recorded in a
data file is parsed without its files). A missing or malformed height map is an error naming the scene key, e.g.
``[surfaces.liner] path = 'maps/liner.csv:3'``.
"""

from __future__ import annotations

import contextlib
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from contactrig.core.inputs import HEIGHT_MAP_MAX_BYTES, HEIGHT_MAP_MAX_SIDE, read_input_bytes, read_text_file
from contactrig.core.validation import SCENE_TABLES, SettingError, check_choice, check_keys

__all__ = [
    "KNOWN_TABLES",
    "SCENE_KEYS",
    "HeightMap",
    "Scene",
    "default_scene_text",
    "load_height_maps",
    "load_scene",
    "parse_scene",
    "read_height_map",
    "read_measured_map",
]

KNOWN_TABLES = SCENE_TABLES
#: The keys of the ``[scene]`` table: ``device`` is where the boundary-element solves run (``"cpu"``/``"gpu"``).
SCENE_KEYS = ("name", "description", "device")


@dataclass(frozen=True)
class HeightMap:
    """A measured height map as read from its file: ``heights`` are the file's numbers (its own unit, rows × columns,
    read-only; 1-D for a line profile; NaN where the instrument measured no point), ``path`` the file it came from
    (resolved; for provenance and messages). ``pixel_m`` and ``height_unit_m`` (m) are the file's own metadata (None
    when it has none: a plain-text grid), ``instrument`` and ``file_format`` what the file and its reader say;
    ``pixel_y_m`` the pitch along y (rows) where the file's pixels are not square (``pixel_m`` is then along x)."""

    path: str
    heights: NDArray[np.float64] = field(repr=False, compare=False)
    pixel_m: float | None = None
    height_unit_m: float | None = None
    instrument: str | None = None
    file_format: str = "plain text"
    pixel_y_m: float | None = None

    def metadata(self) -> dict[str, Any]:
        """What the file says about itself (for ``sims.surface`` and provenance)."""
        return {
            "pixel_m": self.pixel_m,
            "pixel_y_m": self.pixel_y_m,
            "height_unit_m": self.height_unit_m,
            "instrument": self.instrument,
            "file_format": self.file_format,
        }


def _no_height_maps() -> Mapping[str, HeightMap]:
    return MappingProxyType({})


@dataclass(frozen=True)
class Scene:
    """A parsed scene: ``text`` is the file's exact content, ``data`` its tables, ``source`` where it came from."""

    text: str
    data: dict[str, Any] = field(repr=False)
    source: str = "<default>"
    #: measured height maps the scene references, by section (``"surfaces.liner"``); see :func:`load_height_maps`
    height_maps: Mapping[str, HeightMap] = field(default_factory=_no_height_maps, repr=False, compare=False)

    @property
    def name(self) -> str:
        return str(self.data.get("scene", {}).get("name", "unnamed"))

    def table(self, name: str) -> dict[str, Any]:
        """The table ``name`` (an empty dict when the scene has none)."""
        value = self.data.get(name, {})
        if not isinstance(value, dict):
            raise SettingError(name, value, "expected a TOML table")
        return value


def default_scene_text() -> str:
    """The text of the scene shipped with the package."""
    return resources.files("contactrig").joinpath("scenes/default.toml").read_text(encoding="utf-8")


def parse_scene(text: str, source: str = "<string>", *, base_dir: str | Path | None = None) -> Scene:
    """Parse scene ``text``; raise :class:`SettingError` on malformed TOML or an unknown table.

    With ``base_dir``, the height maps the scene references are read too (relative paths from ``base_dir``);
    without it, none are (:attr:`Scene.height_maps` is empty).
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SettingError(source, "<file>", f"malformed TOML: {exc}") from None
    check_keys("", data, KNOWN_TABLES)
    scene_table = data.get("scene", {})
    if not isinstance(scene_table, dict):
        raise SettingError("scene", scene_table, "expected a TOML table")
    check_keys("scene", scene_table, SCENE_KEYS)
    if "device" in scene_table:  # where the boundary-element solves run (sims.bem_backend; issue 28)
        check_choice("scene.device", scene_table["device"], ("cpu", "gpu"))
    maps = load_height_maps(data, base_dir) if base_dir is not None else _no_height_maps()
    return Scene(text=text, data=data, source=source, height_maps=maps)


def load_scene(path: str | Path | None = None) -> Scene:
    """Load the scene at ``path`` and the height-map files it references, or the packaged default scene when
    ``path`` is None."""
    if path is None:
        return parse_scene(default_scene_text(), "<default>")
    p = Path(path)
    return parse_scene(read_text_file("scene", p), str(path), base_dir=p.resolve().parent)


# ---------------------------------------------------------------------------------------------------------------
# Measured height maps.


def _height_map_paths(data: Mapping[str, Any]) -> dict[str, Any]:
    """section → the ``path`` value of every ``[surfaces.<body>]`` table of ``kind = "file"`` (as written)."""
    surfaces = data.get("surfaces", {})
    if not isinstance(surfaces, dict):
        return {}  # sims.surface reports the malformed table
    return {
        f"surfaces.{body}": table.get("path")
        for body, table in surfaces.items()
        if isinstance(table, dict) and table.get("kind") == "file"
    }


def load_height_maps(data: Mapping[str, Any], base_dir: str | Path) -> Mapping[str, HeightMap]:
    """Read every height-map file the scene tables ``data`` reference (relative paths from ``base_dir``).

    Returns a read-only mapping section → :class:`HeightMap`. A ``path`` that is not a non-empty string is left
    for ``sims.surface`` to report; a missing or malformed file is a :class:`SettingError` naming ``[section] path``.
    """
    out: dict[str, HeightMap] = {}
    for section, value in _height_map_paths(data).items():
        if not isinstance(value, str) or not value:
            continue
        p = Path(value)
        if not p.is_absolute():
            p = Path(base_dir) / p
        out[section] = read_measured_map(p, key=f"{section}.path")
    return MappingProxyType(out)


def read_measured_map(path: str | Path, *, key: str = "path") -> HeightMap:
    """A measured height map from a plain-text grid (:func:`read_height_map`) or any profilometer format
    SurfaceTopography reads (:mod:`contactrig.core.topography_file`, with the file's pixel size and unit).

    The file is read once, bounded (:func:`contactrig.core.inputs.read_input_bytes`); UTF-8 text that parses as a
    grid of numbers is a plain-text map, anything else goes to the library (a message naming the pip command when it
    is not installed). Errors are :class:`SettingError` naming ``key``.
    """
    from contactrig.core.topography_file import has_metadata_header, surfaces_library_available

    p = Path(path)
    raw = read_input_bytes(key, p, max_bytes=HEIGHT_MAP_MAX_BYTES)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = None
    if text is not None and has_metadata_header(text) and surfaces_library_available():
        with contextlib.suppress(SettingError):  # the header's pixel size and unit; else the numbers alone
            return _library_map(raw, p, key)
    if text is not None:
        try:
            return HeightMap(path=str(p), heights=_parse_grid(text, p, key))
        except SettingError:
            if not _looks_like_a_header(text):
                raise
    return _library_map(raw, p, key)


def _library_map(raw: bytes, p: Path, key: str) -> HeightMap:
    from contactrig.core.topography_file import read_topography_file

    m = read_topography_file(raw, key=key, path=str(p))
    heights = m.heights
    heights.setflags(write=False)
    return HeightMap(str(p), heights, m.pixel_m, m.height_unit_m, m.instrument, m.file_format, m.pixel_y_m)


def _looks_like_a_header(text: str) -> bool:
    """Text the library may read (e.g. a header with units) rather than a malformed grid: its first line that is
    not blank or a ``#`` comment has letters (other than exponents and nan)."""
    for line in text.splitlines():
        body = line.split("#", 1)[0].lower().replace("nan", "").strip()
        if body:
            return any(c.isalpha() and c != "e" for c in body)
    return False


def _parse_row(line: str, where: str, key: str) -> NDArray[np.float64] | None:
    """The numbers of one line of a height-map file (None for a blank or comment line)."""
    line = line.split("#", 1)[0].strip()
    if not line:
        return None
    values = line.replace(",", " ").replace(";", " ").split()
    if not values:  # separators only
        return None
    try:  # one float64 array per row: 8 bytes a number while parsing, not a Python float's 32
        return np.array(values, dtype=np.float64)
    except ValueError:
        raise SettingError(key, where, "expected numbers only") from None


def read_height_map(path: str | Path, *, key: str = "path") -> NDArray[np.float64]:
    """The numbers of a plain-text height map: a grid separated by whitespace, commas or semicolons, ``#`` comments.

    Returned as written (no unit conversion, no levelling; that is physics, done by ``sims.surface``), rows × columns,
    read-only. The file is read by :func:`contactrig.core.inputs.read_text_file` (a regular file of at most
    ``HEIGHT_MAP_MAX_BYTES``); at most ``HEIGHT_MAP_MAX_SIDE`` rows and columns. A missing, unreadable, too large or
    non-rectangular file is a :class:`SettingError` naming ``key``.
    """
    p = Path(path)
    return _parse_grid(read_text_file(key, p, max_bytes=HEIGHT_MAP_MAX_BYTES), p, key)


def _parse_grid(text: str, p: Path, key: str) -> NDArray[np.float64]:
    rows: list[NDArray[np.float64]] = []
    for line_no, line in enumerate(text.splitlines(), 1):
        row = _parse_row(line, f"{p}:{line_no}", key)
        if row is None:
            continue
        if row.size > HEIGHT_MAP_MAX_SIDE or len(rows) >= HEIGHT_MAP_MAX_SIDE:
            raise SettingError(
                key, f"{p}:{line_no}", f"expected at most {HEIGHT_MAP_MAX_SIDE} rows and columns (the largest grid)"
            )
        if rows and row.size != rows[0].size:
            break
        rows.append(row)
    else:
        if rows:
            z = np.vstack(rows)
            z.setflags(write=False)
            return z
    raise SettingError(key, str(p), "expected a rectangular grid of numbers (same count on every line)")
