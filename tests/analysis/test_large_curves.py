"""A curve of many weights (an imported table of 10 000 rows) is simulated on a grid and its contact areas
interpolated: the areas agree with a direct simulation at every weight to far below any measurement's scatter."""

from __future__ import annotations

import numpy as np


def test_grid_simulation_matches_the_direct_one():
    from analysis import pipeline
    from analysis.fit import area_at_weights
    from contactrig.core.scene import load_scene

    scene = load_scene(None)
    w = np.linspace(5.44, 25.966, 300)
    grid = pipeline._simulated_weights(w)
    assert grid.size == pipeline.SIM_WEIGHTS_MAX < w.size and grid[0] == w[0] and grid[-1] == w[-1]
    direct, _ = pipeline.simulate(scene, w)
    coarse, _ = pipeline.simulate(scene, grid)
    for name, m in direct.models.items():
        g = coarse.models[name]
        a = area_at_weights(np.asarray(g.weight_kg), np.asarray(g.contact_area_m2), np.asarray(m.weight_kg))
        np.testing.assert_allclose(a, np.asarray(m.contact_area_m2), rtol=1e-5, err_msg=name)
