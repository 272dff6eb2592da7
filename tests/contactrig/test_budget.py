"""The work a scene asks for is estimated before it starts and refused in one line when it cannot fit (issue 19,
item 3); the estimates are checked against the peak memory measured in a child process."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from contactrig.cli.main import main
from contactrig.core import budget
from contactrig.core.budget import BudgetError, Estimate, Stage, available_memory_bytes, memory_limit, parse_size
from contactrig.core.scene import default_scene_text, load_scene

CHILD = Path(__file__).with_name("budget_child.py")


def _scene(tmp_path: Path, *changes: tuple[str, str], name: str = "s.toml") -> Path:
    text = default_scene_text()
    for old, new in changes:
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


HUGE_MESH = (('mesh = "variable"', 'mesh = "uniform"'), ("n_theta = 16 ", "n_theta = 1000000 "),
             ("n_axial = 8 ", "n_axial = 100000 "))  # fmt: skip
BIG_SURFACES = (("n = 512", "n = 8192"),)


# ---------------------------------------------------------------------------------------------------------------
# The estimates against measured peaks.


@pytest.mark.parametrize(
    ("stage", "size"),
    [("database_hertz", 1024), ("database_gt", 2048), ("surfaces", 2048), ("rig", 2000), ("press", 1000),
     ("bem", 256)],
)  # fmt: skip
def test_estimate_is_within_a_factor_of_2_of_the_measured_peak(stage, size):
    r = subprocess.run([sys.executable, str(CHILD), stage, str(size)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    got = json.loads(r.stdout.strip().splitlines()[-1])
    measured, estimate = got["measured"], got["estimate"]
    assert measured > 20e6, f"{stage} at {size}: too small to measure ({measured} bytes)"
    assert 0.5 <= estimate / measured <= 2.0, f"{stage} at {size}: estimate {estimate:.3g} B, measured {measured:.3g} B"


# ---------------------------------------------------------------------------------------------------------------
# The mechanism.


def test_parse_size():
    assert parse_size("2G") == 2 << 30
    assert parse_size("512M") == 512 << 20
    assert parse_size("1.5GiB") == 3 << 29
    assert parse_size("4096") == 4096
    assert parse_size(" 10 kb ") == 10 << 10
    for bad in ("", "G", "-1G", "0", "2X", "1e9", "nan", "inf"):
        with pytest.raises(ValueError, match="--max-memory"):
            parse_size(bad)


@settings(max_examples=50)
@given(st.text(max_size=20))
def test_parse_size_of_anything_is_a_size_or_one_value_error(text):
    try:
        n = parse_size(text)
    except ValueError as exc:
        assert "\n" not in str(exc)
    else:
        assert isinstance(n, int) and n >= 1


def test_available_memory_reads_memavailable(tmp_path):
    f = tmp_path / "meminfo"
    f.write_text("MemTotal:       32000000 kB\nMemFree:  1 kB\nMemAvailable:   24000000 kB\n", encoding="ascii")
    assert available_memory_bytes(f) == 24000000 * 1024
    f.write_text("MemTotal: 1 kB\n", encoding="ascii")
    assert available_memory_bytes(f) is None
    assert available_memory_bytes(tmp_path / "none") is None


def test_check_refuses_the_largest_stage_over_the_bound_naming_its_keys():
    small = Estimate("a", "[rig] n_theta = 16", 1e6)
    large = Estimate("rig mesh", "[rig] n_theta = 1000000", 5e9, 60.0)
    with memory_limit(2 << 30):
        assert budget.check([small]) is small
        with pytest.raises(BudgetError) as info:
            budget.check([small, large])
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith("[rig] n_theta = 1000000: the rig mesh needs about 4.66 GiB")
    assert "~60 s" in msg and "2 GiB allowed by --max-memory" in msg
    with memory_limit(10 << 30):
        assert budget.check([small, large]) is large


def test_a_registered_stage_is_estimated_through_the_registry():
    import sims.budget  # noqa: F401  (registers the built-in stages)

    @dataclass(frozen=True)
    class Work:
        cells: int

    toy = Stage("toy", lambda w: Estimate("toy stage", f"[toy] cells = {w.cells}", 8.0 * w.cells), "a test stage")
    budget.STAGES.register(toy)
    try:
        assert "toy" in budget.STAGES.names() and "rig" in budget.STAGES.names()
        with memory_limit(1000), pytest.raises(BudgetError, match=r"^\[toy\] cells = 1000: the toy stage"):
            budget.check([budget.estimate("toy", Work(1000))])
    finally:
        budget.STAGES.unregister("toy")


# ---------------------------------------------------------------------------------------------------------------
# Every command that simulates refuses before starting, in one line, exit 2.


def _one_line(capsys) -> str:
    _, err = capsys.readouterr()
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


def test_the_issue_s_huge_uniform_mesh_is_refused_by_every_command(tmp_path, capsys):
    scene = _scene(tmp_path, *HUGE_MESH)
    for argv in (["simulate", str(scene)], ["design", str(scene), "-o", str(tmp_path / "d")]):
        assert main(argv) == 2
        err = _one_line(capsys)
        assert "[rig] mesh = 'uniform', n_theta = 1000000, n_axial = 100000" in err and "TiB of memory" in err
    assert not (tmp_path / "d" / "plan.toml").exists()


def test_big_surfaces_under_max_memory_are_refused_before_any_work(tmp_path, capsys):
    scene = _scene(tmp_path, *BIG_SURFACES)
    out = tmp_path / "db.h5"
    for argv in (["database", str(scene), "-o", str(out)], ["simulate", str(scene)], ["compare-models", str(scene)],
                 ["design", str(scene), "-o", str(tmp_path / "d")]):  # fmt: skip
        assert main([*argv, "--max-memory", "2G"]) == 2
        err = _one_line(capsys)
        assert "[surfaces.liner] n = 8192, [surfaces.piston] n = 8192" in err and "allowed by --max-memory" in err
    assert not out.exists()
    assert main(["simulate", "--max-memory", "lots"]) == 2
    assert "--max-memory" in _one_line(capsys)


def test_fit_refuses_to_simulate_a_session_scene_beyond_the_bound(tmp_path, capsys):
    session = tmp_path / "s.h5"
    assert main(["import", "--tab1", "-o", str(session)]) == 0
    capsys.readouterr()
    assert main(["fit", str(session), "--bootstrap", "0", "--max-memory", "1M"]) == 2
    assert "the contact database" in _one_line(capsys)


def test_acquire_sim_checks_the_scene_and_the_budget_before_printing_anything(tmp_path, capsys):
    out = tmp_path / "s.h5"
    bad = _scene(tmp_path, ("E_pa = 110e9", "E_pa = -1"), name="bad.toml")
    huge = _scene(tmp_path, *HUGE_MESH, name="huge.toml")
    for scene, says in ((bad, "[materials.liner] E_pa = -1"), (huge, "[rig] mesh = 'uniform'")):
        assert main(["acquire", str(scene), "--sim", "--yes", "--sim-speed", "inf", "-o", str(out)]) == 2
        got, err = capsys.readouterr()
        assert got == "" and err.count("\n") == 1 and says in err, err  # no plan printed before the error
        assert not out.exists()


@settings(max_examples=60, deadline=None)
@given(
    mesh=st.sampled_from(["uniform", "variable"]),
    n_theta=st.integers(2, 1_000_000),
    n_axial=st.integers(1, 100_000),
    max_nodes=st.integers(16, 100_000_000),
    crown=st.booleans(),
    weights=st.integers(1, 10_000),
    n=st.integers(4, 4096).map(lambda k: 2 * k),
)
def test_any_allowed_scene_is_estimated_at_once_and_refused_in_one_line_or_allowed(
    mesh, n_theta, n_axial, max_nodes, crown, weights, n
):
    """Over the whole allowed range of the keys that size the work: an estimate (nothing allocated, so it is
    instant), and either a one-line refusal naming those keys or no refusal at all."""
    from dataclasses import replace

    from sims.budget import check_specimen
    from sims.config import SimConfig
    from sims.rig.settings import RigSettings

    config = SimConfig.from_scene(load_scene(None))
    rig = RigSettings(mesh=mesh, n_theta=n_theta, n_axial=n_axial, max_nodes=max_nodes,
                      crown_m=1e-6 if crown else 0.0, weights_kg=(1.0,) * weights)  # fmt: skip
    config = config.with_changes(rig=rig, liner=replace(config.liner, n=n), piston=replace(config.piston, n=n))
    with memory_limit(4 << 30):
        try:
            check_specimen(config, ["hertz"])
        except BudgetError as exc:
            msg = str(exc)
            assert "\n" not in msg and ("[rig] mesh" in msg or "[surfaces.liner] n" in msg)
            assert exc.estimate.peak_bytes > 4 << 30
