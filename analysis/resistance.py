"""Contact area → electrical contact resistance: the seed paper's bulk formula and constriction resistance.

Three views of the same contact, from crude to physical:

* **Bulk conductor** (seed eq. 23): R_T = ζ·h/A. The contact is treated as a prism of cross-section A (the real
  contact area) and length h (the "electric contact height"). R ∝ 1/A. This is what the paper uses to turn the
  simulated area of Fig. 11 into the resistance ratios of Fig. 12.
* **Holm single spot — an upper bound on the clean-metal constriction** (the ``holm`` conversion of
  :mod:`analysis.fit`): one circular spot of radius a between two half-spaces, R = ζ1/(4a) + ζ2/(4a) (= ζ/(2a) for
  equal resistivities). Current crowding into the spot, not the length of a conductor, sets the resistance;
  R ∝ 1/√A for a single spot of area A = πa². With all of the real area A in one circle it bounds from above the
  clean-metal constriction of any contact of real area A (Pólya & Szegő: the disc has the least capacity among
  plane sets of given area); it is not a model of the rig (:mod:`analysis.resistance_model`).
* **Greenwood (1966)** for a cluster of n spots of radii a_i at centre distances s_ij (both bodies, mean
  resistivity ζ̄ = (ζ1+ζ2)/2)::

      R = ζ̄/(2 Σa_i) + (ζ̄/π) · Σ_{i≠j} a_i a_j / s_ij / (Σa_i)²

  (the double sum runs over ordered pairs). The first term is the spots in parallel, each with its Holm
  resistance; the second is their interaction: current spreading from one spot raises the potential at the others
  by ζ/(π s) per ampere (both bodies). Derived by assuming each spot carries current ∝ a_i, exact to first order in
  a/s. For spots spread uniformly over a patch of radius α it tends to ζ̄/(2Σa) + 16ζ̄/(3π²α): the cluster behaves
  almost like one Holm spot of the patch radius (ζ̄/(2α)), nearly independent of the real area.
  :func:`greenwood_patch_resistance_ohm` evaluates it for n equal spots of total area A spread over a rectangular
  nominal patch (the piston skirt's contact strip), with the patch's mean inverse distance by quadrature.

Reference: J. A. Greenwood, "Constriction resistance and the real area of contact", Br. J. Appl. Phys. 17 (1966)
1621–1632; R. Holm, *Electric Contacts*, 4th ed. (1967), §4. All functions take SI units and numpy arrays.
"""

from __future__ import annotations

import math

import numpy as np

from contactrig.core.validation import SettingError, check_int, check_range

__all__ = [
    "CONVERSIONS",
    "area_to_resistance_ohm",
    "bulk_resistance_ohm",
    "greenwood_cluster_resistance_ohm",
    "greenwood_patch_resistance_ohm",
    "holm_resistance_ohm",
    "holm_single_spot_resistance_ohm",
    "mean_inverse_distance_rectangle_per_m",
    "resistance_unit",
]

#: Named conversions from a real contact area A to a resistance (see :func:`area_to_resistance_ohm`).
CONVERSIONS = ("bulk", "holm", "physical")

#: Display units of resistance, largest first: (factor to multiply ohms by, unit).
_RESISTANCE_UNITS = ((1.0, "Ω"), (1e3, "mΩ"), (1e6, "µΩ"))


def resistance_unit(values_ohm: np.ndarray | float | list[float]) -> tuple[float, str]:
    """The display unit for resistances like ``values_ohm`` [Ω]: ``(factor, unit)`` with ``value_ohm * factor`` in
    ``unit`` — Ω, mΩ or µΩ, the largest in which the median magnitude of the finite values is ≥ 1 (µΩ below 1 mΩ;
    mΩ when no value is finite). The one choice every figure axis and report table makes."""
    x = np.abs(np.asarray(values_ohm, dtype=float)).reshape(-1)
    x = x[np.isfinite(x) & (x > 0)]
    if x.size == 0:
        return 1e3, "mΩ"
    typical = float(np.median(x))
    for factor, unit in _RESISTANCE_UNITS:
        if typical * factor >= 1.0:
            return factor, unit
    return _RESISTANCE_UNITS[-1]


def _positive_array(field: str, value: np.ndarray | float, unit: str) -> np.ndarray:
    x = np.asarray(value, dtype=float)
    bad = ~np.isfinite(x) | (x <= 0.0)
    if np.any(bad):
        first = x.reshape(-1)[int(np.flatnonzero(bad.reshape(-1))[0])]
        raise SettingError(field, float(first), f"expected finite values > 0 {unit} (zero area: no contact)")
    return x


def bulk_resistance_ohm(area_m2: np.ndarray | float, resistivity_ohm_m: float, height_m: float) -> np.ndarray:
    """Seed eq. 23: R_T = ζ·h_R / A_R [Ω], the contact taken as a bulk conductor.

    ``area_m2`` real contact area A_R [m²] (the paper's "contact pressure [m²]" is a misprint), scalar or array,
    every value finite and > 0; ``resistivity_ohm_m`` ζ [Ω·m] > 0; ``height_m`` electric contact height h_R [m] > 0.
    Returns an array of the shape of ``area_m2``.
    """
    zeta = check_range("resistivity_ohm_m", resistivity_ohm_m, 0.0, None, lo_open=True, unit="Ω·m")
    h = check_range("height_m", height_m, 0.0, None, lo_open=True, unit="m")
    a = _positive_array("area_m2", area_m2, "m²")
    return zeta * h / a


def _mean_resistivity(resistivity_ohm_m: float, resistivity2_ohm_m: float | None) -> float:
    z1 = check_range("resistivity_ohm_m", resistivity_ohm_m, 0.0, None, lo_open=True, unit="Ω·m")
    if resistivity2_ohm_m is None:
        return z1
    z2 = check_range("resistivity2_ohm_m", resistivity2_ohm_m, 0.0, None, lo_open=True, unit="Ω·m")
    return 0.5 * (z1 + z2)


def holm_resistance_ohm(
    radius_m: np.ndarray | float, resistivity_ohm_m: float, resistivity2_ohm_m: float | None = None
) -> np.ndarray:
    """Holm constriction resistance of one circular spot of radius a [m] between two half-spaces [Ω].

    R = ζ1/(4a) + ζ2/(4a); with ``resistivity2_ohm_m`` None both bodies have ζ1 and R = ζ1/(2a).
    """
    a = _positive_array("radius_m", radius_m, "m")
    return 2.0 * _mean_resistivity(resistivity_ohm_m, resistivity2_ohm_m) / (4.0 * a)


def holm_single_spot_resistance_ohm(
    area_m2: np.ndarray | float, resistivity_ohm_m: float, resistivity2_ohm_m: float | None = None
) -> np.ndarray:
    """Holm resistance of the whole real area merged into one circular spot, a = √(A/π) [Ω]: R = ζ̄/(2a) ∝ 1/√A."""
    a = np.sqrt(_positive_array("area_m2", area_m2, "m²") / math.pi)
    return holm_resistance_ohm(a, resistivity_ohm_m, resistivity2_ohm_m)


def greenwood_cluster_resistance_ohm(
    radii_m: np.ndarray,
    centres_m: np.ndarray,
    resistivity_ohm_m: float,
    resistivity2_ohm_m: float | None = None,
    *,
    block: int = 512,
) -> float:
    """Greenwood's (1966) constriction resistance of a cluster of circular spots [Ω].

    ``radii_m`` shape (n,) spot radii a_i > 0; ``centres_m`` shape (n, 2) spot centres [m] in the contact plane.
    R = ζ̄/(2Σa_i) + (ζ̄/π) Σ_{i≠j} a_i a_j/s_ij / (Σa_i)², ζ̄ = (ζ1 + ζ2)/2 (module docstring). Valid for spots
    that do not overlap (s_ij ≥ a_i + a_j); overlapping or coincident spots are an error. One spot gives Holm's
    ζ̄/(2a); widely separated spots give the parallel Holm resistances. The pair sum is done in row blocks of
    ``block`` spots, so memory stays O(n·block).
    """
    a = _positive_array("radii_m", radii_m, "m").reshape(-1)
    xy = np.asarray(centres_m, dtype=float)
    if xy.shape != (a.size, 2):
        raise SettingError("centres_m", f"array of shape {xy.shape}", f"expected shape ({a.size}, 2)")
    if not np.all(np.isfinite(xy)):
        raise SettingError("centres_m", "NaN/inf", "expected finite coordinates in m")
    zeta = _mean_resistivity(resistivity_ohm_m, resistivity2_ohm_m)
    total = float(a.sum())
    pair_sum = 0.0
    for start in range(0, a.size, block):
        stop = min(start + block, a.size)
        d = np.hypot(xy[start:stop, None, 0] - xy[None, :, 0], xy[start:stop, None, 1] - xy[None, :, 1])
        rows = np.arange(start, stop)
        d[rows - start, rows] = np.inf  # i == j is not a pair
        touching = d < a[start:stop, None] + a[None, :]
        if np.any(touching):
            i, j = np.argwhere(touching)[0]
            raise SettingError(
                "centres_m",
                f"spots {start + i} and {j} at {d[i, j]:.3g} m",
                "expected non-overlapping spots (s_ij >= a_i + a_j); merge overlapping spots first",
            )
        pair_sum += float(np.sum(a[start:stop, None] * a[None, :] / d))
    return zeta / (2.0 * total) + zeta / math.pi * pair_sum / total**2


def mean_inverse_distance_rectangle_per_m(width_m: float, length_m: float) -> float:
    """⟨1/s⟩ [1/m] between two points drawn uniformly from a width × length rectangle.

    ⟨1/s⟩ = 4/(w²L²) ∫∫_{[0,w]×[0,L]} (w − x)(L − y)/√(x² + y²) dx dy, in polar coordinates (the radial integral
    is a polynomial, done exactly; the angle by adaptive quadrature). Unit square: 4(1 − √2)/3 + 4 asinh 1.
    """
    from scipy.integrate import quad

    a = check_range("patch_width_m", width_m, 0.0, None, lo_open=True, unit="m")
    b = check_range("patch_length_m", length_m, 0.0, None, lo_open=True, unit="m")
    theta0 = math.atan2(b, a)

    def radial(theta: float, r: float) -> float:
        c, s = math.cos(theta), math.sin(theta)
        return a * b * r - (a * s + b * c) * r * r / 2.0 + c * s * r**3 / 3.0

    i1 = quad(lambda t: radial(t, a / math.cos(t)), 0.0, theta0, epsabs=0.0, epsrel=1e-12)[0]
    i2 = quad(lambda t: radial(t, b / math.sin(t)), theta0, math.pi / 2, epsabs=0.0, epsrel=1e-12)[0]
    return 4.0 / (a * a * b * b) * (i1 + i2)


def greenwood_patch_resistance_ohm(
    area_m2: np.ndarray | float,
    n_spots: int,
    patch_width_m: float,
    patch_length_m: float,
    resistivity_ohm_m: float,
    resistivity2_ohm_m: float | None = None,
) -> np.ndarray:
    """Greenwood (1966) for ``n_spots`` equal spots of total area A spread uniformly over a nominal patch [Ω].

    Equal radii a = √(A/(nπ)) make Σa_i = √(nA/π) and the interaction sum (1 − 1/n)(Σa)²⟨1/s⟩, so
    R = ζ̄/(2√(nA/π)) + (ζ̄/π)(1 − 1/n)⟨1/s⟩ with ⟨1/s⟩ of the width × length patch
    (:func:`mean_inverse_distance_rectangle_per_m`). One spot is Holm's single spot; with many spots the second,
    area-independent term dominates — constriction resistance then says little about the real area. With n and
    the patch fixed this is R = const + ζ̄√π/(2√n)/√A: the ``"holm"`` fit conversion with the constant in R_s.
    The real area must be smaller than the patch (A < w·L).
    """
    n = check_int("n_spots", n_spots, 1)
    area = _positive_array("area_m2", area_m2, "m²")
    w = check_range("patch_width_m", patch_width_m, 0.0, None, lo_open=True, unit="m")
    length = check_range("patch_length_m", patch_length_m, 0.0, None, lo_open=True, unit="m")
    if np.any(area >= w * length):
        raise SettingError(
            "area_m2", float(np.max(area)), f"expected a real area below the patch area {w * length:g} m²"
        )
    zeta = _mean_resistivity(resistivity_ohm_m, resistivity2_ohm_m)
    inv = mean_inverse_distance_rectangle_per_m(w, length) if n > 1 else 0.0
    return zeta / (2.0 * np.sqrt(n * area / math.pi)) + zeta / math.pi * (1.0 - 1.0 / n) * inv


def area_to_resistance_ohm(
    area_m2: np.ndarray | float, resistivity_ohm_m: float, height_m: float, conversion: str = "bulk"
) -> np.ndarray:
    """Real contact area A [m²] → contact resistance [Ω] by a named conversion.

    ``"bulk"``: seed eq. 23, ζ h/A. ``"holm"``: all of A in one Holm spot, ζ/(2√(A/π)) (``height_m`` unused).
    ``"physical"`` (R_s + σ_f/A + Barber + band constriction) is a fit only (:mod:`analysis.resistance_model`).
    The fit (:mod:`analysis.fit`) uses the same conversions as regressors.
    """
    if conversion == "bulk":
        return bulk_resistance_ohm(area_m2, resistivity_ohm_m, height_m)
    if conversion == "holm":
        return holm_single_spot_resistance_ohm(area_m2, resistivity_ohm_m)
    if conversion == "physical":
        raise SettingError(
            "conversion", conversion, "the physical model needs the rig's clean-metal terms: analysis.resistance_model"
        )
    raise SettingError("conversion", conversion, "expected one of " + ", ".join(repr(c) for c in CONVERSIONS))
