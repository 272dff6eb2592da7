"""Every error line quotes at most ~80 characters of the offending input (issue 19 item 5): a 131 072-character
table cell, scene value, scene key or command-line argument gives a one-line error of bounded length that still
names the value by its first characters (and says how long it was)."""

from __future__ import annotations

from pathlib import Path

import pytest

from contactrig.cli.main import main
from contactrig.core.text import ERROR_LINE_LIMIT, QUOTE_LIMIT

HUGE = 131072
_EXTRA = 200  # the command name, "error:", "(see … --help)" around the bounded message


def _default_scene() -> str:
    from importlib import resources

    return resources.files("contactrig").joinpath("scenes/default.toml").read_text(encoding="utf-8")


def _cases(tmp: Path) -> dict[str, tuple[list[str], str]]:
    big = "q" * HUGE
    (tmp / "cell.csv").write_text(f"weight_kg,M1\n1,{big}\n2,3\n", encoding="utf-8")
    (tmp / "value.toml").write_text(_default_scene().replace('name = "paper-default"', f'name = 7\nsq = "{big}"'))
    (tmp / "key.toml").write_text(_default_scene().replace('name = "paper-default"', f'{big} = 1'))
    return {
        "table cell": (["import", str(tmp / "cell.csv"), "--unit", "mohm", "-o", str(tmp / "o.h5")], "qqqq"),
        "scene value": (["simulate", str(tmp / "value.toml")], "qqqq"),
        "scene key": (["simulate", str(tmp / "key.toml")], "qqqq"),
        "argument": (["acquire", "--sim", "--yes", "--sim-speed", big, "-o", str(tmp / "a.h5")], "qqqq"),
        "choice": (["export", str(tmp / "none.h5"), "--to", big], "qqqq"),
        "unknown argument": (["scene", "show", str(tmp / "value.toml"), "--" + big], "qqqq"),
    }


@pytest.mark.parametrize("case", ["table cell", "scene value", "scene key", "argument", "choice", "unknown argument"])
def test_a_huge_value_gives_a_bounded_one_line_error(case, tmp_path, capsys):
    argv, start = _cases(tmp_path)[case]
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1, err[:500]
    assert len(err) <= ERROR_LINE_LIMIT + _EXTRA, err[:500]
    assert start in err  # the value is still named by its first characters
    assert "q" * (QUOTE_LIMIT + 1) not in err
