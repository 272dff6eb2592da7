"""Profilometer files in: SurfaceTopography's formats through the bounded reader, units and pixel size from the file.

Files are written by the library's own writers (X3P, GWY, NetCDF) and NumPy (NPY: no metadata) from known surfaces
(tests/surface_maker.py); nothing is copied from elsewhere.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from contactrig.core import topography_file as tf
from contactrig.core.scene import load_scene, read_measured_map
from contactrig.core.validation import SettingError
from sims.config import SimConfig
from sims.database import build_database
from sims.surface import surfaces_from_scene
from tests import surface_maker as mk

pytest.importorskip("SurfaceTopography", reason="SurfaceTopography (extra 'surfaces') reads the profilometer formats")

PIXEL = 0.5e-6


@pytest.mark.parametrize(("suffix", "rel"), [(".x3p", 1e-12), (".gwy", 1e-12), (".nc", 1e-7)])
@pytest.mark.parametrize("unit", ["um", "mm", "nm"])
def test_units_and_pixel_size_come_from_the_file(tmp_path, suffix, rel, unit):
    """A tilted plane on a non-square grid (24 rows × 40 columns): heights in m, pixel, orientation.

    NetCDF stores the physical sizes as float32 (the library's writer): exact to 1e-7 there, to rounding elsewhere.
    """
    z = mk.tilted_plane(24, 40, PIXEL)
    m = read_measured_map(mk.write(tmp_path / f"plane{suffix}", z, PIXEL, unit), key="surfaces.liner.path")
    assert m.heights.shape == (24, 40)
    assert m.pixel_m == pytest.approx(PIXEL, rel=rel)
    assert m.heights * m.height_unit_m == pytest.approx(z, rel=1e-6, abs=1e-15)
    assert m.file_format != "plain text"


def test_a_file_without_pixel_size_or_unit_is_refused_naming_the_quantity(tmp_path):
    np.save(tmp_path / "liner.npy", mk.sinusoid(32, 32, 1.0, 8.0, 1.0))
    scene = tmp_path / "scene.toml"
    base = '[surfaces.liner]\nkind = "file"\npath = "liner.npy"\n{}\n'
    base += '[surfaces.piston]\nkind = "file"\npath = "liner.npy"\n'
    scene.write_text(base.format(""))
    with pytest.raises(SettingError, match=r"\[surfaces\.liner\] pixel_m.*pixel size is missing.*liner\.npy"):
        surfaces_from_scene(load_scene(scene))
    scene.write_text(base.format("pixel_m = 1e-6"))
    with pytest.raises(SettingError, match=r"\[surfaces\.liner\] height_unit_m.*height unit is missing"):
        surfaces_from_scene(load_scene(scene))


def test_scene_keys_override_the_file(tmp_path):
    z = mk.sinusoid(32, 32, PIXEL, 8 * PIXEL, 0.1e-6)
    mk.write(tmp_path / "liner.x3p", z, PIXEL)
    scene = tmp_path / "scene.toml"
    scene.write_text(
        '[surfaces.liner]\nkind = "file"\npath = "liner.x3p"\npixel_m = 1e-6\n'
        '[surfaces.piston]\nkind = "file"\npath = "liner.x3p"\n'
    )
    liner, piston = surfaces_from_scene(load_scene(scene))
    assert liner.pixel_m == 1e-6 and liner.conditioning["pixel_m_from"] == "scene"
    assert piston.pixel_m == pytest.approx(PIXEL) and piston.conditioning["pixel_m_from"] == "file"
    assert np.std(piston.measured) == pytest.approx(0.1e-6 / np.sqrt(2), rel=0.03)  # X3P stores metres (not µm)


def test_without_the_library_the_message_names_the_pip_command(tmp_path, monkeypatch):
    p = mk.write(tmp_path / "a.x3p", mk.tilted_plane(16, 16, PIXEL), PIXEL)
    monkeypatch.setattr(tf, "surfaces_library_available", lambda: False)
    with pytest.raises(SettingError, match=r"pip install 'contactrig\[surfaces\]'"):
        read_measured_map(p, key="surfaces.liner.path")


def test_a_damaged_file_is_one_line(tmp_path):
    p = mk.write(tmp_path / "a.x3p", mk.tilted_plane(16, 16, PIXEL), PIXEL)
    raw = bytearray(p.read_bytes())
    raw[len(raw) // 3 : len(raw) // 3 + 200] = b"\0" * 200
    p.write_bytes(bytes(raw))
    with pytest.raises(SettingError, match=r"\[surfaces\.liner\] path = .* not a height map") as exc:
        read_measured_map(p, key="surfaces.liner.path")
    assert "\n" not in str(exc.value)
    (tmp_path / "b.bin").write_bytes(bytes(range(256)) * 11 + b"\1")  # 2048 bytes would pass as an SRTM tile
    with pytest.raises(SettingError, match="format not recognised"):
        read_measured_map(tmp_path / "b.bin", key="k")


def test_a_grid_declared_too_large_is_refused_before_decoding(tmp_path, monkeypatch):
    p = mk.write(tmp_path / "a.x3p", mk.tilted_plane(16, 40, PIXEL), PIXEL)
    monkeypatch.setattr(tf, "HEIGHT_MAP_MAX_SIDE", 32)
    with pytest.raises(SettingError, match=r"declares \(40, 16\) points; expected at most 32"):
        read_measured_map(p, key="k")


def _profile_scene(tmp_path, models):
    z = mk.sinusoid(1, 4096, PIXEL, 40 * PIXEL, 0.2e-6)[0] + 0.05e-6 * np.sin(np.arange(4096) * 0.9)
    mk.write(tmp_path / "trace.nc", z, PIXEL)
    from contactrig.core.scene import default_scene_text

    text = default_scene_text()
    start = text.index("[surfaces.liner]")
    end = text.index("[", start + 2)
    text = text[:start] + '[surfaces.liner]\nkind = "file"\npath = "trace.nc"\n' + text[end:]
    (tmp_path / "scene.toml").write_text(text)
    return SimConfig.from_scene(load_scene(tmp_path / "scene.toml")), models


def test_a_line_profile_serves_statistics_models_and_is_refused_by_summation_models(tmp_path):
    config, models = _profile_scene(tmp_path, ["greenwood_tripp"])
    assert config.liner.is_profile
    db = build_database(config, models)
    assert db.provenance["surfaces"]["liner"]["sq_m"] == pytest.approx(np.sqrt(0.2e-6**2 / 2 + 0.05e-6**2 / 2), 0.02)
    config, models = _profile_scene(tmp_path, ["greenwood_tripp", "hertz"])
    with pytest.raises(SettingError, match=r"\[surfaces\.liner\] path .*line profile.*need an areal height map"):
        build_database(config, models)


def test_the_packaged_example_is_the_generators_and_a_database_builds_on_it():
    """contactrig/scenes/measured/*.x3p hold exactly what tests/surface_maker.py makes (NaN dropouts at the same
    points), and the scene's database builds with the form removal and filters recorded in its provenance."""
    import contactrig

    folder = Path(contactrig.__file__).parent / "scenes"
    for name, make in mk.EXAMPLE.items():
        m = read_measured_map(folder / "measured" / name, key=name)
        expected = make()
        assert m.pixel_m == pytest.approx(mk.EXAMPLE_PIXEL_M, rel=1e-12)
        np.testing.assert_array_equal(np.isnan(m.heights), np.isnan(expected))
        np.testing.assert_allclose(m.heights * m.height_unit_m, expected, rtol=1e-12, atol=1e-18)
    config = SimConfig.from_scene(load_scene(folder / "measured.toml"))
    db = build_database(config, ["greenwood_tripp", "hertz"])
    rec = db.provenance["surfaces"]["liner"]["conditioning"]
    assert rec["form"] == "cylinder" and rec["lambda_c_m"] == 250e-6 and rec["missing_points"] > 0
    assert rec["cylinder_radius_m"] == pytest.approx(0.0425, rel=0.05)


def test_a_report_finds_the_recorded_scenes_height_maps_only_when_the_scene_file_is_unchanged(tmp_path):
    """analysis.pipeline: a session's recorded scene names maps relative to the scene it was started from; they are
    read from there when that file still holds the recorded text, and not at all otherwise."""
    from types import SimpleNamespace

    from analysis.pipeline import _scene_for

    mk.write(tmp_path / "liner.x3p", mk.liner(n=64), 8e-6)
    text = '[surfaces.liner]\nkind = "file"\npath = "liner.x3p"\n'
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(text)
    session = SimpleNamespace(scene_text=text, path=str(tmp_path / "s.h5"), start={"scene_source": str(scene_file)})
    assert list(_scene_for(session).height_maps) == ["surfaces.liner"]
    scene_file.write_text(text + "# edited\n")
    assert not _scene_for(session).height_maps
