"""The solver's cold start under pressure control: the full-contact pressure cut down to the load (issue 28).

Polonsky & Keer start from the uniform mean pressure, so that the first iterations work on the whole grid; the start
now puts the load where complete contact would press hardest, min(max(f + λ, 0), H′) with f = C⁻¹(z − mean z).
Checked here: the start itself (its mean, its bounds, the exact full-contact field where contact is complete), and
that it reaches the same solution as the uniform start (the solution of the contact problem is unique: the elastic
energy is strictly convex on the pressures) in fewer iterations.
"""

from __future__ import annotations

import math
import types

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sims import bem
from tests.sims.test_bem_rectangular import rough

PIX, E_STAR = 1e-6, 1e11


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    size=st.integers(2, 400),
    mean=st.floats(1e-6, 10.0),
    cap=st.one_of(st.just(math.inf), st.floats(1e-3, 50.0)),
    spread=st.floats(1e-3, 1e3),
)
def test_the_cut_carries_the_load_below_the_hardness(seed, size, mean, cap, spread):
    rng = np.random.default_rng(seed)
    field = rng.standard_normal(size) * spread
    field -= field.mean()  # C⁻¹ has no mean mode: the full-contact field beyond p̄ has mean zero
    cut = bem._cut_full_contact(np, field, mean, cap)
    assert cut.shape == field.shape and np.all(np.isfinite(cut)) and np.all(cut >= 0.0)
    top = cap * (1.0 - 2.0 * bem._CUT_RTOL)
    if mean < top:
        assert np.all(cut <= top)  # no point starts at the hardness, even after the start scales to the load
        assert abs(cut.mean() - mean) <= 1.01 * bem._CUT_RTOL * mean
    else:  # a load within 0.2 % of the hardness: the uniform start
        np.testing.assert_array_equal(cut, np.full(size, mean))


def test_near_the_hardness_the_start_is_uniform(monkeypatch):
    """Above p̄ = 0.5 H the solver keeps Polonsky & Keer's uniform start (the cut one stalled load control there more
    often): the cut is not even made."""
    made = []
    monkeypatch.setattr(bem, "_cut_full_contact", lambda *a: made.append(a) or np.full(a[1].size, a[2]))
    z = rough(64, 64, seed=1)
    slope = float(np.sqrt(np.mean(np.gradient(z, PIX, axis=0) ** 2 + np.gradient(z, PIX, axis=1) ** 2)))
    p_mean = 0.025 * E_STAR * slope
    bem.solve_contact(z, PIX, E_STAR, p_mean, hardness=1.5 * p_mean, tol=1e-6, workers=1)
    assert not made
    bem.solve_contact(z, PIX, E_STAR, p_mean, hardness=2.5 * p_mean, tol=1e-6, workers=1)
    assert len(made) == 1


def test_where_contact_is_complete_the_cut_is_the_full_contact_field():
    field = np.sin(np.linspace(0.0, 2.0 * np.pi, 64, endpoint=False))  # min −1: complete at p̄ ≥ 1
    np.testing.assert_array_equal(bem._cut_full_contact(np, field, 1.5, math.inf), field + 1.5)


@pytest.mark.parametrize("hardness_over_load", [None, 12.0])
@pytest.mark.parametrize("seed", [1, 2])
def test_the_cold_start_reaches_the_uniform_start_solution_in_fewer_iterations(hardness_over_load, seed):
    z = rough(256, 256, seed=seed)
    slope = float(np.sqrt(np.mean(np.gradient(z, PIX, axis=0) ** 2 + np.gradient(z, PIX, axis=1) ** 2)))
    p_mean = 0.025 * E_STAR * slope  # ≈ 5 % of the grid in contact
    hardness = None if hardness_over_load is None else hardness_over_load * p_mean  # the benchmark's capped case
    kwargs = {"hardness": hardness, "tol": 1e-8, "workers": 1}
    cold = bem.solve_contact(z, PIX, E_STAR, p_mean, **kwargs)
    uniform = bem.solve_contact(z, PIX, E_STAR, p_mean, initial_pressure=np.full(z.shape, p_mean), **kwargs)
    assert cold.success and uniform.success
    assert 0.01 < cold.area_fraction < 0.3 and (hardness is None or cold.plastic_fraction > 0.0)
    # one solution: both meet the contact conditions to 1e-8·rms(z)
    assert float(np.abs(cold.pressure - uniform.pressure).max()) <= 1e-6 * float(uniform.pressure.max())
    assert abs(cold.area_fraction - uniform.area_fraction) <= 2.0 / z.size
    assert cold.mean_gap == pytest.approx(uniform.mean_gap, rel=1e-6)
    assert cold.nit < uniform.nit


@pytest.mark.parametrize("cap", [math.inf, 2e-6])
def test_a_load_below_the_fields_resolution_ends_the_search_early(cap):
    """One spike 1e18 times the load: λ ≈ −1e12 is known to ~1e-4, the load's 1e-3 tolerance is 1e-6 a point, no λ
    meets it. The search ends when its bracket holds no float between its ends (it ran all 100 passes before) and
    returns the closest sum it met (the solver's start scales it to the load)."""
    passes = []

    def clip(a: np.ndarray, lo: float, hi: float) -> np.ndarray:
        passes.append(1)
        return np.clip(a, lo, hi)

    xp = types.SimpleNamespace(clip=clip, count_nonzero=np.count_nonzero, full=np.full)
    field = np.zeros(1000)
    field[0] = 1e12
    field -= field.mean()
    cut = bem._cut_full_contact(xp, field, 1e-6, cap)
    assert len(passes) <= 60
    assert np.all(cut >= 0.0) and np.all(cut <= min(cap * (1 - 2 * bem._CUT_RTOL), 1e12))
    assert abs(cut.mean() / 1e-6 - 1) < 0.05


def test_a_stall_from_the_cut_start_starts_again_from_the_uniform_pressure():
    """A flat surface with one crest that the hardness flattens (issue 28's review): from the cut start load control
    stalled and the bracketing fallback ran out of iterations (success False), where the uniform start converges in
    6. The solver now starts once more from the uniform pressure after such a stall, the iterations counted."""
    z = np.zeros((32, 32))
    z[5, 7] = 1e-9
    cold = bem.solve_contact(z, PIX, E_STAR, 1e4, hardness=3e4)
    uniform = bem.solve_contact(z, PIX, E_STAR, 1e4, hardness=3e4, initial_pressure=np.full(z.shape, 1e4))
    assert cold.success and uniform.success
    assert "restarted from the uniform pressure" in cold.message and "bracketing" not in cold.message
    assert cold.nit > uniform.nit  # the stalled iterations are counted, not hidden
    # the load is met, the crest flattened at the hardness, and the same field as the uniform start's
    assert cold.mean_pressure == pytest.approx(1e4, rel=1e-12) and float(cold.pressure.max()) == pytest.approx(3e4)
    assert float(np.abs(cold.pressure - uniform.pressure).max()) <= 1e-6 * 3e4
