"""Mesh of the piston skirt: cells in angle θ and axial position y, one node (cell centre) per cell.

Each node stands for the nominal area of its cell, ``ΔA = R_p Δθ Δy``, and the gap is taken as constant over the
cell (the paper's "one element, one node", section 2.1). The load is vertical and the skirt symmetric, so the mesh
covers one quarter, ``θ ∈ [0, π]`` and ``y ∈ [0, L/2]``, and every node counts four times (mirror images in θ and y);
summing ``area_m2`` gives the whole skirt, ``2π R_p L``.

- :func:`uniform_mesh`: equal cells over the half circumference and the half length (the baseline).
- :func:`variable_mesh`: equal fine cells over the expected contact zone ``θ ≤ θ_z`` (and ``y ≤ y_z`` for a crowned
  skirt), then cells growing geometrically to ``θ = π`` (``y = L/2``): dense where the contact is, coarse where it is
  not (seed Fig. 4). With a straight skirt the gap does not vary along y and one axial cell is exact. With
  ``tail=False`` the mesh stops at ``θ_z``: the caller has shown (:func:`sims.rig.loads.tail_bound`) that the skirt
  beyond carries nothing that matters — for an asperity model nothing at all, since its law is exactly zero above
  the highest summit. ``area_m2`` then sums to the zone's nominal area, not the whole skirt's.

Why equal (midpoint) cells in the zone and not Gauss–Legendre nodes: the Greenwood–Tripp integrand ``a(h(θ))`` is
smooth and falls to ~1e-9 of its peak at the zone's edge, so the midpoint rule is the trapezoidal rule of an
effectively periodic function and converges exponentially — faster per node than Gauss–Legendre, which crowds its
nodes at the edge where nothing happens (Trefethen & Weideman, SIAM Review 56, 2014). The asperity curves are sums
over discrete summits, tabulated: only piecewise smooth, and no rule beats second order on them.
``tests/benchmarks/bench_rig_mesh.py`` measures both rules.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["SkirtMesh", "graded_edges", "uniform_mesh", "variable_mesh"]

#: Size ratio of neighbouring cells outside the contact zone of a variable mesh.
GROWTH = 4.0


@dataclass(frozen=True)
class SkirtMesh:
    """Cell-centred mesh of a quarter of the skirt (θ ∈ [0, π], y ∈ [0, L/2]), each node counted four times.

    ``theta_edges_rad`` [rad] and ``y_edges_m`` [m] are the cell edges, ``radius_m`` the skirt radius R_p [m],
    ``kind`` ``"uniform"`` or ``"variable"``. A variable mesh without tail ends at its contact zone's edge.
    """

    theta_edges_rad: np.ndarray = field(repr=False)
    y_edges_m: np.ndarray = field(repr=False)
    radius_m: float
    kind: str

    @property
    def theta_rad(self) -> np.ndarray:
        """Cell-centre angles [rad]."""
        return 0.5 * (self.theta_edges_rad[1:] + self.theta_edges_rad[:-1])

    @property
    def y_m(self) -> np.ndarray:
        """Cell-centre axial positions from the skirt's middle [m]."""
        return 0.5 * (self.y_edges_m[1:] + self.y_edges_m[:-1])

    @property
    def shape(self) -> tuple[int, int]:
        """``(n_theta, n_y)``: cells in angle and along the axis."""
        return (self.theta_edges_rad.size - 1, self.y_edges_m.size - 1)

    @property
    def n_nodes(self) -> int:
        """Number of nodes evaluated (in the quarter that is meshed)."""
        return self.shape[0] * self.shape[1]

    @property
    def area_m2(self) -> np.ndarray:
        """Nominal area [m²] each node stands for, both mirror images included, shape ``(n_theta, n_y)``."""
        dtheta = np.diff(self.theta_edges_rad)
        dy = np.diff(self.y_edges_m)
        return 4.0 * self.radius_m * np.outer(dtheta, dy)


def graded_edges(start: float, stop: float, first: float, ratio: float = GROWTH) -> np.ndarray:
    """Cell edges from ``start`` to ``stop``: first cell ``first`` wide, each next ``ratio`` times wider.

    The last cell is stretched to end exactly at ``stop`` (a sliver narrower than half a cell is merged).
    """
    if stop <= start:
        return np.array([start])
    edges = [start]
    width = first
    while edges[-1] + width < stop:
        edges.append(edges[-1] + width)
        width *= ratio
    if len(edges) > 1 and stop - edges[-1] < 0.5 * width / ratio:
        edges.pop()
    edges.append(stop)
    return np.asarray(edges)


def uniform_mesh(radius_m: float, skirt_length_m: float, n_theta: int, n_axial: int) -> SkirtMesh:
    """``n_theta`` equal cells on θ ∈ [0, π] times ``n_axial`` equal cells on y ∈ [0, L/2]."""
    return SkirtMesh(
        theta_edges_rad=np.linspace(0.0, math.pi, n_theta + 1),
        y_edges_m=np.linspace(0.0, 0.5 * skirt_length_m, n_axial + 1),
        radius_m=radius_m,
        kind="uniform",
    )


def variable_mesh(
    radius_m: float,
    skirt_length_m: float,
    theta_zone_rad: float,
    n_theta: int,
    y_zone_m: float | None = None,
    n_axial: int = 1,
    *,
    tail: bool = True,
) -> SkirtMesh:
    """``n_theta`` equal cells on [0, θ_zone] then growing cells to π; likewise in y when ``y_zone_m`` is given.

    ``y_zone_m=None`` (straight skirt: the gap does not vary along y) gives one axial cell. ``tail=False`` leaves out
    the cells beyond θ_zone (see the module docstring); angles in rad, lengths in m.
    """
    theta_zone = min(max(theta_zone_rad, 0.0), math.pi)
    if theta_zone <= 0.0:
        theta_zone = math.pi / n_theta  # no expected contact: still resolve the bottom of the skirt
    fine = np.linspace(0.0, theta_zone, n_theta + 1)
    theta_edges = (
        fine if not tail else np.concatenate([fine, graded_edges(theta_zone, math.pi, theta_zone / n_theta)[1:]])
    )
    half = 0.5 * skirt_length_m
    if y_zone_m is None:
        y_edges = np.array([0.0, half])
    else:
        y_zone = min(max(y_zone_m, half / (4 * n_axial)), half)
        y_fine = np.linspace(0.0, y_zone, n_axial + 1)
        y_edges = np.concatenate([y_fine, graded_edges(y_zone, half, y_zone / n_axial)[1:]])
    return SkirtMesh(theta_edges_rad=theta_edges, y_edges_m=y_edges, radius_m=radius_m, kind="variable")
