"""Geometry of a piston lying in a horizontal liner: the gap between skirt and liner at every angle.

Conventions (SI units):

- ``R_l`` liner radius, ``c`` radial clearance, ``R_p = R_l − c`` piston (skirt) radius, ``L`` skirt length.
- The weight presses the piston down; its centre sits ``e`` below the liner's centre (eccentricity). The minimum
  gap is at the bottom, ``θ = 0``: ``h0 = c − e``. ``θ`` is the angle at the liner's centre measured from the
  downward vertical; the gap is measured along that ray (the liner's normal).
- **Exact gap** of an offset circle in a circle: ``h(θ) = R_l − e cos θ − √(R_p² − e² sin² θ)``, evaluated in the
  cancellation-free form ``c − e cos θ + e² sin² θ / (R_p + √(R_p² − e² sin² θ))``.
- **Small-clearance gap** (first order in e/R_p, the journal-bearing form): ``h(θ) = h0 + e (1 − cos θ)``.
  Both give ``h(0) = h0`` and, near ``θ = 0``, ``h ≈ h0 + x²/(2 R_eff)`` with ``x = R θ`` and
  ``R_eff = R_p R_l / c`` (conformal contact: R_eff is metres, not millimetres).

  Note: the form ``h0 + c (1 − cos θ)`` sometimes quoted replaces ``e = c − h0`` by ``c``; it is only right when
  ``|h0| ≪ c`` and fails completely at zero clearance (it predicts a uniform gap and no load capacity).
- Optional axial profile (barrel/crowned skirt): the gap grows by ``crown (2y/L)²`` from the skirt's middle
  (``y = 0``) to its ends (``y = ±L/2``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "OutOfGeometryError",
    "axial_profile_m",
    "contact_edge_angle_rad",
    "contact_half_angle_rad",
    "contact_half_length_m",
    "dgap_dh0",
    "effective_radius_m",
    "gap_m",
]


class OutOfGeometryError(ValueError):
    """A minimum gap the offset-circle geometry cannot have: the piston's centre so far off the liner's that the
    skirt would cross the liner wall (|e sin θ| > R_p, e = c − h0), where the exact gap is the square root of a
    negative number. Raised where it occurs, never returned as NaN; ``h0_m`` is the offending minimum gap [m] and
    ``piston_radius_m`` the bound on the eccentricity |c − h0| [m]."""

    def __init__(self, h0_m: float, clearance_m: float, piston_radius_m: float) -> None:
        self.h0_m = h0_m
        self.piston_radius_m = piston_radius_m
        super().__init__(
            f"minimum gap h0 = {h0_m:.6g} m is outside the piston/liner geometry: the skirt would cross the liner "
            f"wall (the eccentricity |c - h0| must stay below the piston radius {piston_radius_m:.6g} m; "
            f"c = {clearance_m:.6g} m)"
        )


def _inside(e: np.ndarray, sin_theta: np.ndarray, rp: float, clearance_m: float) -> np.ndarray:
    """(e sin θ)² after checking that the exact gap's square root is real (else :class:`OutOfGeometryError`)."""
    s2 = (e * sin_theta) ** 2
    bad = ~(s2 <= rp * rp)  # NaN counts as outside
    if np.any(bad):
        eb = np.broadcast_to(e, bad.shape)
        worst = int(np.argmax(np.where(bad, np.nan_to_num(np.abs(eb), nan=np.inf), -np.inf)))
        raise OutOfGeometryError(float(clearance_m - eb.flat[worst]), clearance_m, rp)
    return s2


def effective_radius_m(liner_radius_m: float, clearance_m: float) -> float:
    """Johnson's effective radius of the conformal pair, ``R_eff = R_p R_l / c`` [m] (``inf`` at zero clearance)."""
    if clearance_m <= 0:
        return math.inf
    return (liner_radius_m - clearance_m) * liner_radius_m / clearance_m


def gap_m(
    theta_rad: ArrayLike, h0_m: ArrayLike, liner_radius_m: float, clearance_m: float, exact: bool = True
) -> np.ndarray:
    """Gap [m] between skirt and liner at angle ``theta_rad`` from the bottom when the minimum gap is ``h0_m``.

    ``theta_rad`` [rad] and ``h0_m`` [m] broadcast against each other (one minimum gap per weight of a batch).
    """
    theta = np.asarray(theta_rad, dtype=float)
    h0 = np.asarray(h0_m, dtype=float)
    e = clearance_m - h0
    if not exact:
        return np.asarray(h0 + e * (1.0 - np.cos(theta)))
    rp = liner_radius_m - clearance_m
    s2 = _inside(e, np.sin(theta), rp, clearance_m)
    return np.asarray(clearance_m - e * np.cos(theta) + s2 / (rp + np.sqrt(rp * rp - s2)))


def dgap_dh0(
    theta_rad: ArrayLike, h0_m: ArrayLike, liner_radius_m: float, clearance_m: float, exact: bool = True
) -> np.ndarray:
    """Derivative of :func:`gap_m` with respect to the minimum gap ``h0`` [-] (``cos θ``: small-clearance gap).

    ``theta_rad`` [rad] and ``h0_m`` [m] broadcast against each other, as in :func:`gap_m`.
    """
    theta = np.asarray(theta_rad, dtype=float)
    h0 = np.asarray(h0_m, dtype=float)
    if not exact:
        return np.asarray(np.cos(theta) + 0.0 * h0)
    e = clearance_m - h0
    rp = liner_radius_m - clearance_m
    sin = np.sin(theta)
    s2 = _inside(e, sin, rp, clearance_m)
    with np.errstate(divide="ignore"):  # |e sin θ| = R_p exactly: the skirt touches the wall edge-on
        return np.asarray(np.cos(theta) - e * sin * sin / np.sqrt(rp * rp - s2))


def axial_profile_m(y_m: ArrayLike, skirt_length_m: float, crown_m: float) -> np.ndarray:
    """Extra gap [m] of a crowned (barrel) skirt at axial position ``y_m`` from its middle: ``crown (2y/L)²``."""
    y = np.asarray(y_m, dtype=float)
    return crown_m * (2.0 * y / skirt_length_m) ** 2


def contact_half_angle_rad(h_edge_m: float, h0_m: float, clearance_m: float) -> float:
    """Half-angle [rad] inside which the (small-clearance) gap is below ``h_edge_m``; ``π`` when it never exceeds it."""
    e = clearance_m - h0_m
    if h_edge_m <= h0_m:
        return 0.0
    if e <= 0:
        return math.pi
    cos_edge = 1.0 - (h_edge_m - h0_m) / e
    if cos_edge <= -1.0:
        return math.pi
    return math.acos(cos_edge)


def contact_half_length_m(h_edge_m: float, h0_m: float, skirt_length_m: float, crown_m: float) -> float:
    """Half-length [m] of skirt where the crown adds less than ``h_edge − h0`` to the gap (``L/2`` at most)."""
    half = 0.5 * skirt_length_m
    if crown_m <= 0:
        return half
    if h_edge_m <= h0_m:
        return 0.0
    return min(half, half * math.sqrt((h_edge_m - h0_m) / crown_m))


def contact_edge_angle_rad(
    h_edge_m: float, h0_m: float, liner_radius_m: float, clearance_m: float, exact: bool = True
) -> float:
    """Angle [rad] at which the gap (:func:`gap_m`, exact or small-clearance) reaches ``h_edge_m``; 0 or π outside.

    The gap grows monotonically from θ = 0 to π (for e > 0), so the crossing is unique; found by Newton's method
    on the exact gap (d/dθ of ``R_l − e cos θ − √(R_p² − e² sin² θ)``), starting from the small-clearance root.
    """
    estimate = contact_half_angle_rad(h_edge_m, h0_m, clearance_m)
    if not exact or estimate in (0.0, math.pi):
        return estimate
    e = clearance_m - h0_m
    rp = liner_radius_m - clearance_m
    if not abs(e) < rp:  # some angle would put the skirt through the liner wall
        raise OutOfGeometryError(h0_m, clearance_m, rp)
    theta = estimate
    for _ in range(8):  # Newton on the exact gap from the small-clearance root; converges in 2–3 steps
        sin, cos = math.sin(theta), math.cos(theta)
        root = math.sqrt(rp * rp - (e * sin) ** 2)
        f = clearance_m - e * cos + (e * sin) ** 2 / (rp + root) - h_edge_m
        slope = e * sin + e * e * sin * cos / root
        if slope <= 0:
            break
        step = f / slope
        theta = min(max(theta - step, 0.0), math.pi)
        if abs(step) <= 1e-15 * max(theta, 1.0):
            break
    return theta
