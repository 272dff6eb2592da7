"""Issue 20 item 12: the file from ``contactrig database -o`` is taken wherever a simulation is (``fit``,
``figures``, ``report`` ``--database DB.h5``): the specimen is simulated now on it, which gives the same A(W) as
building the database again, and a database made for other surfaces is refused like a mismatching sweep."""

from __future__ import annotations

from importlib import resources

import numpy as np
import pytest

from contactrig.cli.main import build_parser, main


@pytest.fixture(scope="module")
def databases(tmp_path_factory):
    folder = tmp_path_factory.mktemp("db")
    same, other = folder / "default.h5", folder / "small.h5"
    assert main(["database", "-o", str(same), "--models", "hertz", "--quiet"]) == 0
    text = resources.files("contactrig").joinpath("scenes/default.toml").read_text(encoding="utf-8")
    scene = folder / "small.toml"
    scene.write_text(text.replace("n = 512", "n = 64"), encoding="utf-8")
    assert main(["database", str(scene), "-o", str(other), "--models", "hertz", "--quiet"]) == 0
    return same, other


def test_same_areas_as_building_the_database_now(databases):
    from analysis.pipeline import analyse_tab1

    on_file = analyse_tab1(database_path=databases[0], models=["hertz"], n_boot=0)
    built = analyse_tab1(models=["hertz"], n_boot=0)
    np.testing.assert_allclose(on_file.areas_m2["hertz"], built.areas_m2["hertz"], rtol=1e-12, atol=0)
    assert "contact database" in on_file.sim_info["source"]


def test_other_surfaces_are_refused_and_sim_with_database_is_one_error(databases, capsys):
    assert main(["fit", "tab1", "--database", str(databases[1]), "--bootstrap", "0"]) == 2
    err = capsys.readouterr().err
    assert "[surfaces.liner] n differs: table 512, simulation 64" in err and len(err.strip().splitlines()) == 1
    assert main(["fit", "tab1", "--database", str(databases[0]), "--sim", "x.h5"]) == 2
    assert "not both" in capsys.readouterr().err


def test_every_command_that_takes_a_simulation_takes_a_database():
    parser = build_parser()
    for argv in (["fit", "tab1"], ["figures", "tab1", "-o", "d"], ["report", "tab1", "-o", "d"]):
        assert parser.parse_args([*argv, "--database", "db.h5"]).database == "db.h5"
