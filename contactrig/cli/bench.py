"""``contactrig bench``: error against run time for every numerical method, and the stability atlas."""

from __future__ import annotations

import argparse


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``bench`` to ``subparsers``."""
    p = subparsers.add_parser(
        "bench",
        help="error against run time of the numerical methods, and the stability atlas",
        description="Run the error-against-run-time studies and the stability atlas; print a table, and with -o "
        "write log-log figures and a Markdown report. --quick took 27 s on two cores (measured).",
    )
    p.add_argument("--quick", action="store_true", help="smaller sizes (27 s on two cores, measured; what CI runs)")
    p.add_argument("--json", action="store_true", help='print {"rows": [...], "atlas": [...]} as JSON')
    p.add_argument(
        "-o", "--output", metavar="DIR",
        help="write figures and report.md into DIR (created when missing; existing files are refused without --force)",
    )  # fmt: skip
    p.add_argument("--force", action="store_true", help="overwrite the figures and report.md of an earlier run in DIR")
    p.add_argument(
        "--study",
        action="append",
        metavar="NAME",
        help="run only this study (repeatable); default all. --study none runs only the atlas",
    )
    p.add_argument("--no-atlas", action="store_true", help="skip the stability atlas")
    p.set_defaults(handler=_bench)


def _bench(args: argparse.Namespace) -> int:
    import json

    from analysis.studies.report import format_atlas, format_rows, report_files, write_report
    from analysis.studies.rows import run, study_names
    from contactrig.core.files import output_folder, refuse_existing

    names = study_names() if not args.study else [s for s in args.study if s != "none"]
    if args.output:  # refused before any study runs
        refuse_existing(report_files(output_folder(args.output), names), force=args.force)
    rows = run(names, quick=args.quick)
    outcomes = []
    if not args.no_atlas:
        from analysis.studies.atlas import run_atlas

        outcomes = run_atlas()
    if args.json:
        from contactrig.cli.options import json_units

        print(json.dumps({"units": json_units(), "rows": [r.as_dict() for r in rows],
                          "atlas": [o.as_dict() for o in outcomes]}, indent=1))  # fmt: skip
    else:
        print(format_rows(rows))
        if outcomes:
            print()
            print(format_atlas(outcomes))
    if args.output:
        path = write_report(rows, outcomes, args.output, studies=names, quick=args.quick, force=args.force)
        if not args.json:
            print(f"\nreport written to {path}")
    failed = [o for o in outcomes if not o.ok]
    return 1 if failed else 0
