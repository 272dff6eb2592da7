"""Contact force and real contact area on the skirt mesh for a given minimum gap (the rigid-body contact model).

With the piston and the liner rigid and the asperities deformable (seed section 2.1), each node ``i`` of the skirt
mesh at gap ``h_i`` carries the nominal pressure ``p(h_i)`` and the real-area fraction ``a(h_i)`` of the contact
law over its nominal area ``ΔA_i``. The pressure acts along the liner normal, so

- vertical contact force ``F(h0) = Σ p(h_i) ΔA_i cos θ_i`` [N] (the ``P_c A_c`` of seed eq. 22),
- real contact area ``A_r(h0) = Σ a(h_i) ΔA_i`` [m²],
- slope ``dF/dh0 = Σ p′(h_i) (∂h_i/∂h0) ΔA_i cos θ_i`` [N/m], from the law's analytic slope; ``∂h/∂h0 cos θ > 0``
  everywhere, so ``F`` is strictly decreasing wherever any node is in contact.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sims.rig_geometry import axial_profile_m, dgap_dh0, gap_m
from sims.rig_law import ContactLaw
from sims.rig_mesh import SkirtMesh
from sims.rig_settings import RigSettings

__all__ = ["SkirtLoads"]


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
