"""The scene's simulation tables, parsed once into typed, frozen, validated settings.

:class:`SimConfig` holds ``[materials.*]``, ``[surfaces.*]``, ``[database]`` and ``[rig]`` of a scene as the types the
solvers take (:class:`~sims.materials.ContactMaterials`, :class:`~sims.surface.SurfaceSpec`,
:class:`~sims.database.DatabaseSettings`, :class:`~sims.rig.settings.RigSettings`), plus the scene's name, source and
exact text for provenance. Every entry point of ``sims`` takes a :class:`SimConfig` (or one of its parts), never a raw
scene; errors raised while parsing name the scene key, e.g. ``[surfaces.liner] sq_m``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from contactrig.core.scene import Scene
    from sims.database import DatabaseSettings
    from sims.materials import ContactMaterials
    from sims.press import PressSettings
    from sims.rig.settings import RigSettings
    from sims.surface import SurfaceSpec

__all__ = ["SimConfig"]


@dataclass(frozen=True)
class SimConfig:
    """The simulation part of a scene, typed. Build it with :meth:`from_scene` (or field by field in a notebook)."""

    materials: ContactMaterials
    liner: SurfaceSpec
    piston: SurfaceSpec
    database: DatabaseSettings
    rig: RigSettings
    press: PressSettings | None = None  # a press scene (sphere on flat) when the scene has [press]; else the rig's
    name: str = "unnamed"
    source: str = "<string>"
    text: str = field(default="", repr=False)

    @classmethod
    def from_scene(cls, scene: Scene) -> SimConfig:
        """Parse the simulation tables of ``scene`` (each table once; errors name the scene key)."""
        from sims.database import DatabaseSettings
        from sims.materials import materials_from_scene
        from sims.press import PressSettings
        from sims.rig.settings import RigSettings
        from sims.surface import surfaces_from_scene

        liner, piston = surfaces_from_scene(scene)
        return cls(
            materials=materials_from_scene(scene),
            liner=liner,
            piston=piston,
            database=DatabaseSettings.from_scene(scene),
            rig=RigSettings.from_scene(scene),
            press=PressSettings.from_scene(scene),
            name=scene.name,
            source=scene.source,
            text=scene.text,
        )

    @property
    def specimen(self) -> str:
        """``"press"`` (a rough sphere on a rough flat, ``[press]``) or ``"rig"`` (the piston in its liner)."""
        return "press" if self.press is not None else "rig"

    @property
    def weights_kg(self) -> tuple[float, ...]:
        """The specimen's load sweep [kg]: ``[press] weights_kg`` or ``[rig] weights_kg``."""
        return tuple(self.press.weights_kg if self.press is not None else self.rig.weights_kg)

    def with_changes(self, **changes: Any) -> SimConfig:
        """A copy with some parts replaced (``database=…``, ``rig=…``), as :func:`dataclasses.replace`."""
        return replace(self, **changes)

    def provenance(self) -> dict[str, Any]:
        """Scene name, source and text for the provenance of every result built from this configuration."""
        return {"scene_name": self.name, "scene_source": self.source, "scene_text": self.text}
