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

import numpy as np
from numpy.typing import ArrayLike

from sims.rig.geometry import axial_profile_m, contact_edge_angle_rad, dgap_dh0, gap_m
from sims.rig.law import ContactLaw
from sims.rig.mesh import SkirtMesh
from sims.rig.settings import RigSettings

__all__ = ["TAIL_SHARE", "SkirtLoads", "tail_bound", "tail_matters"]

#: A variable mesh leaves out the skirt beyond its contact zone only when that part's force and area are provably
#: below this share of ``mesh_tol`` (relative to the load and the area).
TAIL_SHARE = 0.1

#: Sum over the nodes (θ, y) of a gap-shaped array; any leading axes are minimum gaps (one per weight).
_SUM = "...ty,ty->..."


class SkirtLoads:
    """Force, slope and area on one mesh for one contact law, for one minimum gap or many at once.

    The ``*_n``/``*_m2`` methods taking an array ``h0_m`` [m] return one value per minimum gap (the batch solver
    evaluates every weight of a sweep in one call of the law); the scalar methods (:meth:`force_n`,
    :meth:`force_and_slope`, :meth:`area_m2`) are what the dynamics use. ``evaluations`` counts force (or
    force-and-slope) evaluations, ``law_calls`` calls of the contact law (each covers every minimum gap given).
    """

    def __init__(self, law: ContactLaw, settings: RigSettings, mesh: SkirtMesh) -> None:
        self.law, self.settings, self.mesh = law, settings, mesh
        self._theta = mesh.theta_rad
        self._area = mesh.area_m2
        self._cos_area = self._area * np.cos(self._theta)[:, None]
        self._profile = axial_profile_m(mesh.y_m, settings.skirt_length_m, settings.crown_m)[None, :]
        self.evaluations = 0
        self.law_calls = 0

    def gap(self, h0_m: ArrayLike) -> np.ndarray:
        """Gap [m] at every node: shape ``h0_m.shape + mesh.shape`` for minimum gaps ``h0_m`` [m]."""
        s = self.settings
        h0 = np.asarray(h0_m, dtype=float)
        g = gap_m(self._theta, h0[..., None], s.liner_radius_m, s.clearance_m, s.exact_gap)
        return g[..., None] + self._profile

    def _law(self, method: str, h: np.ndarray) -> np.ndarray:
        self.law_calls += 1
        return np.asarray(getattr(self.law, method)(h.ravel()), dtype=float).reshape(h.shape)

    def forces_n(self, h0_m: ArrayLike) -> np.ndarray:
        """Vertical contact force F(h0) = Σ p ΔA cos θ [N] per minimum gap (seed eq. 22, ``P_c A_c``)."""
        self.evaluations += 1
        return np.einsum(_SUM, self._law("pressure", self.gap(h0_m)), self._cos_area)

    def forces_and_slopes(self, h0_m: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """F(h0) [N] and dF/dh0 [N/m] (≤ 0) per minimum gap, from the law's analytic slope."""
        self.evaluations += 1
        s = self.settings
        h0 = np.asarray(h0_m, dtype=float)
        h = self.gap(h0)
        p = self._law("pressure", h)
        dp = self._law("dpressure_dh", h)
        dh = dgap_dh0(self._theta, h0[..., None], s.liner_radius_m, s.clearance_m, s.exact_gap)[..., None]
        return np.einsum(_SUM, p, self._cos_area), np.einsum(_SUM, dp * dh, self._cos_area)

    def areas_m2(self, h0_m: ArrayLike) -> np.ndarray:
        """Real contact area A_r(h0) = Σ a ΔA [m²] per minimum gap."""
        return np.einsum(_SUM, self._law("area_fraction_at", self.gap(h0_m)), self._area)

    def force_n(self, h0_m: float) -> float:
        """Vertical contact force F(h0) [N] for one minimum gap [m]."""
        return float(self.forces_n(h0_m))

    def force_and_slope(self, h0_m: float) -> tuple[float, float]:
        """F(h0) [N] and dF/dh0 [N/m] (≤ 0) for one minimum gap [m]."""
        force, slope = self.forces_and_slopes(h0_m)
        return float(force), float(slope)

    def pressure_pa(self, h0_m: float) -> np.ndarray:
        """Nominal pressure [Pa] at every node, shape ``mesh.shape``, for one minimum gap [m]."""
        return self._law("pressure", self.gap(h0_m))

    def area_fraction(self, h0_m: float) -> np.ndarray:
        """Real-area fraction [-] at every node, shape ``mesh.shape``, for one minimum gap [m]."""
        return self._law("area_fraction_at", self.gap(h0_m))

    def area_m2(self, h0_m: float) -> float:
        """Real contact area A_r(h0) [m²] for one minimum gap [m]."""
        return float(self.areas_m2(h0_m))


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
