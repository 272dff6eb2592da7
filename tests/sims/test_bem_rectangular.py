"""The FFT boundary elements on rectangular periodic cells ny × nx (rows × columns, square pixels).

References used (independent of the solver): Westergaard's wavy surface (Johnson, Contact Mechanics 1985, §13.2:
full contact at p* = πE*Δ/λ, contact half-width a from p̄ = p* sin²(πa/λ), the partial-contact pressure) laid along
the long and along the short axis of a 64 × 256 cell; the full-contact pressure of the two-wave surface
z = Δ cos(2πx/λx) cos(2πy/λy), whose four Fourier modes share |q| = 2π·sqrt(1/λx² + 1/λy²) so that the pressure that
closes every gap is p̄ + (E*|q|/2)·z, i.e. p* = πE*Δ·sqrt(1/λx² + 1/λy²) (Johnson, Greenwood & Higginson,
Int. J. Mech. Sci. 27 (1985) 383: √2·πE*Δ/λ for λx = λy); periodicity (a surface tiled twice is the same periodic
problem); and the Signorini conditions and load balance on random shapes.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from contactrig.core.validation import SettingError
from sims import bem

E_W, DELTA, PIX = 1e9, 1e-6, 1e-5  # Pa, m, m
NY, NX = 64, 256


def rough(ny: int, nx: int, seed: int, cut: int = 4) -> np.ndarray:
    """Periodic random heights (m) on an ny×nx grid at pitch PIX: a power-law spectrum cut at cut·PIX, rms 1 µm."""
    qy = np.fft.fftfreq(ny)[:, None]
    qx = np.fft.rfftfreq(nx)[None, :]
    q = np.hypot(qy, qx)
    psd = np.where((q > 0) & (q < 1.0 / cut), np.maximum(q, 4.0 / max(ny, nx)) ** -3.6, 0.0)
    rng = np.random.default_rng(seed)
    z = np.fft.irfft2(np.sqrt(psd) * np.exp(2j * np.pi * rng.random(q.shape)), s=(ny, nx))
    return z / z.std() * 1e-6


def westergaard(axis: int, waves: int) -> tuple[np.ndarray, np.ndarray, float]:
    """z = Δ cos(2πs/λ) along ``axis`` (0: y, the 64 rows; 1: x, the 256 columns) of a NY × NX cell with ``waves``
    wavelengths in it; (z, s measured from the nearest crest, λ)."""
    n = (NY, NX)[axis]
    lam = n * PIX / waves
    s = np.arange(n) * PIX
    profile = DELTA * np.cos(2 * np.pi * s / lam)
    z = np.broadcast_to(profile[:, None] if axis == 0 else profile[None, :], (NY, NX)).copy()
    return z, (s + lam / 2) % lam - lam / 2, lam


@pytest.mark.parametrize(("axis", "waves"), [(1, 1), (1, 4), (0, 1), (0, 2)])
def test_westergaard_full_contact_along_either_axis(axis, waves):
    z, s, lam = westergaard(axis, waves)
    p_star = math.pi * E_W * DELTA / lam  # Johnson §13.2
    assert bem.full_contact_pressure(z, PIX, E_W) == pytest.approx(p_star, rel=1e-9)
    res = bem.solve_contact(z, PIX, E_W, 1.2 * p_star)
    assert res.success and res.area_fraction == 1.0 and res.shape == (NY, NX)
    expected = 1.2 * p_star + p_star * np.cos(2 * np.pi * s / lam)  # p = p̄ + p* cos(2πs/λ)
    line = res.pressure[:, 5] if axis == 0 else res.pressure[5, :]
    np.testing.assert_allclose(line, expected, rtol=0, atol=1e-9 * p_star)


@pytest.mark.parametrize(("axis", "waves"), [(1, 1), (1, 2), (0, 1)])
@pytest.mark.parametrize("ratio", [0.2, 0.6])
def test_westergaard_partial_contact_along_either_axis(axis, waves, ratio):
    z, s, lam = westergaard(axis, waves)
    p_star = math.pi * E_W * DELTA / lam
    res = bem.solve_contact(z, PIX, E_W, ratio * p_star, tol=1e-8)
    assert res.success and res.mean_pressure == pytest.approx(ratio * p_star, rel=1e-12)
    a = lam / math.pi * math.asin(math.sqrt(ratio))  # p̄ = p* sin²(πa/λ)
    line = res.pressure[:, 3] if axis == 0 else res.pressure[3, :]
    field = res.pressure if axis == 1 else res.pressure.T
    assert np.all(field == field[:1, :])  # extruded along the other axis
    # area fraction 2a/λ within the grid's resolution (one pixel on each side of each contact)
    assert abs(res.area_fraction - 2 * a / lam) <= 2 * PIX / lam + 1e-12
    half_width = np.max(np.abs(s[line > 0]))
    assert abs(half_width - a) <= PIX
    sin2 = ratio
    root = np.sqrt(np.clip(sin2 - np.sin(np.pi * s / lam) ** 2, 0.0, None))
    exact = 2 * ratio * p_star * np.cos(np.pi * s / lam) / sin2 * root  # Johnson §13.2
    inner = np.abs(s) < a - 3 * PIX
    assert inner.sum() >= 6
    assert np.max(np.abs(line - exact)[inner]) < 0.02 * exact.max()


@pytest.mark.parametrize(("ny", "nx", "wy", "wx"), [(64, 256, 1, 2), (96, 32, 3, 1), (48, 128, 2, 5)])
def test_two_wave_surface_full_contact_pressure(ny, nx, wy, wx):
    lam_y, lam_x = ny * PIX / wy, nx * PIX / wx
    y, x = np.mgrid[0:ny, 0:nx] * PIX
    z = DELTA * np.cos(2 * np.pi * x / lam_x) * np.cos(2 * np.pi * y / lam_y)
    p_star = math.pi * E_W * DELTA * math.sqrt(1 / lam_x**2 + 1 / lam_y**2)
    assert bem.full_contact_pressure(z, PIX, E_W) == pytest.approx(p_star, rel=1e-9)
    res = bem.solve_contact(z, PIX, E_W, 1.1 * p_star)
    assert res.success and res.area_fraction == 1.0
    np.testing.assert_allclose(res.pressure, 1.1 * p_star + p_star * z / DELTA, rtol=0, atol=1e-9 * p_star)
    below = bem.solve_contact(z, PIX, E_W, 0.9 * p_star)
    assert below.success and below.area_fraction < 1.0


@pytest.mark.parametrize("axis", [0, 1])
def test_a_tiled_surface_gives_the_tiled_solution(axis):
    z = rough(48, 48, seed=2)
    reps = (2, 1) if axis == 0 else (1, 2)
    for hardness in (None, 3e6):
        one = bem.solve_contact(z, PIX, E_W, 1e6, hardness=hardness, tol=1e-10)
        two = bem.solve_contact(np.tile(z, reps), PIX, E_W, 1e6, hardness=hardness, tol=1e-10)
        assert one.success and two.success and two.shape == (48 * reps[0], 48 * reps[1])
        assert np.max(np.abs(two.pressure - np.tile(one.pressure, reps))) <= 1e-6 * one.pressure.max()
        assert two.area_fraction == one.area_fraction
        assert two.mean_gap == pytest.approx(one.mean_gap, rel=1e-6)
        assert two.n_spots == one.n_spots * 2


def test_a_rectangular_surface_refines_exactly():
    z = rough(24, 40, seed=4)
    fine = bem.refine(z, 2)
    assert fine.shape == (48, 80)
    np.testing.assert_allclose(fine[::2, ::2], z, rtol=0, atol=1e-12 * np.abs(z).max())


@pytest.mark.parametrize("shape", [(12, 20), (20, 12)])
def test_refinement_of_a_band_limited_rectangle_is_the_continuous_surface(shape):
    """A trigonometric polynomial below the grid's Nyquist wavenumber on both axes, different along each: the refined
    grid equals the function itself at every fine point (not only at the old samples)."""
    ny, nx = shape

    def f(y, x):  # y, x in pixels of the coarse grid; periods ny and nx pixels
        return (np.cos(2 * np.pi * 3 * x / nx + 0.3) + 0.5 * np.sin(2 * np.pi * 2 * y / ny)
                + 0.25 * np.cos(2 * np.pi * (x / nx + 4 * y / ny)))  # fmt: skip

    coarse = f(*np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij"))
    fine = bem.refine(coarse, 3)
    expected = f(*np.meshgrid(np.arange(3 * ny) / 3, np.arange(3 * nx) / 3, indexing="ij"))
    np.testing.assert_allclose(fine, expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("shape", [(16, 9), (9, 16), (2, 16), (16, 16386), (3, 5)])
def test_odd_or_out_of_range_sizes_are_refused_in_one_line(shape):
    with pytest.raises(SettingError) as err:
        bem.solve_contact(np.zeros(shape), 1.0, 1.0, 1.0)
    assert err.value.field == "z"
    text = str(err.value)
    assert str(shape) in text and "expected even ny and nx in [4, 16384]" in text and "\n" not in text


@st.composite
def problems(draw):
    ny = 2 * draw(st.integers(4, 20))
    nx = 2 * draw(st.integers(4, 20).filter(lambda k: 2 * k != ny))
    seed = draw(st.integers(0, 10_000))
    fraction = draw(st.floats(0.02, 0.9))
    hardness = draw(st.sampled_from([None, 5.0]))
    return ny, nx, seed, fraction, hardness


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(problems())
def test_random_rectangles_meet_the_contact_conditions(problem):
    ny, nx, seed, fraction, hardness = problem
    z = rough(ny, nx, seed, cut=2) / 1e-6  # rms 1 in units of the pixel: slopes of order 1
    p_full = bem.full_contact_pressure(z, 1.0, 1.0)
    p = fraction * p_full if hardness is None else min(fraction * p_full, 0.5 * hardness)
    res = bem.solve_contact(z, 1.0, 1.0, p, hardness=hardness, tol=1e-8)
    assert res.success and res.residual <= 1e-8 and res.shape == (ny, nx) and res.n == nx
    for field in (res.pressure, res.gap, res.displacement):
        assert field.shape == (ny, nx) and np.all(np.isfinite(field))
    assert np.all(res.pressure >= 0.0) and np.all(res.gap >= 0.0)
    if hardness is not None:
        assert np.all(res.pressure <= hardness)
    assert res.pressure.mean() == pytest.approx(p, rel=1e-10)
    assert res.displacement.mean() == pytest.approx(0.0, abs=1e-10 * np.abs(res.displacement).max())
    # the gap is zero where there is pressure, and the numbers add up: g = u − z + h₀ + mean z
    assert np.all(res.gap[res.pressure > 0] == 0.0)
    assert 0.0 < res.area_fraction <= 1.0 and res.nit >= 0


@pytest.mark.parametrize("hardness", [None, 3e6])
def test_the_gpu_code_path_on_a_rectangle_equals_the_cpu_solution(hardness):
    """The GPU's code (the generic array-namespace path, here over NumPy and over the CuPy stand-in of
    test_bem_sync.py) on a 48 × 96 cell: the same iterations and fields as the CPU path (scipy.fft, row blocks)."""
    from .test_bem_sync import fake

    z = rough(48, 96, seed=9)
    cpu = bem.solve_contact(z, PIX, E_W, 1e6, hardness=hardness, tol=1e-8, workers=2)
    for xp in (np, fake):
        gpu = bem.solve_contact(z, PIX, E_W, 1e6, hardness=hardness, tol=1e-8, xp=xp)
        assert gpu.device == ("cpu" if xp is np else "gpu") and gpu.success and cpu.success
        assert gpu.nit == cpu.nit and gpu.area_fraction == cpu.area_fraction and gpu.shape == (48, 96)
        assert float(np.abs(gpu.pressure - cpu.pressure).max()) <= 1e-10 * float(cpu.pressure.max())


def test_the_gpu_memory_estimate_counts_ny_times_nx():
    from contactrig.core.budget import BudgetError
    from sims.budget import bem_gpu, check_bem_gpu

    assert bem_gpu((1024, 4096)).peak_bytes == bem_gpu(2048).peak_bytes == 4 * bem_gpu((512, 2048)).peak_bytes
    assert "grid 968×1126" in bem_gpu((968, 1126)).keys
    assert bem_gpu(np.int64(2048)).peak_bytes == bem_gpu(2048).peak_bytes  # a NumPy integer is a side too
    fits = 1.5 * bem_gpu((1024, 1024)).peak_bytes
    assert check_bem_gpu((1024, 1024), free_bytes=fits).peak_bytes < fits
    with pytest.raises(BudgetError):
        check_bem_gpu((1024, 2048), free_bytes=fits)


def _measured_scene(tmp_path, ny: int, nx: int, edges: str) -> str:
    """A scene like contactrig/scenes/measured.toml on two X3P maps of ny × nx points at 8 µm written by
    tests/surface_maker.py (rough, flat: form = plane), edges ``edges``."""
    pytest.importorskip("SurfaceTopography", reason="SurfaceTopography (extra 'surfaces') writes and reads X3P")
    from importlib import resources

    from tests import surface_maker as mk

    for name, seed, sq in (("liner", 1, 0.4e-6), ("piston", 2, 0.3e-6)):
        mk.write(tmp_path / f"{name}.x3p", rough(ny, nx, seed) / 1e-6 * sq, 8e-6, "m")
    text = resources.files("contactrig").joinpath("scenes/measured.toml").read_text(encoding="utf-8")
    for name in ("liner", "piston"):
        text = text.replace(f'"measured/{name}.x3p"', f'"{(tmp_path / f"{name}.x3p").as_posix()}"')
    text = text.replace('form = "cylinder"', 'form = "plane"').replace('edges = "mirror"', f'edges = "{edges}"')
    scene = tmp_path / "rect.toml"
    scene.write_text(text, encoding="utf-8")
    return str(scene)


def test_compare_models_runs_on_a_non_square_measured_map(tmp_path, capsys):
    import json

    from contactrig.cli.main import main

    scene = _measured_scene(tmp_path, 96, 160, "mirror")  # mirrored: a 192 × 320 periodic cell
    code = main(["compare-models", scene, "--models", "greenwood_tripp", "--pressures", "1e6,1e7",
                 "--jobs", "1", "--json", "--quiet"])  # fmt: skip
    captured = capsys.readouterr()
    assert code == 0, captured.err
    ref = json.loads(captured.out)["reference"]
    assert len(ref["area_fraction"]) == 2 and all(0.0 < a < 1.0 for a in ref["area_fraction"])
    assert ref["area_fraction"][0] < ref["area_fraction"][1]
    assert all(math.isfinite(v) and v > 0.0 for v in ref["mean_gap_m"] + ref["stiffness_pa_per_m"])


def test_an_odd_windowed_map_is_refused_naming_edges(tmp_path, capsys):
    from contactrig.cli.main import main

    scene = _measured_scene(tmp_path, 96, 161, "window")  # windowed: the map's own 96 × 161 points
    code = main(["compare-models", scene, "--models", "greenwood_tripp", "--pressures", "1e6", "--jobs", "1"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "Traceback" not in err
    assert "[surfaces.liner] edges = 'window'" in err and "96 × 161" in err and "mirror" in err


def test_rectangular_fields_do_not_depend_on_the_thread_count():
    """Row blocks sized by the row width nx (64 × 1024: 31 rows a block, three blocks): 1 and 3 threads agree."""
    from sims import bem_backend

    seen = bem_backend.get_backend("cpu", 3).rows(lambda r: (r.start, r.stop), 64, 1024)
    assert seen == [(0, 31), (31, 62), (62, 64)]
    z = rough(64, 1024, seed=6)
    one = bem.solve_contact(z, PIX, E_W, 1e6, tol=1e-8, workers=1)
    three = bem.solve_contact(z, PIX, E_W, 1e6, tol=1e-8, workers=3)
    assert one.success and one.nit == three.nit
    assert np.array_equal(one.pressure, three.pressure) and np.array_equal(one.gap, three.gap)


def test_the_bem_database_curve_of_a_rectangle_records_its_cell():
    from sims.bem_database import BemCurveSettings, bem_curve

    z = rough(32, 64, seed=8)
    curve = bem_curve(z, PIX, E_W, settings=BemCurveSettings(n_points=4, workers=1))
    params = curve.parameters
    assert params["all_converged"] and params["shape"] == [32, 64] and params["n"] == 64
    assert params["area_m2"] == pytest.approx(32 * PIX * 64 * PIX, rel=1e-15)  # the cell, ny·Δ × nx·Δ
    assert np.all(np.diff(curve.pressure_pa) < 0.0) and np.all(np.isfinite(curve.area_fraction))
