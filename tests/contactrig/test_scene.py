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
