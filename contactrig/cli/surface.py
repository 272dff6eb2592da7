"""``contactrig surface FILE``: what a measured surface file holds and its roughness before and after conditioning.

Registered by ``contactrig.cli.main``. Nothing heavy is imported until the command runs.
"""

from __future__ import annotations

import argparse

__all__ = ["register"]

_KEYS = (
    ("--pixel-m", "pixel_m", float, "pixel size, m (overrides the file's; declares the pixels square)"),
    ("--height-unit-m", "height_unit_m", float, "metres per height unit (overrides the file's)"),
    ("--form", "form", str, "form removal: plane (default), cylinder (a bore the field resolves), polynomial"),
    ("--form-degree", "form_degree", int, "polynomial degree (2)"),
    ("--bore-axis", "bore_axis", str, "x (default: the bore's axis along the map's columns) or y"),
    ("--lambda-s-m", "lambda_s_m", float, "ISO 16610-61 S-filter nesting index, m (none)"),
    ("--lambda-c-m", "lambda_c_m", float, "ISO 16610-61 L-filter nesting index (cut-off), m (none)"),
    ("--max-missing-fraction", "max_missing_fraction", float, "most missing points allowed, a fraction < 1 (0.05)"),
)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``surface`` to ``subparsers``."""
    p = subparsers.add_parser(
        "surface",
        help="what a profilometer file holds; roughness before and after form removal and ISO 16610-61 filtering",
        description=(
            "Reads a height map or line profile (any format SurfaceTopography reads, or a plain-text grid) as a "
            "scene's [surfaces.*] kind = 'file' does, and prints the instrument, size, pixel, units, missing points "
            "and the ISO 25178-2 parameters with the mean plane only removed and after form removal and filtering, "
            "all of the measured points only (filled dropouts never count). Non-square pixels are resampled to "
            "square ones at the coarser pitch (said). The options are the scene keys of that table."
        ),
    )
    p.add_argument("file", help="height-map file")
    for flag, dest, kind, text in _KEYS:
        p.add_argument(flag, dest=dest, type=kind, default=None, help=text)
    p.add_argument("--plot", metavar="PNG", default=None, help="write the figure (map, profile, power spectrum)")
    p.add_argument("--force", action="store_true", help="replace an existing --plot file")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.set_defaults(handler=_surface)


def _surface(args: argparse.Namespace) -> int:
    from analysis.surface_summary import summarise
    from contactrig.core.files import check_new_file
    from contactrig.core.provenance import to_json
    from contactrig.core.text import escape_terminal

    if args.plot is not None:
        check_new_file(args.plot, force=args.force)
    table = {dest: getattr(args, dest) for _, dest, _, _ in _KEYS if getattr(args, dest) is not None}
    summary = summarise(args.file, table)
    if args.plot is not None:
        from analysis.surface_figure import draw_surface

        draw_surface(summary, args.plot, force=args.force)
    if args.json:
        from contactrig.cli.options import json_units

        units = json_units(
            Ssk="1", Sku="1", Sdq="1 (RMS slope)", eta_per_m2="1/m² (summits per area)",
            missing_fraction="1 (a fraction)", height_unit_m="m per unit of the file's heights",
        )  # fmt: skip
        print(to_json({"units": units, **summary.as_dict()}, indent=1))
    else:
        for line in summary.text().splitlines():
            print(escape_terminal(line))
        if args.plot is not None:
            print(f"figure: {escape_terminal(args.plot)}")
    return 0
