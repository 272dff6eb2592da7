"""The cases of the stability atlas, grouped by the method they exercise. Imports are inside each case."""

from __future__ import annotations

from functools import partial
from typing import TYPE_CHECKING

import numpy as np

from analysis.studies.atlas import Case

if TYPE_CHECKING:
    from collections.abc import Mapping

    from contactrig.core.scene import Scene
    from sims.database import ContactCurve

# a smooth steel/cast-iron-like pair, for cases that need statistics
_SIGMA, _ETA, _BETA = 0.5e-6, 5e10, 5e-6


def _gt_F_extremes() -> np.ndarray:
    from sims.greenwood_tripp import F

    t = np.array([-50.0, -8.0, 0.0, 10.0, 40.0, 1e3, 1e6])
    return np.concatenate([F(n, t) for n in (0.0, 1.0, 1.5, 2.0, 2.5)])


def _check_gt_tails(v: np.ndarray) -> None:
    f = v.reshape(5, 7)
    assert np.all(np.diff(f, axis=1) <= 0), "F_n not non-increasing in t"
    assert np.all(f[:, -1] == 0.0) or np.all(f[:, -1] < 1e-300), "F_n(1e6) not vanishing"
    # t → −∞: F_n(t) ≈ |t|^n
    np.testing.assert_allclose(f[:, 0], 50.0 ** np.array([0.0, 1.0, 1.5, 2.0, 2.5]), rtol=2e-3)


def _gt_pressure_sigma_tiny() -> np.ndarray:
    from sims.greenwood_tripp import pressure

    return pressure(np.array([-1e-9, 0.0, 1e-9, 1e-6]), sigma=1e-15, eta=5e10, beta=5e-6, E_star=1e11)


def _gt_pressure_E(E: float) -> np.ndarray:
    from sims.greenwood_tripp import pressure

    return pressure(np.linspace(-2e-6, 5e-6, 50), sigma=_SIGMA, eta=_ETA, beta=_BETA, E_star=E)


def _gt_pressure_E_out_of_domain() -> np.ndarray:
    from sims.greenwood_tripp import pressure

    return pressure(np.array([0.0]), sigma=_SIGMA, eta=_ETA, beta=_BETA, E_star=-1e9)


def _paper_polynomial_beyond_4() -> np.ndarray:
    from sims.greenwood_tripp import F

    return F(2.5, np.array([5.0, 6.0]), method="paper_polynomial")


def _gt_area_too_deep() -> np.ndarray:
    from sims.greenwood_tripp import area_fraction

    return area_fraction(np.array([-1e-3]), sigma=_SIGMA, eta=_ETA, beta=_BETA)


def greenwood_tripp_cases() -> list[Case]:
    return [
        Case(
            "F_n at t = −50 … 1e6",
            "greenwood_tripp.F",
            "Gaussian integrals far in both tails",
            _gt_F_extremes,
            "finite",
            check=_check_gt_tails,
        ),
        Case(
            "σ → 0 (1e-15 m)", "greenwood_tripp.pressure", "nearly smooth surfaces", _gt_pressure_sigma_tiny, "finite"
        ),
        Case(
            "E* = 1 kPa", "greenwood_tripp.pressure", "very compliant material", lambda: _gt_pressure_E(1e3), "finite"
        ),
        Case("E* = 10 TPa", "greenwood_tripp.pressure", "very stiff material", lambda: _gt_pressure_E(1e13), "finite"),
        Case("E* < 0", "greenwood_tripp.pressure", "outside the domain", _gt_pressure_E_out_of_domain, "error"),
        Case(
            "paper polynomial at t = 5, 6",
            "greenwood_tripp.F(paper_polynomial)",
            "beyond its table, where it turns negative",
            _paper_polynomial_beyond_4,
            "error",
        ),
        Case(
            "area fraction at h = −1 mm",
            "greenwood_tripp.area_fraction",
            "separation far below the surfaces",
            _gt_area_too_deep,
            "error",
        ),
    ]


def _asperity_extreme(name: str, E_star: float, deltas: np.ndarray) -> dict[str, np.ndarray]:
    from sims.asperity import model

    m = model(name, E_star=E_star, R=10e-6, H=min(2e9, E_star / 50))  # hardness/modulus of real solids
    return {"force": m.force(deltas), "area": m.area(deltas)}


def _check_monotone_and_zero(v: dict[str, np.ndarray]) -> None:
    for key, arr in v.items():
        assert arr[0] == 0.0 and arr[1] == 0.0, f"{key} not exactly 0 at delta <= 0"
        assert np.all(np.diff(arr[1:]) >= 0), f"{key} not non-decreasing in delta"


def _plastic_models_differ() -> dict[str, float]:
    """Deep in the plastic regime (δ = 1000 ω_c1) the elastic models keep growing as δ^1.5 while the
    plastic ones follow F = H·A: their forces must differ by orders of magnitude."""
    from sims.asperity import MODELS, model

    E, R, H = 49e9, 10e-6, 1.2e9
    wc1 = 0.89 * R * (H / E) ** 2
    d = np.array([1000 * wc1])
    return {name: float(model(name, E_star=E, R=R, H=H).force(d)[0]) for name in MODELS}


def _check_plastic_differ(v: dict[str, float]) -> None:
    assert v["hertz"] > 5 * v["pasaribu_schipper"], v
    assert v["hertz"] > 2 * v["jackson_green"], v


def asperity_cases() -> list[Case]:
    from sims.asperity import MODELS

    deltas = np.array([-1.0, 0.0, 1e-15, 1e-9, 1e-6, 1e-3, 1.0])
    cases = []
    for name in MODELS:
        for E, label in ((1e3, "1 kPa"), (1e12, "1 TPa")):
            cases.append(
                Case(
                    f"δ from −1 m to 1 m, E* = {label}",
                    f"asperity.{name}",
                    "interference over 15 decades",
                    partial(_asperity_extreme, name, E, deltas),
                    "finite",
                    check=_check_monotone_and_zero,
                )
            )
    cases.append(
        Case(
            "δ = 1000 ω_c1",
            "asperity (all)",
            "deep plastic regime: the models must differ",
            _plastic_models_differ,
            "finite",
            check=_check_plastic_differ,
        )
    )
    return cases


#: Surface grid of the atlas's database cases for models built from the surface (summits, or the whole surface for
#: the BEM reference): edge behaviour does not depend on the grid, and at 64² every build is short even on a loaded
#: machine (the BEM curve on the default scene's 512² took up to the whole time limit on two busy cores).
ATLAS_SURFACE_N = 64


def _database_curve(model: str) -> ContactCurve:
    from contactrig.core.scene import load_scene
    from sims.config import SimConfig
    from sims.database import build_database
    from sims.models import get_model

    scene = load_scene()
    if get_model(model).needs_surface:
        scene = _scene_with({"surfaces.liner.n": ATLAS_SURFACE_N, "surfaces.piston.n": ATLAS_SURFACE_N})
    return build_database(SimConfig.from_scene(scene), [model], n_separations=64)[model]


def _curve_far_outside(model: str) -> dict[str, np.ndarray]:
    curve = _database_curve(model)
    h = np.array([curve.h_min - 1e-3, curve.h_min - 1e-6, curve.h_max + 1e-6, curve.h_max + 1.0])
    return {"pressure": curve.pressure(h), "area": curve.area_fraction_at(h), "slope": -curve.dpressure_dh(h)}


def _check_outside(v: dict[str, np.ndarray]) -> None:
    assert np.all(v["area"] <= 1.0), "area fraction above 1"
    assert v["pressure"][0] >= v["pressure"][1] >= v["pressure"][2] >= v["pressure"][3], "not monotone"


def _curve_nan_separation() -> np.ndarray:
    return _database_curve("greenwood_tripp").pressure(np.array([np.nan]))


def database_cases() -> list[Case]:
    """Every registered contact model's curve far outside its table (a newly registered model is checked too)."""
    from sims.models import model_names

    return [
        *[
            Case(
                "h from h_min − 1 mm to h_max + 1 m",
                f"database.{m}",
                "separations far outside the table",
                partial(_curve_far_outside, m),
                "finite",
                check=_check_outside,
            )
            for m in model_names()
        ],
        Case("h = NaN", "database.greenwood_tripp", "not a separation", _curve_nan_separation, "error"),
    ]


def _scene_with(changes: Mapping[str, object]) -> Scene:
    """The default scene with ``changes`` ({"surfaces.liner.sq_m": 1e-8, …}) applied, re-serialised as TOML."""
    import json
    import tomllib

    from contactrig.core.scene import default_scene_text, parse_scene

    data = tomllib.loads(default_scene_text())
    for dotted, value in changes.items():
        *path, key = dotted.split(".")
        table = data
        for part in path:
            table = table[part]
        table[key] = value

    def dump(table: dict, prefix: str) -> list[str]:
        scalars = [f"{k} = {json.dumps(v)}" for k, v in table.items() if not isinstance(v, dict)]
        lines = ([f"[{prefix}]"] if prefix and scalars else []) + scalars
        for k, v in table.items():
            if isinstance(v, dict):
                lines += dump(v, f"{prefix}.{k}" if prefix else k)
        return lines

    return parse_scene("\n".join(dump(data, "")) + "\n", "<atlas>")


def _sweep_numbers(scene=None, models=("greenwood_tripp",), weights=(5.44,), **kw) -> dict[str, np.ndarray]:
    from sims.config import SimConfig
    from sims.rig import sweep

    config = SimConfig.from_scene(scene) if scene is not None else None
    result = sweep(config, models=list(models), weights_kg=list(weights), **kw)
    for w in result.warnings:
        import warnings

        warnings.warn(w, RuntimeWarning, stacklevel=2)
    out: dict[str, np.ndarray] = {}
    for name, m in result.models.items():
        out[f"{name}.area"] = m.contact_area_m2
        out[f"{name}.force"] = m.force_n
        out[f"{name}.peak"] = m.peak_pressure_pa
        out[f"{name}.width"] = m.contact_width_m
    return out


def _check_zero_load(v: dict[str, np.ndarray]) -> None:
    for key, arr in v.items():
        if key.endswith((".area", ".force", ".peak", ".width")):
            assert np.all(arr == 0.0), f"{key} = {arr} at zero weight"


def _check_models_differ(v: dict[str, np.ndarray]) -> None:
    ratio = float(v["hertz.area"][0] / v["pasaribu_schipper.area"][0])
    assert abs(ratio - 1.0) > 0.05, (
        f"elastic and elastic-plastic areas agree to {abs(ratio - 1):.2%} deep in plasticity"
    )


def _zero_clearance() -> dict[str, np.ndarray]:
    import dataclasses

    from contactrig.core.scene import load_scene
    from sims.rig.settings import RigSettings

    settings = dataclasses.replace(RigSettings.from_scene(load_scene()), clearance_m=0.0)
    return _sweep_numbers(None, settings=settings)


def rig_cases() -> list[Case]:
    soft = {"materials.piston.H_pa": 0.3e9, "materials.piston.E_pa": 70e9}
    return [
        Case(
            "weight 0 kg",
            "rig.sweep",
            "no load: area exactly 0",
            lambda: _sweep_numbers(weights=(0.0,)),
            "finite",
            check=_check_zero_load,
        ),
        Case("zero clearance", "rig.sweep", "piston fits the liner exactly", _zero_clearance, "finite"),
        Case(
            "Tab. 1 weights",
            "rig.sweep",
            "the paper's loads on the default scene",
            lambda: _sweep_numbers(weights=(5.44, 25.966)),
            "finite/warning",
        ),
        Case(
            "2000 kg",
            "rig.sweep",
            "far beyond the rig: bulk deformation no longer small",
            lambda: _sweep_numbers(weights=(2000.0,)),
            "warning",
        ),
        Case(
            "σ = 10 nm (very smooth)",
            "rig.sweep",
            "roughness ≪ bulk deflection",
            lambda: _sweep_numbers(_scene_with({"surfaces.liner.sq_m": 1e-8, "surfaces.piston.sq_m": 1e-8})),
            "warning",
        ),
        Case(
            "σ = 5 µm (very rough)",
            "rig.sweep",
            "roughness ≫ clearance-scale deflection",
            lambda: _sweep_numbers(_scene_with({"surfaces.liner.sq_m": 5e-6, "surfaces.piston.sq_m": 5e-6})),
            "finite",
        ),
        Case(
            "E = 1 TPa (very stiff)",
            "rig.sweep",
            "diamond-like bodies",
            lambda: _sweep_numbers(
                _scene_with(
                    {
                        "materials.liner.E_pa": 1e12,
                        "materials.piston.E_pa": 1e12,
                        "materials.liner.H_pa": 50e9,
                        "materials.piston.H_pa": 50e9,
                    }
                )
            ),
            "finite",
        ),
        Case(
            "soft alloy, 25.966 kg",
            "rig.sweep (hertz vs pasaribu_schipper)",
            "asperities deep in the plastic regime: the models must differ",
            lambda: _sweep_numbers(_scene_with(soft), models=("hertz", "pasaribu_schipper"), weights=(25.966,)),
            "finite/warning",
            check=_check_models_differ,
        ),
    ]


def _delta_with_overflow(indices: set[int], count: int = 10) -> dict[str, float]:
    from instruments.delta import DeltaSettings
    from instruments.k6221 import Keithley6221
    from instruments.simulated import Faults, SimulatedBench, simulated_resource_manager

    bench = SimulatedBench(resistance_ohm=5e-3, seed=5, faults=Faults(overflow_readings=indices))
    rm = simulated_resource_manager(bench=bench)
    with Keithley6221.open("GPIB0::12::INSTR", resource_manager=rm, timeout_ms=2000) as k:
        block = k.run_delta(DeltaSettings(high_a=1e-3, count=count))
    out: dict[str, float] = {"n": block.n, "n_invalid": block.n_invalid}
    if block.n:
        out["mean_ohm"] = float(block.resistance_ohm()[block.valid].mean())
    return out


def _check_overflow_not_averaged(v: dict[str, float]) -> None:
    assert v["n"] + v["n_invalid"] == 10
    if "mean_ohm" in v:
        assert abs(v["mean_ohm"] / 5e-3 - 1) < 1e-3, f"mean {v['mean_ohm']} is not the sample's 5 mΩ"


def _session_file_damaged(kind: str) -> dict[str, object]:
    import tempfile
    from pathlib import Path

    from analysis.simulated_session import SimulatedRigBench
    from daq import load_session
    from daq.acquire import acquire

    scene = _scene_with({"session.repeats": 1, "session.weights_kg": [5.44, 7.44], "delta.count": 5})
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "s.h5"
        acquire(scene, path, bench=SimulatedRigBench(float("inf")), yes=True, quiet=True, fsync=False)
        raw = path.read_bytes()
        if kind == "truncated":
            path.write_bytes(raw[: len(raw) // 3])
        else:  # a block's stored values altered after the fact: its checksum no longer matches
            import h5py

            with h5py.File(path, "r+") as f:
                f["entry/readings/resistance_ohm"][0] *= 1.01
        session = load_session(path)
        return {"blocks": len(session.summary)}


def instrument_and_session_cases() -> list[Case]:
    return [
        Case(
            "2 of 10 readings at +9.9E37",
            "instruments.run_delta",
            "2182A overflow in part of a block",
            lambda: _delta_with_overflow({3, 7}),
            "warning",
            check=_check_overflow_not_averaged,
        ),
        Case(
            "10 of 10 readings at +9.9E37",
            "instruments.run_delta",
            "no valid reading at all",
            lambda: _delta_with_overflow(set(range(10))),
            "warning",
            check=_check_overflow_not_averaged,
        ),
        Case(
            "truncated session file",
            "daq.load_session",
            "a file cut to a third of its size",
            lambda: _session_file_damaged("truncated"),
            "error",
        ),
        Case(
            "altered reading",
            "daq.load_session",
            "a stored value changed after the session",
            lambda: _session_file_damaged("tampered"),
            "error",
        ),
    ]


def _settle(method: str, damping: float, budget: int | None) -> dict[str, float]:
    from contactrig.core.scene import load_scene
    from sims.config import SimConfig
    from sims.database import build_database
    from sims.rig.dynamics import settle

    config = SimConfig.from_scene(load_scene())
    curve = build_database(config, ["greenwood_tripp"])["greenwood_tripp"]
    run = settle(curve, config.rig, 25.966, method=method, damping_n_s_per_m=damping, max_evaluations=budget)
    out = {"nfev": float(run.nfev), "status": float(abs(run.status))}
    if run.settled:
        out["rest_error"] = abs(run.separation_error_m) / abs(run.static_separation_m)
    return out


def _check_settled(v: dict[str, float]) -> None:
    assert "rest_error" in v and v["rest_error"] < 1e-4, v


def _check_budget_stops(v: dict[str, float]) -> None:
    assert v["status"] == 2 and "rest_error" not in v and v["nfev"] <= 20_010, v


def dynamics_cases() -> list[Case]:
    return [
        Case(
            "BDF, B = 1e7 N·s/m",
            "rig.dynamics.settle",
            "stiff damping, implicit method with the analytic Jacobian",
            lambda: _settle("BDF", 1e7, 100_000),
            "finite",
            check=_check_settled,
        ),
        Case(
            "RK45, B = 1e7 N·s/m, budget 2e4",
            "rig.dynamics.settle",
            "stiff damping, explicit method: must stop at its budget and say so, not run for minutes",
            lambda: _settle("RK45", 1e7, 20_000),
            "warning",
            check=_check_budget_stops,
        ),
    ]


def all_cases() -> list[Case]:
    """Every case, in report order."""
    cases: list[Case] = []
    cases += greenwood_tripp_cases()
    cases += asperity_cases()
    cases += database_cases()
    cases += rig_cases()
    cases += dynamics_cases()
    cases += instrument_and_session_cases()
    return cases
