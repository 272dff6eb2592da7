"""``contactrig simulate``: the specimen's load sweep, contact area against added weight
(:func:`sims.specimen.sweep_specimen`: the piston/liner rig, or the press for a scene with ``[press]``).

The scene is read once and parsed into a :class:`sims.config.SimConfig`; ``-o`` writes :mod:`daq.sweep_file`.
``--elastic`` couples the rig's asperity layer to the bodies' bulk elasticity and prints its computed effect
(``provenance["bulk_elasticity"]``) instead of the rigid model's σ·R_eff/b² warnings.

Registered by ``contactrig.cli.main``. Nothing heavy is imported until the command runs.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

__all__ = ["elasticity_sentences", "parse_list", "register"]

from contactrig.cli.options import add_device_option, add_max_memory_option, add_models_option
from contactrig.core.text import escape_terminal


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``simulate`` to ``subparsers``."""
    p = subparsers.add_parser(
        "simulate",
        help="simulate the specimen (piston/liner rig, or press): real contact area against weight, per model",
        description=(
            "Static equilibrium of the piston in its liner (seed section 2.1, Fig. 11) — or, for a scene with a "
            "[press] table, of the rough sphere pressed on the rough flat — for every weight and every contact model "
            "of the scene. Prints a table, or JSON with --json; -o writes the sweep to HDF5 with provenance (scene "
            "text, database provenance, software version)."
        ),
    )
    p.add_argument("scene", nargs="?", default=None, help="scene TOML file (default: the packaged paper scene)")
    p.add_argument(
        "--weights", metavar="KG,KG,...", help="added weights in kg, overriding the scene's [rig].weights_kg"
    )
    add_models_option(p)
    p.add_argument(
        "-o", "--output", metavar="FILE.h5",
        help="write the sweep to this HDF5 file (its folder is created; an existing file is refused without --force)",
    )  # fmt: skip
    p.add_argument("--force", action="store_true", help="overwrite an existing output file")
    p.add_argument(
        "--elastic", action="store_true",
        help="rig: include the bodies' bulk elasticity (sims.rig.elastic) and print its effect on area and peak "
        "pressure instead of the sigma*R/b^2 warnings (the press always includes it)",
    )  # fmt: skip
    p.add_argument("--json", action="store_true", help="print the result as JSON on stdout")
    add_max_memory_option(p)
    add_device_option(p)
    p.set_defaults(handler=_simulate)


def parse_list(option: str, text: str, kind: type = float) -> list[Any]:
    """Split a comma-separated option value; an empty item or a bad number is an error naming the option."""
    from contactrig.core.validation import SettingError

    items = [t.strip() for t in text.split(",")]
    if not items or any(t == "" for t in items):
        raise SettingError(option, text, "expected a comma-separated list without empty items")
    if kind is str:
        return items
    try:
        return [kind(t) for t in items]
    except ValueError:
        raise SettingError(option, text, "expected comma-separated numbers") from None


def _simulate(args: argparse.Namespace) -> int:
    from analysis.pipeline import specimen_sweep
    from contactrig.core.files import check_new_file
    from contactrig.core.scene import load_scene
    from daq.sweep_file import save_sweep, validity_warnings
    from sims.bem_backend import scene_device, use_device
    from sims.budget import check_specimen
    from sims.config import SimConfig
    from sims.rig import check_weights

    if args.output:
        check_new_file(args.output, force=args.force)  # refused before simulating anything
    scene = load_scene(args.scene)
    config = SimConfig.from_scene(scene)
    weights = check_weights(parse_list("--weights", args.weights), "--weights") if args.weights is not None else None
    check_specimen(config, args.models, weights)  # the whole sweep, before any of it starts
    with use_device(scene_device(args.device, scene)):  # the BEM model's solves, if the database has it
        result = specimen_sweep(config, args.models, weights, elastic=bool(args.elastic))
    warnings = list(result.warnings) + [w for w in validity_warnings(result) if w not in result.warnings]
    effects = elasticity_sentences(result)
    if args.output:
        path = save_sweep(result, args.output, force=args.force)
        print(f"wrote {path}", file=sys.stderr if args.json else sys.stdout)
    if args.json:
        from contactrig.cli.options import json_units

        print(json.dumps({"units": json_units(), **result.to_json_dict(), "warnings": warnings,
                          "bulk_elasticity": effects}))  # fmt: skip
        return 0
    _print_table(result)
    for line in effects:
        print(f"bulk elasticity: {escape_terminal(line)}")
    if args.elastic and config.press is not None:
        print("note: the press always includes the bulk elasticity (--elastic changes nothing)", file=sys.stderr)
    for w in warnings:
        print(f"warning: {escape_terminal(w)}", file=sys.stderr)
    return 0


def elasticity_sentences(result: Any) -> list[str]:
    """The computed effect of bulk elasticity, one sentence per model and weight (``provenance["bulk_elasticity"]``
    of an ``elastic=True`` rig sweep; empty otherwise)."""
    record = (getattr(result, "provenance", None) or {}).get("bulk_elasticity") or {}
    return [str(line) for m in (record.get("models") or {}).values() for line in (m.get("effect") or [])]


def _print_table(result: Any) -> None:
    for name, m in result.models.items():
        print(escape_terminal(name))
        print(f"  {'weight_kg':>10} {'load_N':>10} {'h0_um':>10} {'area_mm2':>12} {'width_mm':>10} {'p_peak_MPa':>11}")
        for i in range(m.weight_kg.size):
            print(
                f"  {m.weight_kg[i]:10.4g} {m.force_n[i]:10.4g} {m.min_separation_m[i] * 1e6:10.4g} "
                f"{m.contact_area_m2[i] * 1e6:12.5g} {m.contact_width_m[i] * 1e3:10.4g} "
                f"{m.peak_pressure_pa[i] * 1e-6:11.4g}"
            )
