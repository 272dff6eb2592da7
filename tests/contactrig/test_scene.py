"""Scene loading: default scene parses; unknown tables and malformed TOML are named errors."""

import pytest

from contactrig.core.scene import KNOWN_TABLES, load_scene, parse_scene
from contactrig.core.validation import SettingError


def test_default_scene_loads_and_has_only_known_tables():
    scene = load_scene()
    assert scene.name
    assert set(scene.data) <= set(KNOWN_TABLES)
    assert scene.text.startswith("#")


def test_unknown_table_is_named():
    with pytest.raises(SettingError, match="weather"):
        parse_scene("[weather]\nsunny = true\n")


def test_malformed_toml_is_an_error():
    with pytest.raises(SettingError, match="malformed TOML"):
        parse_scene("[scene\nname = 1")


def test_missing_file(tmp_path):
    with pytest.raises(SettingError, match="file not found"):
        load_scene(tmp_path / "nope.toml")


# ---------------------------------------------------------------------------------------------------------------
# Measured height maps: read here, at the edge, when the scene is loaded.

_FILE_SCENE = """
[surfaces.liner]
kind = "file"
path = "maps/liner.csv"
pixel_m = 1e-6
height_unit_m = 1e-6

[surfaces.piston]
kind = "gaussian"
n = 64
pixel_m = 1e-6
sq_m = 0.3e-6
correlation_m = 8e-6
"""


def _write_scene(tmp_path, grid_text):
    (tmp_path / "maps").mkdir()
    (tmp_path / "maps" / "liner.csv").write_text(grid_text)
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(_FILE_SCENE)
    return scene_file


def test_height_maps_are_read_relative_to_the_scene_file(tmp_path, monkeypatch):
    import numpy as np

    scene_file = _write_scene(tmp_path, "# heights in µm\n1, 2; 3\n\n4 5 6  # row two\n")
    monkeypatch.chdir(tmp_path / "maps")  # the working folder does not matter
    scene = load_scene(scene_file)
    assert list(scene.height_maps) == ["surfaces.liner"]  # generated surfaces have no file
    hm = scene.height_maps["surfaces.liner"]
    assert hm.path == str(tmp_path.resolve() / "maps" / "liner.csv")
    np.testing.assert_array_equal(hm.heights, [[1, 2, 3], [4, 5, 6]])  # as written: no unit, no levelling
    assert not hm.heights.flags.writeable
    with pytest.raises(TypeError):
        scene.height_maps["surfaces.piston"] = hm  # frozen
    assert not load_scene().height_maps  # the default scene references no file


def test_parse_scene_reads_height_maps_only_with_a_base_dir(tmp_path):
    _write_scene(tmp_path, "1 2\n3 4\n")
    assert not parse_scene(_FILE_SCENE).height_maps  # e.g. a scene recorded in a data file
    scene = parse_scene(_FILE_SCENE, "<notebook>", base_dir=tmp_path)
    assert scene.height_maps["surfaces.liner"].heights.shape == (2, 2)


@pytest.mark.parametrize(
    ("grid", "match"),
    [
        (None, r"\[surfaces\.liner\] path = '.*liner\.csv' is not allowed: file not found"),
        ("1 2 3\n4 x 6\n", r"\[surfaces\.liner\] path = '.*liner\.csv:2' is not allowed: expected numbers only"),
        ("1 2 3\n4 5\n", r"\[surfaces\.liner\] path = '.*liner\.csv' is not allowed: expected a rectangular grid"),
        ("# nothing\n", r"\[surfaces\.liner\] path = '.*liner\.csv' is not allowed: expected a rectangular grid"),
    ],
)
def test_height_map_errors_name_the_scene_key_and_the_file(tmp_path, grid, match):
    scene_file = _write_scene(tmp_path, grid or "")
    if grid is None:
        (tmp_path / "maps" / "liner.csv").unlink()
    with pytest.raises(SettingError, match=match):
        load_scene(scene_file)


def test_read_height_map_as_a_function(tmp_path):
    from contactrig.core.scene import read_height_map

    f = tmp_path / "z.txt"
    f.write_text("0.5 1.5\n2.5 3.5\n")
    assert read_height_map(f).tolist() == [[0.5, 1.5], [2.5, 3.5]]
    with pytest.raises(SettingError, match=r"^heights = "):
        read_height_map(tmp_path / "none.txt", key="heights")
