"""Options shared by several commands, declared once so they read and behave the same everywhere."""

from __future__ import annotations

import argparse


def models_help(default: str = "the scene's [database] models") -> str:
    """``--models`` help from the model registry."""
    from sims.models import model_names

    return (
        f"contact models, comma-separated or the option repeated (default: {default}); registered: "
        + ", ".join(model_names())
    )


def _split(values: list[str] | None) -> list[str] | None:
    if values is None:
        return None
    return [m for v in values for m in (s.strip() for s in v.split(",")) if m]


class _Models(argparse.Action):
    """``--models a,b`` = ``--models a --models b`` (one value per option, so a scene file after it is never taken
    for a model); unknown names are refused at once, naming the registered ones."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: object,
                 option_string: str | None = None) -> None:  # fmt: skip
        from sims.database import check_models

        before = getattr(namespace, self.dest, None) or []
        names = _split([*before, *(values if isinstance(values, list) else [str(values)])]) or []
        try:
            setattr(namespace, self.dest, list(check_models("--models", names)))
        except ValueError as exc:
            parser.error(str(exc))


def _size(text: str) -> int:
    from contactrig.core.budget import parse_size

    try:
        return parse_size(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_max_memory_option(parser: argparse.ArgumentParser) -> None:
    """The one ``--max-memory SIZE`` option (``args.max_memory``: bytes, or None for the machine's available memory);
    ``contactrig.cli.main`` applies it (:func:`contactrig.core.budget.memory_limit`) around the command."""
    parser.add_argument(
        "--max-memory", metavar="SIZE", type=_size, default=None,
        help="refuse work whose estimated memory exceeds SIZE, e.g. 2G or 512M (default: the memory available now, "
        "MemAvailable)",
    )  # fmt: skip


def add_models_option(parser: argparse.ArgumentParser, default: str = "the scene's [database] models") -> None:
    """The one ``--models`` option (``args.models``: a list of registered keys, or None for the default)."""
    parser.add_argument("--models", metavar="NAME,NAME", action=_Models, default=None, help=models_help(default))


#: Unit suffixes a pressure option accepts (bare numbers are Pa, the SI unit of every pressure option).
PRESSURE_UNITS = {"pa": 1.0, "kpa": 1e3, "mpa": 1e6, "gpa": 1e9}


def parse_pressure_pa(option: str, text: str) -> float:
    """A pressure option's value in Pa: a number (Pa) or a number with a unit suffix, e.g. ``3e5``, ``300kPa``,
    ``0.3MPa`` (the tables print MPa; both are accepted). Raises SettingError naming the option."""
    from contactrig.core.validation import SettingError

    t = text.strip().lower().replace(" ", "")
    factor = 1.0
    for unit in sorted(PRESSURE_UNITS, key=len, reverse=True):
        if t.endswith(unit):
            t, factor = t[: -len(unit)], PRESSURE_UNITS[unit]
            break
    try:
        return float(t) * factor
    except ValueError:
        raise SettingError(option, text, "a pressure in Pa, or with a unit: 3e5, 300kPa, 0.3MPa") from None


def pressure_type(option: str) -> object:
    """argparse ``type=`` for one pressure (see :func:`parse_pressure_pa`)."""

    def parse(text: str) -> float:
        try:
            return parse_pressure_pa(option, text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    return parse


def add_json_option(parser: argparse.ArgumentParser, what: str = "the result") -> None:
    """The one ``--json`` option: print ``what`` as JSON on stdout (units in the keys and a ``units`` object; schema
    in ``contactrig/schemas/<command>.json``)."""
    parser.add_argument("--json", action="store_true", help=f"print {what} as JSON on stdout")
