"""``contactrig`` subcommands of the ``sims`` package (registered by ``contactrig.cli.main``).

``contactrig database [SCENE] -o db.h5 [--models a,b] [--n-separations N] [--gt-heights summits|seed]
[--plot FILE]`` builds the contact database of a scene (the packaged default when SCENE is omitted), writes it to
HDF5 and optionally draws seed Fig. 2. Nothing heavy is imported at module level.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from typing import Any

from contactrig.cli.options import (
    add_device_option,
    add_json_option,
    add_max_memory_option,
    add_models_option,
    json_units,
)
from contactrig.cli.progress import add_quiet_option, progress_bar


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this package's subcommands to ``subparsers``."""
    p = subparsers.add_parser(
        "database",
        help="build the contact database (pressure and real area vs separation) of a scene",
        description="Build the simulated contact database of a scene (seed §1, Fig. 2) and write it to HDF5.",
    )
    p.add_argument("scene", nargs="?", default=None, help="scene TOML file (default: the packaged default scene)")
    p.add_argument(
        "-o", "--output", required=True,
        help="HDF5 file to write (its folder is created; an existing file is refused without --force)",
    )  # fmt: skip
    p.add_argument("--force", action="store_true", help="overwrite existing output files (-o, --plot)")
    add_models_option(p)
    p.add_argument("--n-separations", type=int, default=None, help="grid points per curve (default: the scene's)")
    p.add_argument(
        "--gt-heights",
        choices=("summits", "seed"),
        default=None,
        help="Greenwood-Tripp asperity heights: 'summits' (McCool's summit distribution, same origin of h as the "
        "asperity models) or 'seed' (eq. 1-3 as printed); default: the scene's [database].gt_heights",
    )
    p.add_argument("--plot", default=None, metavar="FILE", help="also draw pressure vs separation (Fig. 2) to FILE")
    add_json_option(p, "what was built (per model: separation range, pressure and area at the closest approach)")
    add_quiet_option(p)
    add_max_memory_option(p)
    add_device_option(p)
    p.set_defaults(handler=run_database)


def run_database(args: argparse.Namespace) -> int:
    """Handler of ``contactrig database``."""
    from contactrig.core.files import refuse_existing
    from contactrig.core.scene import load_scene
    from contactrig.core.text import escape_terminal
    from daq.database_file import save_database
    from daq.sweep_file import plasticity_warnings
    from sims.bem_backend import scene_device, use_device
    from sims.config import SimConfig
    from sims.database import build_database

    refuse_existing([args.output] + ([args.plot] if args.plot else []), force=args.force)  # before any work
    scene = load_scene(args.scene)
    config = SimConfig.from_scene(scene)
    device = use_device(scene_device(args.device, scene))  # the GPU is checked on entering, before any work
    with device, warnings.catch_warnings(), progress_bar("database: models", quiet=args.quiet) as progress:
        warnings.simplefilter("ignore", RuntimeWarning)  # the same text is in provenance["warnings"], printed below
        db = build_database(config, args.models, n_separations=args.n_separations, gt_heights=args.gt_heights,
                            progress=progress)  # fmt: skip
    out = save_database(db, args.output, force=args.force)
    prov = db.provenance
    for w in list(prov.get("warnings", [])) + plasticity_warnings(list(db), prov):
        print(f"warning: {escape_terminal(w)}", file=sys.stderr)
    gt = prov.get("greenwood_tripp", {})
    if args.json:
        _print_json(db, out, prov)
    else:
        _print_text(db, out, prov, gt)
    if args.plot:
        from analysis.figures import write_database_figure

        written = write_database_figure(db, args.plot, force=args.force)
        print(f"wrote {written}", file=sys.stderr if args.json else sys.stdout)
    return 0


def _print_json(db: Any, out: Any, prov: dict[str, Any]) -> None:
    """``database --json`` (schema contactrig/schemas/database.json)."""
    import json
    import math

    def num(x: Any) -> float | None:
        return float(x) if isinstance(x, (int, float)) and math.isfinite(float(x)) else None

    models = {
        name: {"h_min_m": float(c.h_min), "h_max_m": float(c.h_max), "pressure_at_h_min_pa": float(c.pressure_pa[0]),
               "area_fraction_at_h_min": float(c.area_fraction[0])}
        for name, c in db.items()
    }  # fmt: skip
    gt = {k: (num(v) if not isinstance(v, str) else v) for k, v in (prov.get("greenwood_tripp") or {}).items()
          if isinstance(v, (int, float, str))}  # fmt: skip
    print(json.dumps({
        "units": json_units(area_fraction_at_h_min="1 (A/A0)", plasticity_index="1", eta_per_m2="1/m²"),
        "path": str(out), "scene": str(prov.get("scene_name", "")), "models": models, "greenwood_tripp": gt,
        "plasticity_index": num(prov.get("plasticity_index")), "build_time_s": float(prov.get("build_time_s", 0.0)),
        "warnings": [str(w) for w in prov.get("warnings", [])],
    }, indent=1))  # fmt: skip


def _print_text(db: Any, out: Any, prov: dict[str, Any], gt: dict[str, Any]) -> None:
    print(
        f"contact database of scene {prov.get('scene_name', '')!r}: {', '.join(db)}; "
        f"sigma = {gt.get('sigma_m', float('nan')):.3g} m, eta = {gt.get('eta_per_m2', float('nan')):.3g} 1/m², "
        f"beta = {gt.get('beta_m', float('nan')):.3g} m, "
        f"plasticity index {prov.get('plasticity_index', float('nan')):.2f}; GT summit heights "
        f"{gt.get('heights', '?')!r}: mean {gt.get('offset_m', float('nan')):.3g} m, SD "
        f"{gt.get('sigma_summits_m', float('nan')):.3g} m"
    )
    for name, curve in db.items():
        print(
            f"  {name:18s} h = {curve.h_min:.3g} … {curve.h_max:.3g} m, "
            f"p(h_min) = {curve.pressure_pa[0]:.3g} Pa, A/A0(h_min) = {curve.area_fraction[0]:.3g}"
        )
    print(f"wrote {out} ({prov.get('build_time_s', 0.0):.2f} s)")
