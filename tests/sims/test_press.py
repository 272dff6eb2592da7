"""The press geometry (sims.press): rough sphere on a flat with bulk elasticity, against Hertz (σ → 0)."""

from __future__ import annotations

import math

import pytest

from sims.press import PressSettings, press_equilibrium
from tests.sims.test_elastic import PowerLayer

# p = k (−h)^1.5: an asperity layer whose compliance → 0 (σ → 0); the one test law of tests/sims/test_elastic.py
_StiffLayer = PowerLayer


def test_press_smooth_limit_is_hertz() -> None:
    """Johnson's rough sphere with σ → 0: peak p0 = 3W/(2πa²) and contact radius a = (3WR/(4E*))^(1/3)."""
    settings = PressSettings(sphere_radius_m=0.05, weights_kg=(10.0,), n_rings=120)
    e_star, load = 49.1e9, 10.0 * 9.80665
    a = (3 * load * 0.05 / (4 * e_star)) ** (1 / 3)
    p0 = 3 * load / (2 * math.pi * a * a)
    law = _StiffLayer(p0 / (1e-3 * a * a / 0.05) ** 1.5)
    c = press_equilibrium(law, settings, 10.0, e_star)
    assert c.solution.success and c.solution.nit > 0
    assert c.peak_pressure_pa == pytest.approx(p0, rel=0.01)
    assert c.nominal_radius_m == pytest.approx(a, rel=0.04)
    assert c.solution.load_n == pytest.approx(load, rel=1e-9)


def test_press_settings_are_validated() -> None:
    from contactrig.core.validation import SettingError

    with pytest.raises(SettingError, match="sphere_radius_m"):
        PressSettings(sphere_radius_m=-1.0)
    with pytest.raises(SettingError, match="press"):
        PressSettings.from_table({"radius": 1.0})


def test_press_scenes_that_differ_in_the_sphere_have_different_fingerprints():
    """A sweep of one press cannot be fitted to a session of another without a word (issue #11 fingerprints)."""
    from dataclasses import replace
    from pathlib import Path

    import contactrig
    from contactrig.core.fingerprint import differences
    from contactrig.core.scene import load_scene
    from daq.sweep_file import config_fingerprint
    from sims.config import SimConfig

    press = SimConfig.from_scene(load_scene(Path(contactrig.__file__).parent / "scenes" / "press.toml"))
    other = press.with_changes(press=replace(press.press, sphere_radius_m=0.02))
    more_loads = press.with_changes(press=replace(press.press, weights_kg=(1.0, 3.0)))
    a, b, c = (config_fingerprint(x) for x in (press, other, more_loads))
    assert a["tables"]["press"] != b["tables"]["press"]
    assert any("sphere_radius_m" in line for line in differences(a, b))
    assert a["tables"]["press"] == c["tables"]["press"]  # the load sweep is not what the curve is computed from
    rig = SimConfig.from_scene(load_scene())
    assert "press" not in config_fingerprint(rig)["tables"]
