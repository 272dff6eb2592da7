"""Scenes: the TOML file that says what to simulate, measure and compare.

A scene is read once (:func:`load_scene`) and handed around as a :class:`Scene`: the exact text (kept for
provenance in every output file) and the parsed tables. Each consumer validates only the tables it owns:

==================  =====================================  ==============================
table               what                                    parsed by
==================  =====================================  ==============================
``[scene]``         name, description                       this module
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
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from contactrig.core.validation import SCENE_TABLES, SettingError, check_keys, read_text_file

__all__ = ["KNOWN_TABLES", "Scene", "default_scene_text", "load_scene", "parse_scene"]

KNOWN_TABLES = SCENE_TABLES


@dataclass(frozen=True)
class Scene:
    """A parsed scene: ``text`` is the file's exact content, ``data`` its tables, ``source`` where it came from."""

    text: str
    data: dict[str, Any] = field(repr=False)
    source: str = "<default>"

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


def parse_scene(text: str, source: str = "<string>") -> Scene:
    """Parse scene ``text``; raise :class:`SettingError` on malformed TOML or an unknown table."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SettingError(source, "<file>", f"malformed TOML: {exc}") from None
    check_keys("", data, KNOWN_TABLES)
    scene_table = data.get("scene", {})
    if not isinstance(scene_table, dict):
        raise SettingError("scene", scene_table, "expected a TOML table")
    check_keys("scene", scene_table, ("name", "description"))
    return Scene(text=text, data=data, source=source)


def load_scene(path: str | Path | None = None) -> Scene:
    """Load the scene at ``path``, or the packaged default scene when ``path`` is None."""
    if path is None:
        return parse_scene(default_scene_text(), "<default>")
    return parse_scene(read_text_file("scene", path), str(path))
