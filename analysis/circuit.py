"""The measuring circuit of the seed paper (eq. 23–25) as a design calculator, and the ``[circuit]`` scene table.

Seed eq. 23 R_T = ζ h_R / A_R (contact resistance), eq. 24 I = U_R / (R_T + R_piston + R_pistonLiner) and eq. 25
U_c = R_T · I. Eq. 24 as printed leaves out the 100 Ω resistor the text then adds; here the loop resistance is
R_loop = R_T + R_series + R_piston + R_liner + R_added, so the paper's "120 mA" follows (12 V / 100 Ω).

The paper's design example (section 2.2) prints only the outputs, I = 1.2·10⁻¹ A and U_c = 1.34·10⁻⁸ V, so it
pins R_T = U_c / I ≈ 1.12·10⁻⁷ Ω (and U_R ≈ I · 100 Ω = 12 V), i.e. the product ζ·h/A, not ζ, h and A one by one.
:func:`paper_design_example` (``contactrig circuit --paper``) uses ζ = 1·10⁻⁷ Ω·m and h = 5 mm with
A = 4.47·10⁻³ m², the size of the nominal piston-skirt area — the paper evidently designed with the apparent area,
which is why the measured resistances (mΩ, Tab. 1) came out some 10⁴ times larger than "predicted". The default
scene's ζ = 4.3·10⁻⁷ Ω·m and R_s = 0 are instead fitted to Tab. 1 with the simulated greenwood_tripp area (the
scene's comment), so that a simulated session has Tab. 1's magnitude.

The Keithley 6221 is a current source limited to ±105 mA; the paper's 120 mA cannot be sourced by it (its "1 A"
limit is not the 6221's). With the 6221 one sets the current directly: :meth:`CircuitSettings.design` accepts
``current_a`` and then reports the compliance voltage the loop needs.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from analysis.resistance import bulk_resistance_ohm
from contactrig.core.validation import check_keys, check_range
from instruments.commands import K6221, MAX_CURRENT_A

__all__ = [
    "K6221_MAX_CURRENT_A",
    "CircuitDesign",
    "CircuitSettings",
    "paper_design_example",
]

#: The 6221's largest source current (either polarity) [A].
K6221_MAX_CURRENT_A = MAX_CURRENT_A  # the one declaration: instruments.commands
#: The 6221's largest voltage compliance [V].
K6221_MAX_COMPLIANCE_V = float(K6221["SOUR:CURR:COMP"].high or 0.0)


@dataclass(frozen=True)
class CircuitDesign:
    """Result of :meth:`CircuitSettings.design` (seed eq. 23–25). SI units; ``warnings`` in plain words."""

    contact_resistance_ohm: float
    loop_resistance_ohm: float
    current_a: float
    contact_voltage_v: float
    source_voltage_v: float
    warnings: tuple[str, ...] = ()

    def as_dict(self) -> dict[str, Any]:
        return {f.name: (list(v) if isinstance(v := getattr(self, f.name), tuple) else v) for f in fields(self)}


@dataclass(frozen=True)
class CircuitSettings:
    """The ``[circuit]`` table of a scene (seed eq. 23–25), validated on construction.

    Used by the simulated bench: ``resistivity_ohm_m`` ζ [Ω·m] > 0, ``contact_height_m`` h_R [m] > 0 and
    ``series_resistance_ohm`` R_s [Ω] ≥ 0 (leads, other contacts and bodies between the voltage taps, seen in series
    with R_T by the Delta measurement): R_measured = R_s + ζ h_R / A. Defaults: the packaged default scene's.
    Used by the design calculator only: ``contact_area_m2`` A_R [m²] > 0 (design contact area),
    ``source_voltage_v`` U_R [V] > 0, ``added_resistance_ohm`` R_P [Ω] ≥ 0 (the paper's 100 Ω resistor),
    ``piston_resistance_ohm`` and ``liner_resistance_ohm`` [Ω] ≥ 0 (bodies; the paper estimates them by eq. 23 with
    the wall height in place of h_R).
    """

    resistivity_ohm_m: float = 4.3e-7
    contact_height_m: float = 5.0e-3
    series_resistance_ohm: float = 0.0
    contact_area_m2: float = 4.47e-3
    source_voltage_v: float = 12.0
    added_resistance_ohm: float = 100.0
    piston_resistance_ohm: float = 0.0
    liner_resistance_ohm: float = 0.0

    def __post_init__(self) -> None:
        positive = {
            "resistivity_ohm_m": "Ω·m",
            "contact_height_m": "m",
            "contact_area_m2": "m²",
            "source_voltage_v": "V",
        }
        non_negative = {
            "series_resistance_ohm": "Ω",
            "added_resistance_ohm": "Ω",
            "piston_resistance_ohm": "Ω",
            "liner_resistance_ohm": "Ω",
        }
        for name, unit in positive.items():
            value = check_range(f"circuit.{name}", getattr(self, name), 0.0, None, lo_open=True, unit=unit)
            object.__setattr__(self, name, value)
        for name, unit in non_negative.items():
            value = check_range(f"circuit.{name}", getattr(self, name), 0.0, None, unit=unit)
            object.__setattr__(self, name, value)

    @classmethod
    def keys(cls) -> tuple[str, ...]:
        """The keys allowed in ``[circuit]``."""
        return tuple(f.name for f in fields(cls))

    @classmethod
    def from_mapping(cls, table: Mapping[str, Any]) -> CircuitSettings:
        """Build from a ``[circuit]`` table; unknown keys are an error naming the key; missing keys take defaults."""
        check_keys("circuit", table, cls.keys())
        return cls(**dict(table))

    @classmethod
    def from_scene(cls, scene: Any) -> CircuitSettings:
        """Build from ``scene.table("circuit")`` (a :class:`contactrig.core.scene.Scene`)."""
        return cls.from_mapping(scene.table("circuit"))

    def replace(self, **changes: Any) -> CircuitSettings:
        """A copy with ``changes`` (validated again); None values are ignored."""
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        unknown = {k: v for k, v in changes.items() if k not in values}
        check_keys("circuit", unknown, self.keys())
        values.update({k: v for k, v in changes.items() if v is not None})
        return CircuitSettings(**values)

    def contact_resistance_ohm(self, area_m2: np.ndarray | float) -> np.ndarray:
        """Seed eq. 23 with this table's ζ and h_R: R_T(A) [Ω]."""
        return bulk_resistance_ohm(area_m2, self.resistivity_ohm_m, self.contact_height_m)

    def measured_resistance_ohm(self, area_m2: np.ndarray | float) -> np.ndarray:
        """What a four-wire Delta measurement sees for real contact area A [m²]: R_s + ζ h_R / A [Ω]."""
        return self.series_resistance_ohm + self.contact_resistance_ohm(area_m2)

    def design(self, current_a: float | None = None) -> CircuitDesign:
        """Seed eq. 23–25 for the design contact area.

        With ``current_a`` None, a voltage source U_R drives the loop: I = U_R / R_loop (eq. 24 with the added
        resistor). With ``current_a`` given (a current source such as the 6221), I is set and the source must
        supply U = I · R_loop (its compliance voltage). Either way U_c = R_T · I (eq. 25).
        """
        r_t = float(self.contact_resistance_ohm(self.contact_area_m2))
        r_loop = (
            r_t
            + self.series_resistance_ohm
            + self.piston_resistance_ohm
            + self.liner_resistance_ohm
            + self.added_resistance_ohm
        )
        warnings: list[str] = []
        if current_a is None:
            current = self.source_voltage_v / r_loop
            voltage = self.source_voltage_v
        else:
            current = check_range("current_a", current_a, 0.0, None, lo_open=True, unit="A")
            voltage = current * r_loop
        if current > K6221_MAX_CURRENT_A:
            warnings.append(
                f"current {current:.4g} A exceeds the Keithley 6221's ±{K6221_MAX_CURRENT_A} A range: "
                "it cannot be sourced in Delta mode; raise added_resistance_ohm or set current_a ≤ 0.105 A"
            )
        if current_a is not None and voltage > K6221_MAX_COMPLIANCE_V:
            warnings.append(f"the loop needs {voltage:.4g} V, above the 6221's 105 V compliance limit")
        return CircuitDesign(
            contact_resistance_ohm=r_t,
            loop_resistance_ohm=r_loop,
            current_a=current,
            contact_voltage_v=r_t * current,
            source_voltage_v=voltage,
            warnings=tuple(warnings),
        )


def paper_design_example() -> CircuitSettings:
    """Inputs that reproduce the seed paper's design example (section 2.2): about 120 mA and 13.4 nV.

    U_R = 12 V and R_P = 100 Ω give the current; ζ = 1·10⁻⁷ Ω·m, h_R = 5 mm and A_R = 4.47·10⁻³ m² give
    R_T = 1.119·10⁻⁷ Ω and U_c = 13.4 nV. Only ζ·h/A is fixed by the paper (module docstring); body resistances and
    the series resistance are taken as zero (they are micro-ohms against 100 Ω).
    """
    return CircuitSettings(
        resistivity_ohm_m=1.0e-7,
        contact_height_m=5.0e-3,
        series_resistance_ohm=0.0,
        contact_area_m2=4.47e-3,
        source_voltage_v=12.0,
        added_resistance_ohm=100.0,
        piston_resistance_ohm=0.0,
        liner_resistance_ohm=0.0,
    )
