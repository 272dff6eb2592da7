"""Materials of the contact pair and the composite modulus (seed eq. 4).

Johnson's convention throughout: ``1/E* = (1 − ν1²)/E1 + (1 − ν2²)/E2`` (seed eq. 4; Johnson, *Contact
Mechanics*, eq. 4.22). Stachowiak & Batchelor's ``E′`` (used in seed eq. 5–7) is ``2 E*``; that conversion is done
once, in :mod:`sims.asperity`.

Scene tables ``[materials.liner]`` and ``[materials.piston]`` (all SI):

``E_pa``      Young's modulus, Pa, in [1e3, 1e13] and at least 2 ``H_pa`` (H/E is 1e-3…0.1 for real solids; a smaller
              E is a unit slip such as MPa typed for Pa, and would put H above E*, seed eq. 4)
``nu``        Poisson's ratio, in [0, 0.5)
``H_pa``      indentation hardness, Pa, in [1e3, 1e12]; the softer body's H drives the plastic asperity models
``yield_pa``  optional yield strength, Pa (Jackson–Green); default ``H_pa / 2.84`` (Jackson & Green's H/S_y limit)
``resistivity_ohm_m``  optional electrical resistivity of the bulk, Ω·m, in [1e-9, 1] (metals 1.6e-8 … 2e-6); needed
              only by the clean-metal constriction resistance (:mod:`analysis.resistance_model`: Holm, Barber)
``name``      optional free-text description
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from contactrig.core.validation import SettingError, check_keys, check_range

__all__ = [
    "MATERIAL_KEYS",
    "MAX_HARDNESS_TO_MODULUS",
    "ContactMaterials",
    "Material",
    "composite_modulus",
    "materials_from_scene",
]

MATERIAL_KEYS = ("E_pa", "nu", "H_pa", "yield_pa", "resistivity_ohm_m", "name")

#: Jackson & Green (2005): hardness/yield-strength ratio at full plasticity (their H_G/S_y → 2.84).
HARDNESS_TO_YIELD = 2.84

#: Largest H/E a body may have. Real solids have 1e-3…0.1 (diamond ≈ 0.1). With H ≤ E/2 on both bodies the softer
#: hardness never exceeds E* ≥ min(E1, E2)/2, which the plastic asperity models require.
MAX_HARDNESS_TO_MODULUS = 0.5


@dataclass(frozen=True)
class Material:
    """An isotropic elastic–plastic body. ``E_pa`` Pa, ``nu`` −, ``H_pa`` Pa, ``yield_pa`` Pa (None → H/2.84)."""

    E_pa: float
    nu: float
    H_pa: float
    yield_pa: float | None = None
    name: str = ""
    resistivity_ohm_m: float | None = None

    def __post_init__(self) -> None:
        check_range("E_pa", self.E_pa, 1e3, 1e13, unit="Pa")
        check_range("nu", self.nu, 0.0, 0.5, hi_open=True)
        check_range("H_pa", self.H_pa, 1e3, 1e12, unit="Pa")
        if self.yield_pa is not None:
            check_range("yield_pa", self.yield_pa, 1e3, 1e12, unit="Pa")
        if self.resistivity_ohm_m is not None:
            check_range("resistivity_ohm_m", self.resistivity_ohm_m, 1e-9, 1.0, unit="Ω·m")
        if self.H_pa > MAX_HARDNESS_TO_MODULUS * self.E_pa:
            lo = self.H_pa / MAX_HARDNESS_TO_MODULUS
            raise SettingError(
                "E_pa",
                self.E_pa,
                f"expected a value >= {lo:g} Pa, twice the hardness H_pa = {self.H_pa:g} Pa (H/E is 1e-3..0.1 for "
                "real solids): is it in Pa?",
            )

    @property
    def yield_strength_pa(self) -> float:
        """Yield strength S_y, Pa: ``yield_pa`` if given, else ``H_pa / 2.84``."""
        return float(self.yield_pa) if self.yield_pa is not None else self.H_pa / HARDNESS_TO_YIELD

    @classmethod
    def from_table(cls, section: str, table: dict[str, Any]) -> Material:
        """Build from a scene table; errors name ``section.key``."""
        if not isinstance(table, dict):
            raise SettingError(section, table, "expected a TOML table")
        check_keys(section, table, MATERIAL_KEYS)
        for key in ("E_pa", "nu", "H_pa"):
            if key not in table:
                raise SettingError(f"{section}.{key}", None, "required key is missing")
        name = table.get("name", "")
        if not isinstance(name, str):
            raise SettingError(f"{section}.name", name, "expected a string")
        try:
            return cls(
                E_pa=table["E_pa"],
                nu=table["nu"],
                H_pa=table["H_pa"],
                yield_pa=table.get("yield_pa"),
                name=name,
                resistivity_ohm_m=table.get("resistivity_ohm_m"),
            )
        except SettingError as exc:
            raise SettingError(f"{section}.{exc.field}", exc.value, exc.allowed) from None


def composite_modulus(m1: Material, m2: Material) -> float:
    """Johnson's composite modulus E* in Pa (seed eq. 4): ``1/E* = (1−ν1²)/E1 + (1−ν2²)/E2``."""
    return 1.0 / ((1.0 - m1.nu**2) / m1.E_pa + (1.0 - m2.nu**2) / m2.E_pa)


@dataclass(frozen=True)
class ContactMaterials:
    """The pair liner/piston and the derived contact constants the asperity models need."""

    liner: Material
    piston: Material

    @property
    def E_star(self) -> float:
        """Composite modulus E*, Pa (seed eq. 4)."""
        return composite_modulus(self.liner, self.piston)

    @property
    def softer(self) -> Material:
        """The body with the lower hardness (it yields first)."""
        return self.liner if self.liner.H_pa <= self.piston.H_pa else self.piston

    @property
    def H(self) -> float:
        """Hardness of the softer body, Pa (seed eq. 13, 18, 21: H_m)."""
        return self.softer.H_pa

    @property
    def resistivity_sum_ohm_m(self) -> float | None:
        """ρ1 + ρ2 [Ω·m] of the two bodies (Holm's and Barber's constriction resistance); None if either is unknown."""
        r1, r2 = self.liner.resistivity_ohm_m, self.piston.resistivity_ohm_m
        return None if r1 is None or r2 is None else float(r1) + float(r2)

    def as_dict(self) -> dict[str, Any]:
        """Plain values for provenance."""
        out: dict[str, Any] = {"E_star_pa": self.E_star, "H_pa": self.H}
        for label, m in (("liner", self.liner), ("piston", self.piston)):
            out[label] = {"E_pa": m.E_pa, "nu": m.nu, "H_pa": m.H_pa, "yield_pa": m.yield_strength_pa, "name": m.name}
            if m.resistivity_ohm_m is not None:
                out[label]["resistivity_ohm_m"] = m.resistivity_ohm_m
        return out


def materials_from_scene(scene: Any) -> ContactMaterials:
    """Parse ``[materials.liner]`` and ``[materials.piston]`` of ``scene`` (a :class:`contactrig.core.scene.Scene`)."""
    table = scene.table("materials")
    check_keys("materials", table, ("liner", "piston"))
    bodies = {}
    for body in ("liner", "piston"):
        if body not in table:
            raise SettingError(f"materials.{body}", None, "required table is missing")
        bodies[body] = Material.from_table(f"materials.{body}", table[body])
    pair = ContactMaterials(**bodies)
    if not math.isfinite(pair.E_star):  # pragma: no cover - guarded by the ranges above
        raise SettingError("materials", pair.E_star, "composite modulus is not finite")
    return pair
