"""Rough surfaces: generators, height maps, summits, curvature (eq. 8) and McCool against summit statistics."""

from __future__ import annotations

import math

import numpy as np
import pytest

from contactrig.core.validation import SettingError
from sims import surface as s

PX = 1e-6


def test_gaussian_exact_sq_zero_mean_deterministic() -> None:
    z = s.gaussian(128, pixel_m=PX, sq_m=0.5e-6, correlation_m=8e-6, seed=4)
    assert z.shape == (128, 128)
    assert s.rms_roughness(z) == pytest.approx(0.5e-6, rel=1e-12)
    assert abs(z.mean()) < 1e-20
    np.testing.assert_array_equal(z, s.gaussian(128, pixel_m=PX, sq_m=0.5e-6, correlation_m=8e-6, seed=4))
    assert not np.array_equal(z, s.gaussian(128, pixel_m=PX, sq_m=0.5e-6, correlation_m=8e-6, seed=5))
    with pytest.raises(SettingError, match="n"):
        s.gaussian(127, pixel_m=PX, sq_m=1e-6, correlation_m=8e-6)


def test_gaussian_moments_match_the_autocorrelation_closed_form() -> None:
    # ACF σ² exp(−r²/λ²): m2 = 2σ²/λ², m4 = 12σ²/λ⁴, α = 3
    sig, lam = 0.5e-6, 10e-6
    z = s.gaussian(256, pixel_m=PX, sq_m=sig, correlation_m=lam, seed=1)
    m = s.spectral_moments(z, PX)
    assert m.m0 == pytest.approx(sig**2, rel=1e-9)
    assert m.m2 == pytest.approx(2 * sig**2 / lam**2, rel=0.05)
    assert m.m4 == pytest.approx(12 * sig**2 / lam**4, rel=0.05)
    spec = s.SurfaceSpec.from_table(
        "surfaces.x", {"kind": "gaussian", "n": 256, "pixel_m": PX, "sq_m": sig, "correlation_m": lam}
    )
    e = spec.moments()
    # deterministic amplitudes: the realisation has exactly the prescribed spectrum
    assert e.m2 == pytest.approx(m.m2, rel=1e-9) and e.m4 == pytest.approx(m.m4, rel=1e-9)


def test_summit_statistics_agree_with_mccool_on_a_resolved_gaussian_surface() -> None:
    z = s.gaussian(512, pixel_m=PX, sq_m=0.5e-6, correlation_m=8e-6, seed=3)
    direct = s.summit_statistics(z, PX)
    mc = s.mccool(s.spectral_moments(z, PX))
    assert direct.n_summits > 500
    assert direct.eta == pytest.approx(mc.eta, rel=0.03)
    assert direct.beta == pytest.approx(mc.beta, rel=0.03)
    assert direct.sigma_s == pytest.approx(mc.sigma_s, rel=0.05)
    # summits sit well above the mean plane of the heights (what GT's F_n(h/σ) assumes to be 0)
    assert direct.mean_height == pytest.approx(mc.mean_height, rel=0.03)
    assert direct.mean_height > 1.2 * 0.5e-6


def test_mccool_of_a_gaussian_autocorrelation_matches_the_closed_forms() -> None:
    # ACF Sq² exp(−r²/λ²): α = 3, η = 1/(π√3 λ²), β = 0.375 λ² √(π/12)/Sq, σ_s = √(1 − 0.8968/3) Sq and mean summit
    # height 4 Sq/√(3π). Moments of the prescribed spectrum on a 64 λ box at 8 px/λ (no surface generated).
    sq, lam = 0.5e-6, 8e-6
    spec = s.SurfaceSpec.from_table(
        "surfaces.x", {"kind": "gaussian", "n": 512, "pixel_m": lam / 8, "sq_m": sq, "correlation_m": lam}
    )
    st = s.mccool(spec.moments())
    assert st.alpha == pytest.approx(3.0, rel=3e-3)
    assert st.eta == pytest.approx(1 / (math.pi * math.sqrt(3) * lam**2), rel=3e-3)
    assert st.beta == pytest.approx(0.375 * lam**2 * math.sqrt(math.pi / 12) / sq, rel=3e-3)
    assert st.sigma_s == pytest.approx(math.sqrt(1 - 0.8968 / 3) * sq, rel=3e-3)
    assert st.mean_height == pytest.approx(4 * sq / math.sqrt(3 * math.pi), rel=3e-3)


def test_summits_eight_neighbour_periodic_and_border() -> None:
    z = np.zeros((6, 6))
    z[2, 3] = 1.0  # a summit
    z[0, 0] = 2.0  # on the border: a summit only if periodic
    z[4, 1] = 0.5
    z[4, 2] = 0.5  # a plateau of two equal points is no summit
    m = s.summits(z)
    assert {tuple(p) for p in np.argwhere(m)} == {(2, 3), (0, 0)}
    assert {tuple(p) for p in np.argwhere(s.summits(z, periodic=False))} == {(2, 3)}


def test_radius_of_curvature_eq8_on_a_circle_negative_at_peaks() -> None:
    radius = 1e-3
    x = (np.arange(-50, 51) * 1e-6)[:, None]
    z = np.sqrt(radius**2 - x**2) * np.ones((1, 5))
    rx, _ = s.radius_of_curvature(z, 1e-6)
    inner = rx[5:-5, 2]
    np.testing.assert_allclose(inner, -radius, rtol=1e-6)  # exact circle: |R| = radius everywhere, negative


def test_summit_radius_of_a_paraboloid() -> None:
    radius = 5e-4
    yy, xx = np.mgrid[-20:21, -20:21] * 1e-6
    z = -(xx**2 + yy**2) / (2 * radius)
    d = s.summit_data(z, 1e-6, periodic=False)
    assert d.height_m.size == 1
    assert float(d.radius_m[0]) == pytest.approx(radius, rel=1e-6)


def test_combined_sigma_eq3() -> None:
    assert s.combined_sigma(0.3e-6, 0.4e-6) == pytest.approx(0.5e-6)


def test_self_affine_exact_sq_and_spectral_slope() -> None:
    hurst = 0.8
    z = s.self_affine(256, pixel_m=PX, sq_m=1e-6, hurst=hurst, rolloff_m=64e-6, cutoff_m=4e-6, seed=2)
    assert s.rms_roughness(z) == pytest.approx(1e-6, rel=1e-12)
    power = np.abs(np.fft.fft2(z)) ** 2
    q = 2 * np.pi * np.hypot(*np.meshgrid(np.fft.fftfreq(256, PX), np.fft.fftfreq(256, PX), indexing="ij"))
    band = (q > 2 * np.pi / 40e-6) & (q < 2 * np.pi / 6e-6)
    slope = np.polyfit(np.log(q[band]), np.log(power[band]), 1)[0]
    assert slope == pytest.approx(-2 * (1 + hurst), abs=0.05)
    assert power[q > 2 * np.pi / 4e-6 * 1.001].max() < 1e-20 * power.max()


def test_level_height_map_removes_the_plane() -> None:
    rng = np.random.default_rng(0)
    rough = rng.normal(size=(12, 10))
    rough -= rough.mean()
    yy, xx = np.mgrid[0:12, 0:10]
    data = rough + 0.3 * xx - 0.2 * yy + 5.0
    z = s.level_height_map(data, pixel_m=2e-6, height_unit_m=1e-6)
    a = np.column_stack([np.ones(rough.size), xx.ravel(), yy.ravel()])
    coef, *_ = np.linalg.lstsq(a, rough.ravel(), rcond=None)
    np.testing.assert_allclose(z, (rough - (a @ coef).reshape(rough.shape)) * 1e-6, atol=1e-15)
    with pytest.raises(SettingError, match="at least 8×8"):
        s.level_height_map(np.zeros((4, 9)), pixel_m=1e-6)
    with pytest.raises(SettingError, match="non-finite"):
        s.level_height_map(np.full((8, 8), np.nan), pixel_m=1e-6)
    with pytest.raises(SettingError, match="2-D"):
        s.level_height_map(np.zeros(64), pixel_m=1e-6)


def test_measured_surface_from_an_array_without_any_file() -> None:
    z_um = s.gaussian(32, pixel_m=1e-6, sq_m=0.5e-6, correlation_m=4e-6, seed=3) * 1e6  # numbers in µm
    spec = s.SurfaceSpec.from_heights(z_um, pixel_m=1e-6, height_unit_m=1e-6, section="surfaces.liner")
    assert spec.kind == "file" and not spec.periodic and spec.path is None
    np.testing.assert_allclose(s.rms_roughness(spec.heights()), 0.5e-6, rtol=0.05)
    assert "measured" not in spec.as_dict()
    assert spec.heights() is not spec.heights()  # fresh arrays: the spec's own stays untouched
    assert spec.measured is not None and not spec.measured.flags.writeable
    via_table = s.SurfaceSpec.from_table(
        "surfaces.liner", {"kind": "file", "path": "liner.csv", "pixel_m": 1e-6, "height_unit_m": 1e-6}, z_um
    )
    assert via_table.path == "liner.csv" and via_table == s.SurfaceSpec.from_table(
        "surfaces.liner",
        {"kind": "file", "path": "elsewhere.csv", "pixel_m": 1e-6, "height_unit_m": 1e-6},
        z_um,
        path="liner.csv",
    )
    np.testing.assert_array_equal(via_table.heights(), spec.heights())
    assert via_table.moments().m0 == pytest.approx(float(np.mean(spec.heights() ** 2)), rel=1e-9)


def test_measured_surface_errors_name_the_scene_key_and_the_file() -> None:
    table = {"kind": "file", "path": "maps/liner.csv", "pixel_m": 1e-6, "height_unit_m": 1e-6}
    # a table whose file was never read (a scene parsed from text): the key and the file are named
    with pytest.raises(SettingError, match=r"\[surfaces\.liner\] path = 'maps/liner\.csv'.*not read"):
        s.SurfaceSpec.from_table("surfaces.liner", table)
    with pytest.raises(SettingError, match=r"\[surfaces\.liner\] kind = 'gaussian'.*heights were given"):
        s.SurfaceSpec.from_table(
            "surfaces.liner",
            {"kind": "gaussian", "n": 64, "pixel_m": 1e-6, "sq_m": 1e-7, "correlation_m": 8e-6},
            np.zeros((8, 8)),
        )
    with pytest.raises(SettingError, match=r"\[surfaces\.liner\] path = None.*missing"):
        s.SurfaceSpec.from_table("surfaces.liner", {"kind": "file", "pixel_m": 1e-6})
    with pytest.raises(SettingError, match=r"\[surfaces\.liner\] path = '/data/liner\.csv'.*8×8"):
        s.SurfaceSpec.from_table("surfaces.liner", table, np.zeros((4, 4)), path="/data/liner.csv")
    # numbers in µm read as metres: the unit is blamed, with the file, not something downstream
    z_um = s.gaussian(32, pixel_m=1e-6, sq_m=0.5e-6, correlation_m=4e-6, seed=3) * 1e6
    with pytest.raises(SettingError, match=r"\[surfaces\.liner\] height_unit_m = 1\.0 .*/data/liner\.csv.*slope"):
        s.SurfaceSpec.from_table("surfaces.liner", {**table, "height_unit_m": 1.0}, z_um, path="/data/liner.csv")


def test_roughness_in_the_wrong_unit_names_sq_m() -> None:
    good = {"kind": "gaussian", "n": 512, "pixel_m": 10e-6, "sq_m": 0.4e-6, "correlation_m": 80e-6}
    s.SurfaceSpec.from_table("surfaces.liner", good)
    with pytest.raises(SettingError, match=r"\[surfaces\.liner\] sq_m = 0\.0004 .*RMS slope of 10"):
        s.SurfaceSpec.from_table("surfaces.liner", {**good, "sq_m": 0.4e-3})  # 0.4 µm typed in mm
    affine = {"kind": "self_affine", "n": 128, "pixel_m": 10e-6, "sq_m": 0.4e-6, "hurst": 0.8, "cutoff_m": 40e-6}
    s.SurfaceSpec.from_table("surfaces.piston", affine)
    with pytest.raises(SettingError, match=r"\[surfaces\.piston\] sq_m .*RMS slope"):
        s.SurfaceSpec.from_table("surfaces.piston", {**affine, "sq_m": 0.4e-3})


def test_rms_slope_of_a_gaussian_surface() -> None:
    z = s.gaussian(256, pixel_m=PX, sq_m=0.1e-6, correlation_m=16e-6, seed=2)
    assert s.rms_slope(z, PX) == pytest.approx(2 * 0.1e-6 / 16e-6, rel=0.02)  # 2 Sq/λ
    assert s.rms_slope(z, PX, periodic=False) == pytest.approx(s.rms_slope(z, PX), rel=0.05)


def test_surface_spec_validation_names_the_key() -> None:
    good = {"kind": "gaussian", "n": 64, "pixel_m": 1e-6, "sq_m": 1e-6, "correlation_m": 8e-6}
    assert s.SurfaceSpec.from_table("surfaces.liner", good).n == 64
    with pytest.raises(SettingError, match=r"\[surfaces\.liner\] hurst"):
        s.SurfaceSpec.from_table("surfaces.liner", {**good, "hurst": 0.5})
    with pytest.raises(SettingError, match=r"\[surfaces\.liner\] sq_m"):
        s.SurfaceSpec.from_table("surfaces.liner", {**good, "sq_m": -1.0})
    with pytest.raises(SettingError, match=r"\[surfaces\.liner\] kind"):
        s.SurfaceSpec.from_table("surfaces.liner", {**good, "kind": "fractal"})
    with pytest.raises(SettingError, match=r"\[surfaces\.liner\] correlation_m"):
        s.SurfaceSpec.from_table("surfaces.liner", {k: v for k, v in good.items() if k != "correlation_m"})


def test_a_scene_with_a_measured_height_map(tmp_path) -> None:
    from contactrig.core.scene import load_scene, parse_scene

    z_um = s.gaussian(32, pixel_m=1e-6, sq_m=0.5e-6, correlation_m=4e-6, seed=3) * 1e6
    (tmp_path / "liner.csv").write_text("\n".join(",".join(f"{v:.12g}" for v in row) for row in z_um))
    text = (
        '[surfaces.liner]\nkind = "file"\npath = "liner.csv"\npixel_m = 1e-6\nheight_unit_m = 1e-6\n'
        '[surfaces.piston]\nkind = "gaussian"\nn = 32\npixel_m = 1e-6\nsq_m = 0.3e-6\ncorrelation_m = 4e-6\n'
    )
    (tmp_path / "scene.toml").write_text(text)
    liner, piston = s.surfaces_from_scene(load_scene(tmp_path / "scene.toml"))
    assert liner.path == str(tmp_path.resolve() / "liner.csv") and liner.as_dict()["path"] == liner.path
    np.testing.assert_allclose(liner.measured, s.level_height_map(z_um, pixel_m=1e-6, height_unit_m=1e-6), atol=1e-18)
    np.testing.assert_array_equal(liner.heights()[:32, :32], liner.measured)  # edges = "mirror" (default): 64×64
    assert liner.heights().shape == (64, 64)
    assert piston.kind == "gaussian" and piston.measured is None
    with pytest.raises(SettingError, match=r"\[surfaces\.liner\] path = 'liner\.csv'.*not read"):
        s.surfaces_from_scene(parse_scene(text))  # parsed from text: no file was read


def test_the_surface_module_reads_no_file() -> None:
    """Physics does no I/O: height-map files are read by contactrig.core.scene."""
    import ast
    import inspect

    tree = ast.parse(inspect.getsource(s))
    imported = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    imported |= {n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert not imported & {"pathlib", "os", "io", "csv"}, imported
    called = {
        n.func.attr if isinstance(n.func, ast.Attribute) else getattr(n.func, "id", "")
        for n in ast.walk(tree)
        if isinstance(n, ast.Call)
    }
    assert not called & {"open", "read_text", "read_bytes", "loadtxt", "genfromtxt", "read_text_file"}, called
