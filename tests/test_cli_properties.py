"""Every command that reads a scene or a table, fed generated mistakes (issue #11 acceptance).

One key of a small scene (or a whole table) gets a value of the wrong type, NaN/inf, zero, negative, huge, unicode,
or an unknown key appears; each command that reads the scene runs on it through the real entry point. Every
outcome must be success, or an error whose last line is ``contactrig <command>: error: …`` with exit code 2 —
never a traceback, never another exit code, never a changed input file.
"""

from __future__ import annotations

import hashlib
import math
import re
import tomllib
import warnings
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from contactrig.cli.main import main
from contactrig.core.scene import default_scene_text


def _toml_value(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f'"{k}" = {_toml_value(x)}' for k, x in v.items()) + "}"
    raise TypeError(v)


def _dump(table: dict, prefix: str = "") -> list[str]:
    scalars = [f'"{k}" = {_toml_value(v)}' for k, v in table.items() if not isinstance(v, dict)]
    lines = ([f"[{prefix}]"] if prefix and scalars else []) + scalars
    for k, v in table.items():
        if isinstance(v, dict):
            lines += _dump(v, f"{prefix}.{k}" if prefix else k)
    return lines


def _base() -> dict:
    """The default scene, made small: GT only, two weights, one short block per weight, a small surface."""
    data = tomllib.loads(default_scene_text())
    data["database"]["models"] = ["greenwood_tripp"]
    data["rig"]["weights_kg"] = [5.44, 10.526]
    data["session"]["repeats"] = 1
    data["delta"]["count"] = 5
    for body in ("liner", "piston"):
        data["surfaces"][body]["n"] = 64
    return data


BASE = _base()
KEYS = [(t, k) for t, table in BASE.items() for k in table if not isinstance(table[k], dict)]
KEYS += [(f"{t}.{b}", k) for t in ("materials", "surfaces") for b in BASE[t] for k in BASE[t][b]]

BAD_VALUES = st.one_of(
    st.sampled_from([0, -1, -1.0e-9, 1e300, -1e300, float("nan"), float("inf"), float("-inf"), True, "", "µΩ ☃"]),
    st.sampled_from([[], [1, "a"], {"x": 1}, "1e-6", "nan", [float("nan")], 10**30]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),
)


def _mutated(table: str, key: str, value: object, extra_key: bool) -> str:
    data = tomllib.loads(default_scene_text())  # fresh copy
    data.update({t: v for t, v in _base().items()})
    node = data
    for part in table.split("."):
        node = node[part]
    node[key] = value
    if extra_key:
        node["colour_of_the_rig"] = "blue"
    return "\n".join(_dump(data)) + "\n"


def _outcome(argv: list[str], capsys) -> tuple[int, str]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse usage errors
            code = int(exc.code or 0)
    err = capsys.readouterr().err
    return code, err


def _check(argv: list[str], code: int, err: str) -> None:
    assert "Traceback" not in err, (argv, err)
    assert code in (0, 2), (argv, code, err)
    if code == 2:
        last = err.strip().splitlines()[-1]
        assert re.match(r"contactrig [\w-]+( \w+)?: error: ", last), (argv, last)


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(where=st.sampled_from(KEYS), value=BAD_VALUES, extra=st.booleans())
def test_generated_scene_mistakes_give_success_or_one_line_errors(where, value, extra, tmp_path_factory, capsys):
    folder = tmp_path_factory.mktemp("scene")
    scene = folder / "bad scene ☃.toml"
    scene.write_text(_mutated(*where, value, extra), encoding="utf-8")
    before = _digest(scene)
    # command → the tables it reads (each validates those, so an unknown key there must be refused)
    sim_tables = {"scene", "materials", "surfaces", "database", "rig"}
    runs = [
        (["circuit", "--scene", str(scene)], {"circuit"}),
        (["simulate", str(scene), "--json"], sim_tables),
        (["acquire", str(scene), "--sim", "--yes", "--sim-speed", "1000", "-o", str(folder / "s.h5")],
         sim_tables | {"circuit", "instrument", "delta", "session"}),
        (["scene", "show", str(scene)], {"scene"}),
    ]  # fmt: skip
    for argv, reads in runs:
        code, err = _outcome(argv, capsys)
        _check(argv, code, err)
        if extra and where[0].split(".")[0] in reads:
            assert code == 2, (argv, "an unknown key must be refused", err)  # (it, or the bad value, named)
    assert _digest(scene) == before


CELLS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["", "0", "-1", "1e300", "7,1", "NaN", "#DIV/0!", "µ", "1;2"]),
    st.text(max_size=6),
)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    header=st.lists(st.sampled_from(["weight_kg", "weight_g", "load_N", "M1", "R_ohm", "M1", "x", "☃"]), min_size=1,
                    max_size=4),
    rows=st.lists(st.lists(CELLS, min_size=1, max_size=4), max_size=5),
    sep=st.sampled_from([",", ";", "\t"]),
    unit=st.sampled_from([[], ["--unit", "mohm"], ["--unit", "ohm"]]),
)  # fmt: skip
def test_generated_tables_give_success_or_one_line_errors(header, rows, sep, unit, tmp_path_factory, capsys):
    folder = tmp_path_factory.mktemp("table")
    table = folder / "table.csv"
    table.write_text("\n".join(sep.join(r) for r in [header, *rows]) + "\n", encoding="utf-8")
    before = _digest(table)
    argv = ["import", str(table), *unit, "-o", str(folder / "t.h5")]
    code, err = _outcome(argv, capsys)
    _check(argv, code, err)
    assert _digest(table) == before


@pytest.mark.parametrize("table", ["delta", "session", "rig", "database", "materials", "surfaces"])
def test_a_missing_table_is_named(table, tmp_path, capsys):
    data = _base()
    del data[table]
    scene = tmp_path / "s.toml"
    scene.write_text("\n".join(_dump(data)) + "\n", encoding="utf-8")
    argv = ["acquire", str(scene), "--sim", "--yes", "--sim-speed", "1000", "-o", str(tmp_path / "s.h5")]
    code, err = _outcome(argv, capsys)
    _check(argv, code, err)
    if table in ("materials", "surfaces"):  # no defaults for the bodies: the missing table is named
        assert code == 2 and f"[{table}" in err, err
