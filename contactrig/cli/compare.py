"""``contactrig compare-models [SCENE]``: every contact model against the boundary-element reference (issue #14).

``contactrig compare-models [SCENE] [--models a,b] [--pressures P1,P2,… | --p-min PA --p-max PA --n-pressures N]
[--realisations N] [--scheduler ADDRESS] [--jobs N] [--device cpu|gpu] [--elastic] [--area corrected|counted]
[--refine F] [--plot FILE] [--json] [--quiet]`` prints the table (≤ 100 columns), the favoured model and one
verdict line per model; ``--plot`` draws the figure; ``--json`` prints everything at full precision with units.
The work runs on local processes, or on a Dask cluster with ``--scheduler tcp://host:port`` (extra ``dask``).
Nothing heavy is imported at module level.
"""

from __future__ import annotations

import argparse
from typing import Any

from contactrig.cli.options import (
    add_device_option,
    add_json_option,
    add_max_memory_option,
    add_models_option,
    json_units,
    parse_pressure_pa,
    pressure_type,
)
from contactrig.cli.progress import add_quiet_option, progress_bar


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``compare-models`` to ``subparsers``."""
    p = subparsers.add_parser(
        "compare-models",
        help="rank the contact models against a boundary-element (FFT-BEM) solution of the scene's surface",
        description="Real area, mean gap and interfacial stiffness of each contact model against the periodic "
        "FFT boundary-element solution of the scene's composite surface (the reference), over mean pressure.",
    )
    p.add_argument("scene", nargs="?", default=None, help="scene TOML file (default: the packaged default scene)")
    add_models_option(p)
    p.add_argument(
        "--pressures", default=None, metavar="P,P,…",
        help="comma-separated mean nominal pressures: Pa, or with a unit (300kPa, 0.3MPa)",
    )  # fmt: skip
    p.add_argument("--p-min", type=pressure_type("--p-min"), default=0.1e6, metavar="P",
                   help="lowest mean pressure: Pa, or with a unit (default 0.1MPa)")  # fmt: skip
    p.add_argument("--p-max", type=pressure_type("--p-max"), default=30e6, metavar="P",
                   help="highest mean pressure: Pa, or with a unit (default 30MPa)")  # fmt: skip
    p.add_argument("--n-pressures", type=int, default=12, help="pressures, geometric from --p-min (default 12)")
    p.add_argument("--realisations", type=int, default=1, help="surface realisations (seeds), default 1")
    p.add_argument("--scheduler", default=None, help="Dask scheduler address (tcp://host:port); default: local")
    p.add_argument("--jobs", type=int, default=None, help="local processes (default: one per core)")
    p.add_argument("--elastic", action="store_true", help="BEM without the hardness cap")
    p.add_argument("--area", choices=("corrected", "counted"), default="corrected", help="BEM real area")
    p.add_argument("--refine", type=int, default=1, help="Fourier refinement of the surface for BEM (default 1)")
    p.add_argument("--plot", default=None, metavar="FILE", help="also draw the comparison figure to FILE")
    add_json_option(p, "the comparison (full precision, units)")
    add_quiet_option(p)
    add_max_memory_option(p)
    add_device_option(p)
    p.set_defaults(handler=run_compare)


def _pressures(args: argparse.Namespace) -> tuple[float, ...]:
    from contactrig.core.validation import SettingError
    from sims.ensemble import geometric_pressures

    if args.pressures is None:
        return geometric_pressures(args.p_min, args.p_max, args.n_pressures)
    try:
        return tuple(parse_pressure_pa("--pressures", v) for v in args.pressures.split(",") if v.strip())
    except ValueError:
        raise SettingError(
            "--pressures", args.pressures, "comma-separated pressures: Pa, or with a unit (300kPa, 0.3MPa)"
        ) from None


def run_compare(args: argparse.Namespace) -> int:
    """Handler of ``contactrig compare-models``."""
    import json
    import textwrap

    from analysis.compare_models import TABLE_WIDTH, compare_models, comparison_dict, comparison_table, report_lines
    from contactrig.core.files import refuse_existing
    from contactrig.core.scene import load_scene
    from sims.bem_backend import scene_device, use_device

    if args.plot:  # refused (or its folder created) before the comparison runs, as every command's outputs
        refuse_existing([args.plot])
    scene = load_scene(args.scene)
    device = use_device(scene_device(args.device, scene))  # the GPU is checked on entering, before any work
    with device, progress_bar("compare-models: tasks", quiet=args.quiet) as progress:
        cmp = compare_models(
            scene,
            args.models,
            pressures_pa=_pressures(args),
            realisations=args.realisations,
            plastic=not args.elastic,
            area=args.area,
            refine=args.refine,
            scheduler=args.scheduler,
            jobs=args.jobs,
            progress=progress,
        )
    prov = cmp.provenance
    if args.json:
        written = _plot(cmp, args.plot)
        d = comparison_dict(cmp)
        d["units"] = json_units(**d["units"])
        print(json.dumps({**d, "figure": written}, indent=1))  # schema: contactrig/schemas/compare-models.json
        return 0
    print(comparison_table(cmp, width=TABLE_WIDTH))
    print()
    lines = [*report_lines(cmp), f"({prov['tasks']} tasks on {prov['executor']}, {prov['fft_threads_per_task']} FFT "
             f"thread(s) each: {prov['wall_s']:.1f} s wall, {prov['task_s']:.1f} s in tasks)"]  # fmt: skip
    for line in lines:
        print(textwrap.fill(line, TABLE_WIDTH, subsequent_indent="    ", break_on_hyphens=False))
    written = _plot(cmp, args.plot)
    if written:
        print(f"wrote {written}")
    return 0


def _plot(cmp: Any, path: str | None) -> str | None:
    """``--plot FILE``: the figure, drawn to FILE; its path (None without --plot)."""
    if not path:
        return None
    from analysis.compare_models import figure_compare_models
    from analysis.figures import save_figure_file

    return str(save_figure_file(figure_compare_models(cmp), path))
