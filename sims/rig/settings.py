"""Settings of the piston/liner rig model: the scene's ``[rig]`` table, validated on construction.

Every key (SI units, the unit in the name):

==========================  ==========================================================================================
``liner_radius_m``          liner bore radius R_l, (0, 10] m
``clearance_m``             radial clearance c = R_l − R_p, [0, 0.1 R_l]; 0 is an exact fit
``skirt_length_m``          axial length L of the skirt in contact, (0, 10] m
``crown_m``                 axial profile: the gap grows by crown·(2y/L)² towards the skirt ends; 0 = straight skirt
``piston_mass_kg``          piston's own mass, added to every weight: load W = (weight + piston mass)·g
``damping_n_s_per_m``       damping B of the dynamic settle, seed eq. 22, [0, 1e12] N·s/m
``gap``                     ``"exact"`` offset circle in a circle, or ``"small_clearance"`` h0 + e(1 − cos θ)
``mesh``                    ``"variable"`` (refined at the contact, converged to ``mesh_tol``) or ``"uniform"``
``n_theta``                 uniform: cells on θ ∈ [0, π]; variable: first-level cells across the contact zone
``n_axial``                 uniform: cells on y ∈ [0, L/2] (1 is exact on a straight skirt, whose gap does not vary
                            along y); variable: first-level cells across a crowned contact (unused when straight)
``mesh_tol``                variable mesh: refine (double the cells) until the real area changes less than this
``max_nodes``               variable mesh: node budget; reaching it leaves a warning in the result
``weights_kg``              added weights of the load sweep [kg], each in [0, 1e6]
==========================  ==========================================================================================
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any

from contactrig.core.validation import SettingError, check_choice, check_int, check_keys, check_range

if TYPE_CHECKING:
    from contactrig.core.scene import Scene

__all__ = ["PAPER_WEIGHTS_KG", "STANDARD_GRAVITY", "RigSettings"]

#: Standard gravity [m/s²]; the paper's "255 N (26 kg)" is 25.966 kg × g.
STANDARD_GRAVITY = 9.80665

#: The added weights of the seed paper's Tab. 1 [kg].
PAPER_WEIGHTS_KG = (5.44, 7.44, 10.526, 13.616, 16.708, 19.795, 22.882, 25.966)


@dataclass(frozen=True)
class RigSettings:
    """Geometry, mesh, mass, damping and weights of the rig model; see the module docstring for each field."""

    liner_radius_m: float = 0.042
    clearance_m: float = 40e-6
    skirt_length_m: float = 0.045
    crown_m: float = 0.0
    piston_mass_kg: float = 0.0
    damping_n_s_per_m: float = 2.0e4
    gap: str = "exact"
    mesh: str = "variable"
    n_theta: int = 16
    n_axial: int = 8
    mesh_tol: float = 1e-3
    max_nodes: int = 20000
    weights_kg: tuple[float, ...] = PAPER_WEIGHTS_KG

    def __post_init__(self) -> None:
        f = "rig."
        r = check_range(f + "liner_radius_m", self.liner_radius_m, 0.0, 10.0, lo_open=True, unit="m")
        object.__setattr__(self, "liner_radius_m", r)
        c = check_range(f + "clearance_m", self.clearance_m, 0.0, 0.1 * r, unit="m (at most 10 % of the liner radius)")
        object.__setattr__(self, "clearance_m", c)
        length = check_range(f + "skirt_length_m", self.skirt_length_m, 0.0, 10.0, lo_open=True, unit="m")
        object.__setattr__(self, "skirt_length_m", length)
        crown = check_range(f + "crown_m", self.crown_m, 0.0, 0.01 * r, unit="m (at most 1 % of the liner radius)")
        object.__setattr__(self, "crown_m", crown)
        object.__setattr__(
            self, "piston_mass_kg", check_range(f + "piston_mass_kg", self.piston_mass_kg, 0.0, 1e6, unit="kg")
        )
        object.__setattr__(
            self,
            "damping_n_s_per_m",
            check_range(f + "damping_n_s_per_m", self.damping_n_s_per_m, 0.0, 1e12, unit="N·s/m"),
        )
        check_choice(f + "gap", self.gap, ("exact", "small_clearance"))
        check_choice(f + "mesh", self.mesh, ("variable", "uniform"))
        object.__setattr__(self, "n_theta", check_int(f + "n_theta", self.n_theta, 2, 1_000_000))
        object.__setattr__(self, "n_axial", check_int(f + "n_axial", self.n_axial, 1, 100_000))
        object.__setattr__(self, "mesh_tol", check_range(f + "mesh_tol", self.mesh_tol, 0.0, 0.1, lo_open=True))
        object.__setattr__(self, "max_nodes", check_int(f + "max_nodes", self.max_nodes, 16, 100_000_000))
        object.__setattr__(self, "weights_kg", check_weights(self.weights_kg, f + "weights_kg"))

    @property
    def piston_radius_m(self) -> float:
        """R_p = R_l − c [m]."""
        return self.liner_radius_m - self.clearance_m

    @property
    def exact_gap(self) -> bool:
        """True for the exact offset-circle gap, False for the small-clearance form."""
        return self.gap == "exact"

    def load_n(self, weight_kg: float) -> float:
        """Vertical load W = (weight + piston mass)·g [N] the skirt carries."""
        return (weight_kg + self.piston_mass_kg) * STANDARD_GRAVITY

    @classmethod
    def from_table(cls, table: Mapping[str, Any]) -> RigSettings:
        """Settings from a ``[rig]`` table; unknown keys are errors naming the key; missing keys take the defaults."""
        if not isinstance(table, Mapping):
            raise SettingError("rig", table, "expected a TOML table")
        known = [f.name for f in fields(cls)]
        check_keys("rig", table, known)
        return cls(**dict(table))

    @classmethod
    def from_scene(cls, scene: Scene) -> RigSettings:
        """Settings from the scene's ``[rig]`` table."""
        return cls.from_table(scene.table("rig"))

    def as_dict(self) -> dict[str, Any]:
        """Plain dict of every field (for provenance), weights as a list."""
        d = {f.name: getattr(self, f.name) for f in fields(self)}
        d["weights_kg"] = list(self.weights_kg)
        return d


def check_weights(weights: Any, field: str = "weights_kg") -> tuple[float, ...]:
    """Validate a list of added weights [kg]: non-empty, each finite and in [0, 1e6]."""
    if isinstance(weights, (str, bytes)) or not isinstance(weights, Sequence):
        try:
            weights = list(weights)
        except TypeError:
            raise SettingError(field, weights, "expected a list of weights in kg") from None
    if len(weights) == 0:
        raise SettingError(field, list(weights), "expected at least one weight")
    return tuple(check_range(f"{field}[{i}]", w, 0.0, 1e6, unit="kg") for i, w in enumerate(weights))
