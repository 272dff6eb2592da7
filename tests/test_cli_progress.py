"""Issue 20 item 3: one progress mechanism — library functions call ``progress(done, total)``, the command draws a
tqdm bar on stderr only on a terminal and without ``--quiet`` (contactrig.cli.progress)."""

from __future__ import annotations

import io
from importlib import resources

from contactrig.cli.progress import progress_bar, shows_progress


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_bar_only_on_a_terminal_and_not_quiet():
    for stream, quiet, drawn in ((io.StringIO(), False, False), (_Terminal(), True, False), (_Terminal(), False, True)):
        assert shows_progress(quiet, stream) is drawn
        with progress_bar("work", quiet=quiet, stream=stream) as progress:
            for k in range(1, 4):
                progress(k, 3)
        text = stream.getvalue()
        assert ("work" in text and "3/3" in text) if drawn else text == ""


def _small_scene(tmp_path):
    text = resources.files("contactrig").joinpath("scenes/default.toml").read_text(encoding="utf-8")
    scene = tmp_path / "small.toml"
    scene.write_text(text.replace("n = 512", "n = 64"), encoding="utf-8")
    return scene


def test_compare_models_and_database_report_each_step(tmp_path):
    from analysis.compare_models import compare_models
    from contactrig.core.scene import load_scene
    from sims.config import SimConfig
    from sims.database import build_database

    calls: list[tuple[int, int]] = []
    cmp = compare_models(_small_scene(tmp_path), ["hertz", "greenwood_tripp"], pressures_pa=(1e6, 3e6), jobs=1,
                         progress=lambda done, total: calls.append((done, total)))  # fmt: skip
    n = cmp.provenance["tasks"]
    assert calls == [(k, n) for k in range(1, n + 1)] and n >= 3  # at least BEM, Hertz, GT: one call per task
    calls.clear()
    build_database(SimConfig.from_scene(load_scene(None)), ["hertz", "greenwood_tripp"],
                   progress=lambda done, total: calls.append((done, total)))  # fmt: skip
    assert calls == [(1, 2), (2, 2)]


def test_design_reports_each_plan():
    import numpy as np

    from analysis.design import ModelCurves, Plan, design

    w = np.geomspace(2.0, 26.0, 10)
    curves = ModelCurves(w, {"a": 1e-6 * w, "b": 1e-6 * w**0.5}, {"a": 0 * w + 1e-6, "b": 0 * w + 1e-6}, "rig")
    plans = [Plan((2.0, 26.0), 2, 100.0), Plan((2.0, 6.0, 26.0), 3, 200.0)]
    calls: list[tuple[int, int]] = []
    design(curves, plans, n_sessions=20, progress=lambda done, total: calls.append((done, total)))
    assert calls == [(1, 2), (2, 2)]


def test_commands_with_long_work_have_quiet():
    from contactrig.cli.main import build_parser

    parser = build_parser()
    for argv in (["compare-models"], ["design"], ["database", "-o", "x.h5"], ["report", "tab1", "-o", "r"],
                 ["demo"]):  # fmt: skip
        assert parser.parse_args([*argv, "--quiet"]).quiet is True
