"""The ``bem`` contact model (sims.bem_database) against Westergaard's closed form and the database's invariants.

References (independent of the solver): Westergaard's wavy surface z = Δ cos(2πx/λ) (Johnson, Contact Mechanics
§13.2): contact half-width a with p̄/p* = sin²(πa/λ), mean gap ū/Δ = 1 − x + x ln x (x = p̄/p*, checked by quadrature
in test_bem.py), p* = πE*Δ/λ; the RMS slope of a single cosine, 2πΔ/(λ√2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import pytest

from contactrig.core.validation import SettingError
from sims import bem_database as bd
from sims.database import BuildContext, DatabaseSettings, Summits
from sims.models import default_model_names, get_model, model_names

N, LAM, DELTA, E = 64, 1e-3, 1e-6, 1e9
PIX = LAM / N
X = np.arange(N) * PIX
Z_W = np.tile((DELTA * np.cos(2 * np.pi * X / LAM))[:, None], (1, N))
P_STAR = math.pi * E * DELTA / LAM


def test_registered_as_a_reference_not_built_by_default():
    assert "bem" in model_names(builtin_only=True)
    assert "bem" not in default_model_names()
    spec = get_model("bem")
    assert spec.needs_surface and not spec.elastic_only and not spec.default
    assert "Polonsky" in spec.equations


def test_rms_slope_of_a_cosine():
    assert bd.rms_slope_spectral(Z_W, PIX) == pytest.approx(2 * math.pi * DELTA / (LAM * math.sqrt(2)), rel=1e-12)


def test_curve_follows_westergaard():
    st = bd.BemCurveSettings(n_points=8, max_area_fraction=0.6, min_pressure_ratio=0.02, plastic=False,
                             area="counted", tol=1e-9)  # fmt: skip
    curve = bd.bem_curve(Z_W, PIX, E, settings=st)
    h, p, a = curve.separation_m[:-1], curve.pressure_pa[:-1], curve.area_fraction[:-1]
    assert curve.separation_m[-1] == pytest.approx(DELTA, rel=1e-12)  # onset: the crest, p = A = 0
    assert curve.pressure_pa[-1] == 0.0 and curve.area_fraction[-1] == 0.0
    x = p / P_STAR
    assert x.max() < 1.0 and x.min() > 0.0
    # separation of the mean planes = mean gap of an elastic half-space: Westergaard's ū(p̄)
    np.testing.assert_allclose(h / DELTA, 1 - x + x * np.log(x), atol=3e-3)
    # contact width 2a/λ with sin²(πa/λ) = p̄/p*, to one cell per edge
    np.testing.assert_allclose(a, 2 / math.pi * np.arcsin(np.sqrt(x)), atol=2.0 / N)
    # the database's slope is the interfacial stiffness K = −dp̄/dū = p*/(Δ ln(p*/p̄)) (interpolated, so loose)
    mid = h[3]
    k_exact = P_STAR / (DELTA * math.log(1 / float(curve.pressure(mid)) * P_STAR))
    assert -float(curve.dpressure_dh(mid)) == pytest.approx(k_exact, rel=0.05)
    assert curve.parameters["all_converged"] and curve.parameters["area_monotone_fixes"] == 0


def _ctx(z: np.ndarray | None, pixel: float, hardness: float) -> BuildContext:
    mats = SimpleNamespace(E_star=E, H=hardness)
    summits = Summits(np.array([1e-6, 0.5e-6]), np.array([1e-3, 1e-3]), (N * pixel) ** 2, np.linspace(0, 1e-6, 16))
    ctx = BuildContext(DatabaseSettings(models=("hertz",)), mats, {"sigma_m": float(np.std(Z_W))}, summits)  # type: ignore[arg-type]
    if z is not None:

        @dataclass(frozen=True)
        class WithComposite(Summits):
            composite_m: np.ndarray | None = None
            pixel_m: float = math.nan

        ctx.summits = WithComposite(summits.height_m, summits.radius_m, summits.area_m2, summits.separation_m,
                                    composite_m=z, pixel_m=pixel)  # fmt: skip
    return ctx


def test_registry_build_caps_at_the_hardness_and_keeps_the_database_invariants():
    rng = np.random.default_rng(4)
    z = Z_W + 0.2 * DELTA * np.roll(Z_W.T, 5, axis=0) + 1e-9 * rng.standard_normal(Z_W.shape)
    hardness = 0.4 * P_STAR
    curve = get_model("bem").build(_ctx(z, PIX, hardness))
    p, a = curve.pressure_pa, curve.area_fraction
    assert np.all(np.isfinite(p)) and np.all(p[:-1] > 0) and np.all(a[:-1] > 0) and p[-1] == a[-1] == 0.0
    assert np.all(np.diff(p) <= 0) and np.all(np.diff(a) <= 0)
    assert p.max() <= 0.5 * hardness * (1 + 1e-12)  # the ramp stays below H/2 with a cap
    assert curve.parameters["H_pa"] == hardness
    # evaluation anywhere: finite, non-negative
    hq = np.linspace(curve.h_min - 2 * DELTA, curve.h_max + DELTA, 50)
    assert np.all(curve.pressure(hq) >= 0) and np.all(np.isfinite(curve.pressure(hq)))
    assert np.all((curve.area_fraction_at(hq) >= 0) & (curve.area_fraction_at(hq) <= 1))


def test_registry_build_without_the_composite_map_says_what_is_missing():
    with pytest.raises(RuntimeError, match="composite_m"):
        get_model("bem").build(_ctx(None, PIX, P_STAR))


def test_build_database_with_bem_on_a_small_scene():
    from dataclasses import replace

    from contactrig.core.scene import load_scene
    from sims.config import SimConfig
    from sims.database import build_database

    cfg = SimConfig.from_scene(load_scene(None))
    cfg = cfg.with_changes(liner=replace(cfg.liner, n=64), piston=replace(cfg.piston, n=64))
    db = build_database(cfg, ["hertz", "bem"])
    z, pix = bd.composite_from_config(cfg)
    assert db["bem"].h_max == pytest.approx(float(z.max() - z.mean()), rel=1e-12)
    assert db["bem"].parameters["pixel_m"] == pix


def test_invalid_settings_raise():
    with pytest.raises(SettingError, match=r"bem\.area"):
        bd.BemCurveSettings(area="exact")
    with pytest.raises(SettingError, match=r"bem\.n_points"):
        bd.BemCurveSettings(n_points=2)
    with pytest.raises(SettingError, match="rough"):
        bd.bem_curve(np.zeros((8, 8)), 1e-6, E)
