"""Options shared by several commands, declared once so they read and behave the same everywhere."""

from __future__ import annotations

import argparse
from typing import Any


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


class _Deprecated(argparse.Action):
    """An old option name that still works: says on stderr which name replaces it, then stores the value (through
    ``convert``, e.g. an inverse) where the new option stores it."""

    def __init__(self, option_strings: list[str], dest: str, new: str = "", convert: Any = None, **kw: Any) -> None:
        self.new, self.convert = new, convert
        super().__init__(option_strings, dest, **kw)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: object,
                 option_string: str | None = None) -> None:  # fmt: skip
        import sys

        print(f"{parser.prog}: warning: {option_string} is deprecated, use {self.new}", file=sys.stderr)
        try:
            value = self.convert(values) if self.convert is not None else values
        except ValueError as exc:
            parser.error(f"{option_string} = {values!r}: {exc}")
        setattr(namespace, self.dest, value)


def add_deprecated_alias(parser: argparse.ArgumentParser, old: str, new: str, dest: str, convert: Any = None) -> None:
    """``old`` (hidden from --help) as a deprecated spelling of ``new`` (stored in ``dest``, via ``convert``)."""
    parser.add_argument(old, dest=dest, action=_Deprecated, new=new, convert=convert, default=argparse.SUPPRESS,
                        help=argparse.SUPPRESS)  # fmt: skip


#: The option vocabulary of every ``contactrig`` command (tests/test_cli_vocabulary.py walks every parser against it):
#: an option name means one thing and takes one kind of value wherever it appears. ``"flag"`` takes no value;
#: otherwise the value's kind and unit. A bare number for a physical quantity is in SI units (Pa, s, kg, A, V, Ω);
#: other units are in the name (``--timeout-ms``) or accepted as a suffix (pressures: ``0.3MPa``).
OPTION_VOCABULARY: dict[str, tuple[str, str]] = {
    "--output": ("path", "-o/--output: where the command writes (a file or a folder), never an input"),
    "--force": ("flag", "replace existing output files"),
    "--json": ("flag", "print the result as JSON on stdout (schema: contactrig/schemas/<command>.json)"),
    "--quiet": ("flag", "no progress bar on stderr"),
    "--models": ("names", "registered contact-model keys, comma-separated or repeated"),
    "--max-memory": ("size", "memory bound, e.g. 2G"),
    "--device": ("choice", "where the boundary-element solves run: cpu or gpu (CuPy)"),
    "--sim-speed": ("number", "simulated instrument time runs X times faster than real (inf: no waiting)"),
    "--seed": ("integer", "random seed"),
    "--visa-library": ("text", "VISA library, e.g. @py"),
    "--timeout-ms": ("integer", "VISA timeout in ms"),
    "--current": ("number", "current in A"),
    "--bootstrap": ("integer", "bootstrap resamples"),
    "--pressures": ("pressures", "mean nominal pressures: Pa, or with a unit suffix"),
    "--p-min": ("pressure", "lowest mean pressure: Pa, or with a unit suffix"),
    "--p-max": ("pressure", "highest mean pressure: Pa, or with a unit suffix"),
    "--plot": ("path", "also draw the figure to this file"),
    "--database": ("path", "DB.h5 from `contactrig database -o`, an input: the specimen is simulated now on it"),
    "--sessions": ("integer", "simulated sessions"),
    "--area": ("choice|number", "circuit: A_R in m²; compare-models: BEM area corrected|counted"),
    "--elastic": ("flag", "include elasticity"),
    "--unit": ("choice", "unit of values (import: resistance; delta: reading)"),
    "--conversion": ("choice", "area → resistance: bulk, holm or physical"),
    "--sample": ("text", "the sample: acquire sets it for the run (over the scene); sessions filters by it"),
    "--operator": ("text", "who runs the session: acquire/import set it (over the scene or the table)"),
    "--weighting": ("choice", "σ per weight of the fit"),
    "--interval": ("choice", "bootstrap interval"),
    "--allow-mismatch": ("flag", "compare although the simulation's scene differs"),
    "--no-compare-models": ("flag", "--compare-models/--no-compare-models: run the BEM comparison or not"),
    "--host": ("text", "address a server listens on (default: loopback)"),
    "--port": ("integer", "TCP port a server listens on"),
    "--noise-from": ("choice|path", "noise model from a session file (SESSION.h5; design: also tab1 or iid)"),
}
#: Options that are not yet one word for one thing (kept for compatibility, listed so that no new one appears):
#: ``--sim`` is a flag (use the simulated bench) on acquire/instruments and a path (SIM.h5, a rig sweep) on
#: fit/figures/report/export.
KNOWN_CONFLICTS = {"--sim": "flag on acquire/instruments; SIM.h5 path on fit/figures/report/export"}
#: Old names that still work with a warning on stderr: old → new.
DEPRECATED = {"--out": "-o/--output", "--time-scale": "--sim-speed"}


#: Units of JSON numbers by the suffix of their key (``contact_area_m2``: m²); every ``--json`` object carries this
#: map as ``units["by_suffix"]`` (plus entries for keys without a suffix), so a reader needs no manual.
JSON_SUFFIX_UNITS = {
    "_ohm": "Ω", "_ohm_m": "Ω·m", "_m": "m", "_m2": "m²", "_per_m": "1/m", "_a": "A", "_v": "V", "_kg": "kg",
    "_n": "N", "_pa": "Pa", "_pa_per_m": "Pa/m", "_s": "s", "_ms": "ms",
}  # fmt: skip


def json_units(**keys: str) -> dict[str, Any]:
    """The ``units`` object of a ``--json`` output: the suffix map and ``keys`` (key → unit) for keys without one."""
    return {"by_suffix": dict(JSON_SUFFIX_UNITS), **keys}


def add_device_option(parser: argparse.ArgumentParser) -> None:
    """The one ``--device cpu|gpu`` option (``args.device``; None: the scene's ``[scene] device``, else cpu):
    where the boundary-element solves run (:mod:`sims.bem_backend`)."""
    parser.add_argument(
        "--device", choices=("cpu", "gpu"), default=None,
        help="where the boundary-element (BEM) solves run: cpu, or gpu with CuPy (extra 'gpu'); default: the "
        "scene's [scene] device, else cpu",
    )  # fmt: skip
