"""Issue 20 item 5: one option vocabulary over every subcommand (the table contactrig.cli.options.OPTION_VOCABULARY).

Walks every parser that ``contactrig`` builds (also nested ones: ``scene init``, ``instruments verify``) and checks:
an option that appears on two commands is declared; a declared option is a flag everywhere or takes a value
everywhere; ``-o`` is always ``--output``; no visible option is a deprecated name; an option whose value has a unit
says it in its help (SI, or the unit in the name); and the deprecated names still work, with a warning.
"""

from __future__ import annotations

import argparse
from collections import defaultdict

import pytest

from contactrig.cli.main import build_parser
from contactrig.cli.options import DEPRECATED, KNOWN_CONFLICTS, OPTION_VOCABULARY
from tests.cli_tree import subcommand_parsers


def _options(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    return [a for a in parser._actions if a.option_strings and a.help != argparse.SUPPRESS
            and not isinstance(a, (argparse._HelpAction, argparse._VersionAction))]  # fmt: skip


COMMANDS = subcommand_parsers(build_parser())


def _long(action: argparse.Action) -> str:
    return max(action.option_strings, key=len)


def test_every_command_is_walked():
    assert {"acquire", "compare-models", "design", "instruments verify", "instruments serve-sim", "scene init"} <= set(
        COMMANDS
    )


def test_shared_options_are_declared_and_take_one_kind_of_value():
    kinds: dict[str, set[bool]] = defaultdict(set)
    where: dict[str, set[str]] = defaultdict(set)
    for name, parser in COMMANDS.items():
        for a in _options(parser):
            kinds[_long(a)].add(a.nargs == 0)
            where[_long(a)].add(name)
    shared = {opt for opt, cmds in where.items() if len(cmds) > 1}
    undeclared = shared - set(OPTION_VOCABULARY) - set(KNOWN_CONFLICTS)
    assert not undeclared, f"options on several commands missing from OPTION_VOCABULARY: {sorted(undeclared)}"
    for opt, (kind, _) in OPTION_VOCABULARY.items():
        if opt in kinds:
            assert kinds[opt] == {kind == "flag"}, f"{opt}: a flag on some commands, a value on others ({where[opt]})"
    mixed = {opt for opt, k in kinds.items() if len(k) > 1} - set(KNOWN_CONFLICTS)
    assert not mixed, f"flag here, value there: {sorted(mixed)}"


def test_dash_o_is_always_output_and_no_deprecated_name_is_visible():
    for name, parser in COMMANDS.items():
        for a in _options(parser):
            if "-o" in a.option_strings:
                assert "--output" in a.option_strings, f"{name}: -o is not --output ({a.option_strings})"
            assert not set(a.option_strings) & set(DEPRECATED), f"{name}: shows deprecated {a.option_strings}"


UNIT_WORDS = {"--p-min": "Pa", "--p-max": "Pa", "--pressures": "Pa", "--current": " A", "--timeout-ms": "ms",
              "--delay": " s", "--compliance": " V", "--repeat-sd": "ln", "--resistance": "OHM"}  # fmt: skip


@pytest.mark.parametrize("option", sorted(UNIT_WORDS))
def test_options_with_units_say_their_unit(option):
    found = 0
    for parser in COMMANDS.values():
        for a in _options(parser):
            if _long(a) == option:
                found += 1
                text = f"{a.help} {a.metavar or ''}"
                assert UNIT_WORDS[option] in text, f"{option}: help {text!r} does not give its unit"
    assert found


def test_deprecated_names_still_work_with_a_warning(capsys):
    parser = build_parser()
    args = parser.parse_args(["instruments", "serve-sim", "--time-scale", "0.5"])
    assert args.sim_speed == 2.0  # inverse: 0.5 real s per instrument s = twice as fast
    assert parser.parse_args(["instruments", "serve-sim", "--time-scale", "0"]).sim_speed == float("inf")
    assert parser.parse_args(["instruments", "verify", "--out", "X"]).output == "X"
    err = capsys.readouterr().err
    assert "--time-scale is deprecated, use --sim-speed" in err and "--out is deprecated, use -o/--output" in err
    assert parser.parse_args(["instruments", "serve-sim", "--sim-speed", "inf"]).sim_speed == float("inf")


def test_pressures_accept_a_unit_and_say_pa():
    from contactrig.cli.options import parse_pressure_pa

    assert parse_pressure_pa("--p-min", "3e5") == 3e5
    assert parse_pressure_pa("--p-min", "0.3MPa") == pytest.approx(3e5)
    assert parse_pressure_pa("--p-min", "300 kPa") == pytest.approx(3e5)
    with pytest.raises(ValueError, match="--p-min"):
        parse_pressure_pa("--p-min", "3 bar")
