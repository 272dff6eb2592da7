"""``contactrig compare-models [SCENE]``: every contact model against the boundary-element reference (issue #14).

``contactrig compare-models [SCENE] [--models a,b] [--pressures P1,P2,… | --p-min PA --p-max PA --n-pressures N]
[--realisations N] [--scheduler ADDRESS] [--jobs N] [--elastic] [--area corrected|counted] [--refine F]
[--plot FILE]`` prints the table, the favoured model and one verdict line per model; ``--plot`` draws the figure.
The work runs on local processes, or on a Dask cluster with ``--scheduler tcp://host:port`` (extra ``dask``).
Nothing heavy is imported at module level.
"""

from __future__ import annotations

import argparse

from contactrig.cli.options import add_max_memory_option


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``compare-models`` to ``subparsers``."""
    p = subparsers.add_parser(
        "compare-models",
        help="rank the contact models against a boundary-element (FFT-BEM) solution of the scene's surface",
        description="Real area, mean gap and interfacial stiffness of each contact model against the periodic "
        "FFT boundary-element solution of the scene's composite surface (the reference), over mean pressure.",
    )
    p.add_argument("scene", nargs="?", default=None, help="scene TOML file (default: the packaged default scene)")
    p.add_argument("--models", default=None, help="comma-separated models to compare (default: the scene's)")
    p.add_argument("--pressures", default=None, help="comma-separated mean nominal pressures, Pa")
    p.add_argument("--p-min", type=float, default=0.1e6, help="lowest mean pressure, Pa (default 1e5)")
    p.add_argument("--p-max", type=float, default=30e6, help="highest mean pressure, Pa (default 3e7)")
    p.add_argument("--n-pressures", type=int, default=12, help="pressures, geometric from --p-min (default 12)")
    p.add_argument("--realisations", type=int, default=1, help="surface realisations (seeds), default 1")
    p.add_argument("--scheduler", default=None, help="Dask scheduler address (tcp://host:port); default: local")
    p.add_argument("--jobs", type=int, default=None, help="local processes (default: one per core)")
    p.add_argument("--elastic", action="store_true", help="BEM without the hardness cap")
    p.add_argument("--area", choices=("corrected", "counted"), default="corrected", help="BEM real area")
    p.add_argument("--refine", type=int, default=1, help="Fourier refinement of the surface for BEM (default 1)")
    p.add_argument("--plot", default=None, metavar="FILE", help="also draw the comparison figure to FILE")
    add_max_memory_option(p)
    p.set_defaults(handler=run_compare)


def _pressures(args: argparse.Namespace) -> tuple[float, ...]:
    from contactrig.core.validation import SettingError
    from sims.ensemble import geometric_pressures

    if args.pressures is None:
        return geometric_pressures(args.p_min, args.p_max, args.n_pressures)
    try:
        return tuple(float(v) for v in args.pressures.split(",") if v.strip())
    except ValueError:
        raise SettingError("--pressures", args.pressures, "expected comma-separated pressures in Pa") from None


def run_compare(args: argparse.Namespace) -> int:
    """Handler of ``contactrig compare-models``."""
    from analysis.compare_models import compare_models, comparison_table, report_lines
    from contactrig.core.files import refuse_existing

    if args.plot:  # refused (or its folder created) before the comparison runs, as every command's outputs
        refuse_existing([args.plot])
    cmp = compare_models(
        args.scene,
        args.models,
        pressures_pa=_pressures(args),
        realisations=args.realisations,
        plastic=not args.elastic,
        area=args.area,
        refine=args.refine,
        scheduler=args.scheduler,
        jobs=args.jobs,
    )
    prov = cmp.provenance
    print(comparison_table(cmp))
    print()
    for line in report_lines(cmp):
        print(line)
    print(
        f"({prov['tasks']} tasks on {prov['executor']}, {prov['fft_threads_per_task']} FFT thread(s) each: "
        f"{prov['wall_s']:.1f} s wall, {prov['task_s']:.1f} s in tasks)"
    )
    if args.plot:
        from analysis.compare_models import figure_compare_models
        from analysis.figures import save_figure_file

        print(f"wrote {save_figure_file(figure_compare_models(cmp), args.plot)}")
    return 0
