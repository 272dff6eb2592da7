"""Per-run overrides of the scene: the keys a user changes from one run to the next (the instrument's address, the
sample, who measures…), given for one run (``contactrig acquire --address …``) instead of by editing the scene.

One declared table, :data:`OVERRIDES` (option → scene key → how a different value on ``--resume`` is treated), is
used by the command line, the start record, ``scene show`` and ``--resume`` alike (and by any other front end: it
calls :func:`apply_overrides` with the same ``{scene key: value}`` mapping).

* **Text, as UTF-8.** A value holding bytes that are not UTF-8 (``--sample $'Kolben-\xd8'`` from a Latin-1
  terminal, or the console's form) is refused naming its option (:func:`contactrig.core.text.check_text`), before any
  file is made.
* **Validated as the scene key.** An override is put in place of the scene's value and the plan is validated by the
  scene's own validators (:class:`daq.plan.SessionPlan`); an error names the option (``--address = 'x' is not
  allowed: …``).
* **Recorded apart from the scene.** The start record keeps the scene text exactly as the file was and the
  overrides under ``overrides`` (``{scene key: value}``); its ``plan`` holds the effective values.
* **Kept on ``--resume``.** A resumed run takes the overrides of the run before it; an option given again with a
  different value is a change: ``"record"`` keys (address, VISA library, operator, notes) are changed, said on the
  terminal and recorded in the run's start record (``override_changes``); ``"refuse"`` keys (the sample, and the
  simulated bench's seed — they change what the remaining blocks measure) are refused unless ``allow_change``.

``sim_seed`` is overridable because taking several realisations of the simulated bench from one scene is a daily
use (training, checking a fit's spread); ``rig``, ``repeats`` and the weights are not: they define the experiment,
which is the scene's job.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Literal

from contactrig.core.scene import Scene
from contactrig.core.text import check_text
from contactrig.core.validation import SettingError, scene_key

__all__ = [
    "OVERRIDES",
    "Overridable",
    "OverrideChange",
    "apply_overrides",
    "check_bench",
    "effective_values",
    "overrides_by_option",
    "plan_values",
    "plan_with_overrides",
    "resume_overrides",
    "visa_resource",
]


def _whole_number(text: str) -> Any:
    """A whole number from the option's text; other text is passed on for the scene key's validator to refuse."""
    try:
        return int(text)
    except ValueError:
        return text


#: GPIB primary addresses (IEEE 488.1: 0…30).
GPIB_PRIMARY = range(0, 31)


def visa_resource(text: str) -> str:
    """``--address``: a VISA resource name as VISA parses it (PyVISA's ``rname``: ``GPIB0::12::INSTR``,
    ``ASRL3::INSTR``, ``ASRL/dev/ttyUSB0::INSTR``, ``TCPIP0::192.168.0.50::1394::SOCKET``, ``USB0::…::INSTR``),
    with a GPIB primary address 0…30 and a socket port 1…65535; kept as typed. Raises SettingError naming the
    option, the value and the syntax."""
    from pyvisa import rname  # on use only: the command line's parser stays light

    allowed = ("a VISA resource name, e.g. GPIB0::12::INSTR, ASRL3::INSTR, ASRL/dev/ttyUSB0::INSTR or "
               "TCPIP0::192.168.0.50::1394::SOCKET")  # fmt: skip
    try:
        parsed = rname.parse_resource_name(text.strip())
    except rname.InvalidResourceName as exc:
        reason = str(exc).split(". ", 1)[-1] if ". " in str(exc) else str(exc)
        raise SettingError("--address", text, f"{allowed} ({reason})") from None
    primary = getattr(parsed, "primary_address", None)
    if isinstance(parsed, rname.GPIBInstr) and not (str(primary).isdigit() and int(str(primary)) in GPIB_PRIMARY):
        raise SettingError("--address", text, f"{allowed}: a GPIB primary address is a whole number 0…30")
    port = getattr(parsed, "port", None)
    if isinstance(parsed, rname.TCPIPSocket) and not (str(port).isdigit() and 0 < int(str(port)) < 65536):
        raise SettingError("--address", text, f"{allowed}: a socket port is a whole number 1…65535")
    return text.strip()


@dataclass(frozen=True)
class Overridable:
    """One overridable scene key: ``option`` on the command line, ``key`` the scene path (``"session.sample"``),
    ``parse`` the option's text to the key's type (validation stays the scene's), ``on_resume`` what a different
    value on ``--resume`` does (``"record"``: changed and recorded; ``"refuse"``: refused unless allowed),
    ``sim_only``: for the simulated bench only."""

    option: str
    key: str
    help: str
    on_resume: Literal["record", "refuse"]
    parse: Callable[[str], Any] = str
    sim_only: bool = False

    @property
    def dest(self) -> str:
        """The argparse destination of :attr:`option` (``--visa-library`` → ``visa_library``)."""
        return self.option.lstrip("-").replace("-", "_")


OVERRIDES: tuple[Overridable, ...] = (
    Overridable("--address", "instrument.address", "VISA resource of the instrument the PC talks to, e.g. "
                "GPIB0::12::INSTR, ASRL/dev/ttyUSB0::INSTR or TCPIP0::<ip>::1394::SOCKET (--sim answers at any)",
                "record", parse=visa_resource),
    Overridable("--visa-library", "instrument.visa_library", "VISA library for the address, e.g. @py (pyvisa-py); "
                "default the system's", "record"),
    Overridable("--sample", "session.sample", "free-text sample description", "refuse"),
    Overridable("--operator", "session.operator", "who runs the session (default: the scene's, else the login name)",
                "record"),
    Overridable("--notes", "session.notes", "free-text notes on this run", "record"),
    Overridable("--sim-seed", "session.sim_seed", "--sim: seed of the simulated noise and re-seating factors (>= 0)",
                "refuse", parse=_whole_number, sim_only=True),
)  # fmt: skip
_BY_KEY = {o.key: o for o in OVERRIDES}


def overrides_by_option(values: Mapping[str, str | None]) -> dict[str, Any]:
    """``{scene key: value}`` from option values by argparse destination (``{"address": "…", "sample": None}``);
    options not given (None) are left out."""
    given = {o: values.get(o.dest) for o in OVERRIDES}
    return {o.key: o.parse(check_text(o.option, text)) for o, text in given.items() if text is not None}


def _check_keys(overrides: Mapping[str, Any]) -> None:
    for key in overrides:
        if key not in _BY_KEY:
            raise SettingError("overrides", key, "expected one of " + ", ".join(_BY_KEY))


def apply_overrides(scene: Scene, overrides: Mapping[str, Any]) -> Scene:
    """``scene`` with ``overrides`` (``{scene key: value}``) in place of its values; its text stays the file's."""
    _check_keys(overrides)
    data = copy.deepcopy(scene.data)
    for key, value in overrides.items():
        check_text(_BY_KEY[key].option, value)  # not UTF-8 (a Latin-1 terminal): refused, never stored
        table, name = key.split(".")
        data.setdefault(table, {})[name] = value
    return Scene(text=scene.text, data=data, source=scene.source, height_maps=scene.height_maps)


def plan_with_overrides(scene: Scene, overrides: Mapping[str, Any]) -> Any:
    """The :class:`daq.plan.SessionPlan` of ``scene`` with ``overrides``, validated by the scene's validators; an
    error on an overridden key names its option."""
    from daq.plan import SessionPlan

    try:
        return SessionPlan.from_scene(apply_overrides(scene, overrides))
    except SettingError as exc:
        key = exc.field.split("[")[0]
        if key in overrides:
            option = _BY_KEY[key].option
            raise SettingError(option, exc.value, f"{exc.allowed} (as {scene_key(key)})") from None
        raise


def effective_values(scene: Scene, overrides: Mapping[str, Any]) -> list[tuple[Overridable, Any, str]]:
    """(declaration, effective value, where it comes from: ``"override"``, ``"scene"`` or ``"default"``) of every
    overridable key."""
    rows = []
    for o in OVERRIDES:
        table, name = o.key.split(".")
        if o.key in overrides:
            rows.append((o, overrides[o.key], "override"))
        elif name in scene.table(table):
            rows.append((o, scene.table(table)[name], "scene"))
        else:
            rows.append((o, None, "default"))
    return rows


@dataclass(frozen=True)
class OverrideChange:
    """A key a resumed run changes: ``before`` (the earlier run's effective value) → ``after``."""

    key: str
    option: str
    before: Any
    after: Any

    def as_dict(self) -> dict[str, Any]:
        return {"key": self.key, "option": self.option, "before": self.before, "after": self.after}

    def describe(self) -> str:
        return f"{self.option} changed on resume: {self.before!r} → {self.after!r} (recorded in the run's start record)"


def resume_overrides(
    earlier: Mapping[str, Any],
    given: Mapping[str, Any],
    earlier_values: Mapping[str, Any],
    *,
    allow_change: bool = False,
) -> tuple[dict[str, Any], list[OverrideChange]]:
    """The overrides of a resumed run: the earlier run's (``earlier``) with those ``given`` now on top, and the
    changes — a given value that differs from the earlier run's effective one (``earlier_values``, by scene key).
    A change of a ``"refuse"`` key raises a :class:`SettingError` naming the option unless ``allow_change``."""
    _check_keys(given)
    changes = []
    for key, value in given.items():
        before = earlier_values.get(key)
        if value == before:
            continue
        o = _BY_KEY[key]
        if o.on_resume == "refuse" and not allow_change:
            raise SettingError(
                o.option, value, f"the session was recorded with {scene_key(key)} = {before!r}; a resumed session "
                "continues the same measurement (start a new session, or add --allow-change to record the change)"
            )  # fmt: skip
        changes.append(OverrideChange(key, o.option, before, value))
    return {**earlier, **given}, changes


def plan_values(plan: Any) -> dict[str, Any]:
    """``{scene key: effective value}`` of every overridable key in a :class:`daq.plan.SessionPlan`."""
    values = {}
    for o in OVERRIDES:
        table, name = o.key.split(".")
        values[o.key] = getattr(getattr(plan, table), name)
    return values


def check_bench(overrides: Mapping[str, Any], *, simulated: bool) -> None:
    """Refuse an override that does not apply to the bench: a ``sim_only`` key on the real bench, the VISA library
    on the simulated one."""
    for key in overrides:
        o = _BY_KEY[key]
        if o.sim_only and not simulated:
            raise SettingError(o.option, overrides[key], "applies to the simulated bench (--sim) only")
        if simulated and key == "instrument.visa_library":
            raise SettingError(o.option, overrides[key], "applies to the real bench, not to --sim")


def describe_runs(runs: list[Any]) -> list[str]:
    """What ``scene show`` prints after a session's scene text, as TOML comments (so the output stays a scene): the
    overrides of each run (start records ``runs``) and the effective value of every overridable key in the latest run
    (from its recorded plan), with where it came from. Nothing for a session without overrides records (imported,
    or older)."""
    records = [r for r in runs if isinstance(r, dict)]
    if not any("overrides" in r for r in records):
        return []  # imported, or recorded before overrides existed
    lines = ["# overrides (acquire options; the scene text above is the file as it was, unchanged):"]
    for i, record in enumerate(records):
        given = _dict(record.get("overrides"))
        shown = ", ".join(f"{_option(k)} {v!r}" for k, v in given.items()) or "none"
        lines.append(f"#   run {i + 1}: {shown}")
        for change in record.get("override_changes") or []:
            if isinstance(change, dict):
                lines.append(f"#     changed on resume: {change.get('option')} {change.get('before')!r} → "
                             f"{change.get('after')!r}")  # fmt: skip
    latest = records[-1]
    given, plan = _dict(latest.get("overrides")), _dict(latest.get("plan"))
    lines.append(f"# effective values (run {len(records)}):")
    for o in OVERRIDES:
        table, name = o.key.split(".")
        section = _dict(plan.get(table))
        if name not in section:
            continue  # recorded before the key existed
        origin = f"override {o.option}" if o.key in given else "scene or default"
        lines.append(f"#   {scene_key(o.key)} = {section[name]!r}  ({origin})")
    return lines


def _option(key: Any) -> str:
    o = _BY_KEY.get(str(key))
    return o.option if o is not None else str(key)


def _dict(value: Any) -> dict[str, Any]:
    return value if isinstance(value, dict) else {}
