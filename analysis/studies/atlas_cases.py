"""The cases of the stability atlas, grouped by the method they exercise. Imports are inside each case."""

from __future__ import annotations

import numpy as np

from analysis.studies.atlas import Case

# a smooth steel/cast-iron-like pair, for cases that need statistics
_GT = {"sigma": 0.5e-6, "eta": 5e10, "beta": 5e-6}


def _gt_F_extremes() -> np.ndarray:
    from sims.greenwood_tripp import F

    t = np.array([-50.0, -8.0, 0.0, 10.0, 40.0, 1e3, 1e6])
    return np.concatenate([F(n, t) for n in (0.0, 1.0, 1.5, 2.0, 2.5)])


def _check_gt_tails(v: np.ndarray) -> None:
    f = v.reshape(5, 7)
    assert np.all(np.diff(f, axis=1) <= 0), "F_n not non-increasing in t"
    assert np.all(f[:, -1] == 0.0) or np.all(f[:, -1] < 1e-300), "F_n(1e6) not vanishing"
    # t → −∞: F_n(t) ≈ |t|^n
    np.testing.assert_allclose(f[:, 0], 50.0 ** np.array([0.0, 1.0, 1.5, 2.0, 2.5]), rtol=2e-3)


def _gt_pressure_sigma_tiny() -> np.ndarray:
    from sims.greenwood_tripp import pressure

    return pressure(np.array([-1e-9, 0.0, 1e-9, 1e-6]), sigma=1e-15, eta=5e10, beta=5e-6, E_star=1e11)


def _gt_pressure_E(E: float) -> np.ndarray:
    from sims.greenwood_tripp import pressure

    return pressure(np.linspace(-2e-6, 5e-6, 50), E_star=E, **_GT)


def _gt_pressure_E_out_of_domain() -> np.ndarray:
    from sims.greenwood_tripp import pressure

    return pressure(np.array([0.0]), E_star=-1e9, **_GT)


def _paper_polynomial_beyond_4() -> np.ndarray:
    from sims.greenwood_tripp import F

    return F(2.5, np.array([5.0, 6.0]), method="paper_polynomial")


def _gt_area_too_deep() -> np.ndarray:
    from sims.greenwood_tripp import area_fraction

    return area_fraction(np.array([-1e-3]), **_GT)


def greenwood_tripp_cases() -> list[Case]:
    return [
        Case(
            "F_n at t = −50 … 1e6",
            "greenwood_tripp.F",
            "Gaussian integrals far in both tails",
            _gt_F_extremes,
            "finite",
            check=_check_gt_tails,
        ),
        Case(
            "σ → 0 (1e-15 m)", "greenwood_tripp.pressure", "nearly smooth surfaces", _gt_pressure_sigma_tiny, "finite"
        ),
        Case(
            "E* = 1 kPa", "greenwood_tripp.pressure", "very compliant material", lambda: _gt_pressure_E(1e3), "finite"
        ),
        Case("E* = 10 TPa", "greenwood_tripp.pressure", "very stiff material", lambda: _gt_pressure_E(1e13), "finite"),
        Case("E* < 0", "greenwood_tripp.pressure", "outside the domain", _gt_pressure_E_out_of_domain, "error"),
        Case(
            "paper polynomial at t = 5, 6",
            "greenwood_tripp.F(paper_polynomial)",
            "beyond its table, where it turns negative",
            _paper_polynomial_beyond_4,
            "error",
        ),
        Case(
            "area fraction at h = −1 mm",
            "greenwood_tripp.area_fraction",
            "separation far below the surfaces",
            _gt_area_too_deep,
            "error",
        ),
    ]


def all_cases() -> list[Case]:
    """Every case, in report order."""
    cases: list[Case] = []
    cases += greenwood_tripp_cases()
    return cases
