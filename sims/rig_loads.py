"""Contact force and real contact area on the skirt mesh for a given minimum gap (the rigid-body contact model).

With the piston and the liner rigid and the asperities deformable (seed section 2.1), each node ``i`` of the skirt
mesh at gap ``h_i`` carries the nominal pressure ``p(h_i)`` and the real-area fraction ``a(h_i)`` of the contact
law over its nominal area ``ΔA_i``. The pressure acts along the liner normal, so

- vertical contact force ``F(h0) = Σ p(h_i) ΔA_i cos θ_i`` [N] (the ``P_c A_c`` of seed eq. 22),
- real contact area ``A_r(h0) = Σ a(h_i) ΔA_i`` [m²],
- slope ``dF/dh0 = Σ p′(h_i) (∂h_i/∂h0) ΔA_i cos θ_i`` [N/m], from the law's analytic slope; ``∂h/∂h0 cos θ > 0``
  everywhere, so ``F`` is strictly decreasing wherever any node is in contact.

:func:`tail_bound` bounds what a mesh that stops at ``θ_z`` leaves out: the gap grows with θ (and with |y| on a
crowned skirt) and the law is non-increasing in h, so beyond ``θ_z`` both ``p`` and ``a`` are at most their value at
the zone's edge, ``h_z = h(θ_z, y = 0)``. Hence ``|F_tail| ≤ 2 R_p L p(h_z) (θ_top − θ_z)`` and
``A_tail ≤ 2 R_p L a(h_z) (θ_top − θ_z)``, with ``θ_top`` where the gap reaches the law's ``h_max`` when the law is
exactly zero there (contact onset of an asperity model), else π.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from sims.rig_geometry import axial_profile_m, contact_edge_angle_rad, dgap_dh0, gap_m
from sims.rig_law import ContactLaw
from sims.rig_mesh import SkirtMesh
from sims.rig_settings import RigSettings

__all__ = ["TAIL_SHARE", "SkirtLoads", "tail_bound", "tail_matters"]

#: A variable mesh leaves out the skirt beyond its contact zone only when that part's force and area are provably
#: below this share of ``mesh_tol`` (relative to the load and the area).
TAIL_SHARE = 0.1


@dataclass(frozen=True)
class SkirtLoads:
    """Evaluator of force, slope and area on one mesh for one contact law; ``evaluations`` counts force calls."""

    law: ContactLaw
    settings: RigSettings
    mesh: SkirtMesh
    _theta: np.ndarray = field(init=False, repr=False)
    _cos_area: np.ndarray = field(init=False, repr=False)
    _area: np.ndarray = field(init=False, repr=False)
    _profile: np.ndarray = field(init=False, repr=False)
    _count: list[int] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        theta = self.mesh.theta_rad
        area = self.mesh.area_m2
        object.__setattr__(self, "_theta", theta)
        object.__setattr__(self, "_area", area)
        object.__setattr__(self, "_cos_area", area * np.cos(theta)[:, None])
        s = self.settings
        object.__setattr__(self, "_profile", axial_profile_m(self.mesh.y_m, s.skirt_length_m, s.crown_m)[None, :])
        object.__setattr__(self, "_count", [0])

    @property
    def evaluations(self) -> int:
        """Number of force (or force-and-slope) evaluations so far."""
        return self._count[0]

    def gap(self, h0_m: float) -> np.ndarray:
        """Gap [m] at every node, shape ``mesh.shape``."""
        s = self.settings
        g = gap_m(self._theta, h0_m, s.liner_radius_m, s.clearance_m, s.exact_gap)
        return g[:, None] + self._profile

    def force_n(self, h0_m: float) -> float:
        """Vertical contact force F(h0) [N]."""
        self._count[0] += 1
        p = self.law.pressure(self.gap(h0_m).ravel()).reshape(self.mesh.shape)
        return float(np.sum(p * self._cos_area))

    def force_and_slope(self, h0_m: float) -> tuple[float, float]:
        """F(h0) [N] and dF/dh0 [N/m] (≤ 0)."""
        self._count[0] += 1
        s = self.settings
        h = self.gap(h0_m).ravel()
        p = self.law.pressure(h).reshape(self.mesh.shape)
        dp = self.law.dpressure_dh(h).reshape(self.mesh.shape)
        dh = dgap_dh0(self._theta, h0_m, s.liner_radius_m, s.clearance_m, s.exact_gap)[:, None]
        return float(np.sum(p * self._cos_area)), float(np.sum(dp * dh * self._cos_area))

    def pressure_pa(self, h0_m: float) -> np.ndarray:
        """Nominal pressure [Pa] at every node."""
        return np.asarray(self.law.pressure(self.gap(h0_m).ravel()), dtype=float).reshape(self.mesh.shape)

    def area_fraction(self, h0_m: float) -> np.ndarray:
        """Real-area fraction [-] at every node."""
        return np.asarray(self.law.area_fraction_at(self.gap(h0_m).ravel()), dtype=float).reshape(self.mesh.shape)

    def area_m2(self, h0_m: float) -> float:
        """Real contact area A_r(h0) [m²]."""
        return float(np.sum(self.area_fraction(h0_m) * self._area))


def tail_bound(
    law: ContactLaw, settings: RigSettings, theta_zone_rad: float, h0_m: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """Upper bounds on the force [N] and the real area [m²] beyond ``θ_zone`` for minimum gaps ``h0_m`` [m].

    See the module docstring; vectorised over ``h0_m``. Zero when the law is exactly zero at the zone's edge and
    beyond it (an asperity law whose contact onset lies inside the zone).
    """
    s = settings
    h0 = np.atleast_1d(np.asarray(h0_m, dtype=float))
    h_max = float(law.h_max)
    onset = float(law.pressure(np.array([h_max]))[0]) == 0.0 and float(law.area_fraction_at(np.array([h_max]))[0]) == 0
    h_zone = gap_m(theta_zone_rad, h0, s.liner_radius_m, s.clearance_m, s.exact_gap)
    if onset:
        top = np.array([contact_edge_angle_rad(h_max, h, s.liner_radius_m, s.clearance_m, s.exact_gap) for h in h0])
    else:
        top = np.full(h0.shape, math.pi)
    arc = 2.0 * s.piston_radius_m * s.skirt_length_m * np.clip(top - theta_zone_rad, 0.0, None)
    p = np.asarray(law.pressure(h_zone), dtype=float)
    a = np.asarray(law.area_fraction_at(h_zone), dtype=float)
    return p * arc, a * arc


def tail_matters(
    law: ContactLaw,
    settings: RigSettings,
    theta_zone_rad: float,
    h0_m: ArrayLike,
    load_n: ArrayLike,
    area_m2: ArrayLike,
) -> bool:
    """True unless, for every minimum gap ``h0_m`` [m], the skirt beyond ``θ_zone`` provably carries less than
    ``TAIL_SHARE·mesh_tol`` of its load ``load_n`` [N] and of its real area ``area_m2`` [m²] (:func:`tail_bound`)."""
    force_out, area_out = tail_bound(law, settings, theta_zone_rad, h0_m)
    limit = TAIL_SHARE * settings.mesh_tol
    return bool(np.any(force_out > limit * np.asarray(load_n)) or np.any(area_out > limit * np.asarray(area_m2)))
