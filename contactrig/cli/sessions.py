"""``contactrig acquire``, ``replay`` and ``import``: a thin layer over daq functions.

Nothing heavy is imported at module level: h5py, pyvisa and pandas load only when a command runs.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any

from contactrig.cli.options import add_max_memory_option


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this package's subcommands to ``subparsers``."""
    acq = subparsers.add_parser(
        "acquire",
        help="run a bench session: Delta-mode resistance for each weight, written to HDF5 block by block",
        description=(
            "Run the session plan of SCENE ([instrument], [delta], [session]; default: the packaged scene). For "
            "each weight the operator is asked to place it (Enter go on, s skip, q stop) unless --yes. Every block "
            "is on disk before the next starts. Ctrl-C once stops after the current block, twice stops now; the "
            "source is always left idle and the stop record written. Exit 0 when the plan is done, 1 when stopped "
            "early (the file is kept; --resume continues it), 2 on an error."
        ),
    )
    acq.add_argument("scene", nargs="?", default=None, help="scene TOML (default: the packaged scene)")
    acq.add_argument("-o", "--output", required=True, help="session file to write (HDF5, .h5)")
    acq.add_argument("--sim", action="store_true", help="use the simulated bench driven by the rig simulation")
    acq.add_argument("--yes", action="store_true", help="unattended: do not ask the operator to place weights")
    acq.add_argument(
        "--sim-speed",
        type=_speed,
        default=None,
        metavar="X",
        help="simulated instrument time runs X times faster than real (1 = real pace, inf = no waiting; default 1000)",
    )
    acq.add_argument("--resume", action="store_true", help="continue an incomplete session file where it stopped")
    acq.add_argument("--force", action="store_true", help="overwrite an existing output file")
    acq.add_argument(
        "--live", nargs="?", const="", default=None, metavar="PNG",
        help="show the live view (as `contactrig watch`) in a window, or rewrite the snapshot PNG (headless); a "
        "failure of the view is reported once and turns it off, the acquisition goes on",
    )  # fmt: skip
    acq.add_argument(
        "--quiet", action="store_true",
        help="no plan, no progress bar or block lines and no notes on stderr (the prompts, errors and the final line "
        "stay; what the notes say is in the start record)",
    )  # fmt: skip
    acq.add_argument(
        "--adaptive", action="store_true",
        help="choose each next placement as the session goes (the largest expected gain in evidence per minute), "
        "show the evidence after each block and stop when decisive or futile (issue 27; see Bench day)",
    )  # fmt: skip
    acq.add_argument(
        "--budget-min", type=float, default=None, metavar="MIN",
        help="--adaptive: bench time allowed, in minutes (default 60); futile when P(decisive within it) < 5 %%",
    )  # fmt: skip
    acq.add_argument(
        "--noise-from", default=None, metavar="SESSION.h5",
        help="--adaptive: the prior noise estimated from an earlier session of this bench, as `design --noise-from` "
        "does (default: Tab. 1's, or the simulated bench's with --sim); recorded with the file's name and content id",
    )  # fmt: skip
    _add_override_options(acq)
    add_max_memory_option(acq)  # --sim: the rig simulation behind the simulated bench
    acq.set_defaults(handler=acquire_command)

    rep = subparsers.add_parser(
        "replay",
        help="re-run a recorded session through the acquisition code against its recorded instrument replies",
        description=(
            "Replay SESSION through the same acquisition code path with the recorded instrument replies and check "
            "that every block's summary and readings come out identical. Exit 0 if identical; 2 if not, with one "
            "line on stderr saying what differs (the one contract: 0 done, 1 stopped early, 2 error)."
        ),
    )
    rep.add_argument("session", help="session file (HDF5)")
    rep.add_argument("--pace", action="store_true", help="replay at the recorded pace instead of at once")
    rep.add_argument("--json", action="store_true", help='print {"identical": true|false, ...} as JSON')
    rep.set_defaults(handler=replay_command)

    imp = subparsers.add_parser(
        "import",
        help="convert a table of resistance per weight (like the seed paper's Tab. 1) into a session file",
        description=(
            "TABLE is CSV with a header row: first the weight column (weight_kg, weight_g, load_N or weight [kg]; "
            "load_N is divided by g = 9.80665 m/s²; no unit = kg), then one column per repeat (M1, M2, …). A repeat "
            "header may carry its unit (M1_mohm, R [mΩ], R_ohm, R_uohm); otherwise --unit gives it; a header unit "
            "that differs from --unit is an error. ',' ';' or tab separators and decimal commas (with ';'/tab) are "
            "detected. Refused with a one-line error naming the file, row and column: non-numbers, NaN/inf, values "
            "<= 0, empty cells, duplicate columns or weights, average columns, weights outside [0, 10000] kg, "
            "resistances outside [10 nΩ, 1 Ω]. `contactrig import --tab1` imports the seed paper's Tab. 1 (mΩ)."
        ),
    )
    imp.add_argument("table", nargs="?", default=None, help="CSV table (omit with --tab1)")
    imp.add_argument("--tab1", action="store_true", help="import the seed paper's Tab. 1 (shipped, in mohm)")
    imp.add_argument(
        "--unit", choices=("ohm", "mohm", "uohm"), default=None,
        help="unit of repeat columns whose header names none (required unless every header has one)",
    )  # fmt: skip
    imp.add_argument(
        "--delimiter", choices=(",", ";", "tab", "comma", "semicolon"), default=None, metavar="SEP",
        help="column separator: ',' (comma), ';' (semicolon) or tab (default: detected from the header row)",
    )  # fmt: skip
    imp.add_argument(
        "--decimal", choices=(".", ","), default=None, metavar="MARK",
        help="decimal mark: '.' or ',' (default: detected; ',' only with ';' or tab separators)",
    )  # fmt: skip
    imp.add_argument(
        "--allow-missing", action="store_true",
        help="read an empty repeat cell as a missing repeat (no block) instead of refusing it",
    )  # fmt: skip
    imp.add_argument("-o", "--output", required=True, help="session file to write (HDF5)")
    imp.add_argument("--force", action="store_true", help="overwrite an existing output file")
    imp.add_argument(
        "--operator", default="",
        help="who measured the table (recorded as its operator; default: the one an exported table names, else "
        "unknown — the login name is recorded as imported_by, not as the operator; --tab1: measured by the seed "
        "paper's authors, recorded as measured_by)",
    )  # fmt: skip
    imp.set_defaults(handler=import_command)


def _add_override_options(parser: argparse.ArgumentParser) -> None:
    """The scene keys a run may override (daq.overrides.OVERRIDES), one option each, and --allow-change."""
    from contactrig.core.validation import scene_key
    from daq.overrides import OVERRIDES

    group = parser.add_argument_group(
        "overrides of the scene for this run",
        "validated as the scene key; recorded in the start record apart from the scene text (see `scene show`); "
        "kept by --resume, where a different value is stated and recorded (a different sample or sim seed is "
        "refused unless --allow-change)",
    )
    for o in OVERRIDES:
        group.add_argument(o.option, default=None, help=f"{o.help} (overrides {scene_key(o.key)})")
    group.add_argument(
        "--allow-change", action="store_true", help="--resume: accept (and record) a different sample or sim seed"
    )


def _speed(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--sim-speed = {text!r}: expected a number > 0 or inf") from None
    if not (x > 0) or math.isnan(x):
        raise argparse.ArgumentTypeError(f"--sim-speed = {text!r}: expected a number > 0 (1 = real pace) or inf")
    return x


def acquire_command(args: argparse.Namespace) -> int:
    from analysis.simulated_session import DEFAULT_SIM_SPEED, SimulatedRigBench
    from contactrig.core.text import escape_terminal as safe
    from daq.acquire import acquire
    from daq.link import VisaBench
    from daq.overrides import overrides_by_option

    if args.sim_speed is not None and not args.sim:
        raise ValueError("--sim-speed only applies to --sim")
    if args.resume and args.force:
        raise ValueError("--resume and --force contradict each other: --resume keeps the file, --force replaces it")
    if args.allow_change and not args.resume:
        raise ValueError("--allow-change only applies to --resume")
    speed = args.sim_speed if args.sim_speed is not None else DEFAULT_SIM_SPEED
    bench = SimulatedRigBench(speed) if args.sim else VisaBench()
    adaptive = _adaptive(args)
    live = _live_view(args)
    result = acquire(
        args.scene, args.output, bench=bench, yes=args.yes, resume=args.resume, force=args.force, extra_writers=live,
        overrides=overrides_by_option(vars(args)), allow_change=args.allow_change, quiet=args.quiet,
        adaptive=adaptive,
    )  # fmt: skip
    print(
        f"{safe(result.path)}: {result.status}, {result.blocks_done} of {result.blocks_planned} blocks — "
        f"{safe(result.reason)}",
        file=sys.stderr,
    )
    if result.status == "success":
        return 0
    return 1 if result.status == "aborted" else 2  # aborted: stopped early (Ctrl-C, q); failed: an error


def _adaptive(args: argparse.Namespace) -> Any:
    """``--adaptive [--budget-min N]``: the steps chosen as the session goes (analysis.adaptive_session)."""
    if args.budget_min is not None and not args.adaptive:
        raise ValueError("--budget-min only applies to --adaptive")
    if args.noise_from is not None and not args.adaptive:
        raise ValueError(f"--noise-from {args.noise_from!r}: only applies to --adaptive (its prior noise)")
    if not args.adaptive:
        return None
    if args.resume:
        prior = f" (--noise-from {args.noise_from!r}: its prior cannot change either)" if args.noise_from else ""
        raise ValueError(f"--adaptive does not resume a session: start a new one (without --resume){prior}")
    from analysis.adaptive_session import DEFAULT_BUDGET_MIN, adaptive_source, terminal_chooser

    budget = DEFAULT_BUDGET_MIN if args.budget_min is None else args.budget_min
    return adaptive_source(budget, simulated=args.sim, choose=None if args.yes else terminal_chooser(),
                           noise_from=args.noise_from)  # fmt: skip


def _live_view(args: argparse.Namespace) -> list:
    """``--live [PNG]``: the live view as one more writer, guarded (its failures never reach the acquisition)."""
    if args.live is None:
        return []
    from analysis.watch import Guarded, LiveView

    png = args.live or None
    return [Guarded(LiveView(png, every=1.0, name=str(args.output), force=args.force))]


def replay_command(args: argparse.Namespace) -> int:
    from contactrig.core.text import escape_terminal as safe
    from daq.replay import replay_session

    report = replay_session(args.session, pace=args.pace)
    report = _replay_suggestions(args.session, report)
    if args.json:
        from contactrig.cli.options import json_units

        print(json.dumps({"units": json_units(), **report.as_dict()}, indent=2))  # JSON escapes control characters
    else:
        verdict = "identical" if report.identical else "DIFFERENT"
        print(
            f"{safe(report.path)}: replayed {report.blocks_replayed} of {report.blocks_recorded} blocks "
            f"({report.readings_replayed} readings, {report.runs} run(s)) in {report.elapsed_s:.3f} s: {verdict}"
        )
        for line in report.notes:
            print(f"  note: {safe(line)}")
        for line in report.differences:
            print(f"  difference: {safe(line)}")
    if report.identical:
        return 0
    print(f"contactrig replay: error: {safe(report.verdict())}", file=sys.stderr)
    return 2  # a replay that does not reproduce the recording is an error, not a run stopped early


def _replay_suggestions(path: str, report: Any) -> Any:
    """An adaptive session: its suggestions rebuilt from the recorded blocks and compared with the recorded ones
    (analysis.adaptive_session.replay_suggestions); the result is one more note, or a difference."""
    import dataclasses

    from daq import load_session

    if not isinstance(load_session(path).start.get("adaptive"), dict):
        return report
    from analysis.adaptive_session import replay_suggestions

    same, text = replay_suggestions(path)
    if same:
        return dataclasses.replace(report, notes=(*report.notes, f"adaptive: {text}"))
    return dataclasses.replace(report, differences=(*report.differences, f"adaptive: {text}"), identical=False)


def import_command(args: argparse.Namespace) -> int:
    from contactrig.core.text import escape_terminal as safe
    from daq.table_import import TAB1_MEASURED_BY, import_table, read_table, tab1_path

    measured_by = ""
    if args.tab1:
        if args.table is not None:
            raise ValueError("give either TABLE or --tab1, not both")
        if args.unit not in (None, "mohm"):
            raise ValueError("Tab. 1 is in mΩ: leave out --unit or use --unit mohm")
        table, unit, measured_by = tab1_path(), "mohm", TAB1_MEASURED_BY
    else:
        if args.table is None:
            raise ValueError("give a TABLE (CSV) to import, or --tab1 for the seed paper's Tab. 1")
        table, unit = args.table, args.unit
    options = {"delimiter": args.delimiter, "decimal": args.decimal, "allow_missing": args.allow_missing}
    read = read_table(table, unit, **options)  # every error before the output file is created
    out = import_table(table, args.output, unit=unit, force=args.force, operator=args.operator,
                       measured_by=measured_by, **options)  # fmt: skip
    for note in read.notes:
        print(f"note: {safe(note)}", file=sys.stderr)
    missing = int((read.resistance_ohm != read.resistance_ohm).sum())  # NaN: a missing repeat
    gaps = f", {missing} missing repeat(s)" if missing else ""
    print(
        f"{safe(out)}: imported {safe(table)}: {read.weight_kg.size} weights × {len(read.columns)} repeats "
        f"({read.unit}{gaps})",
        file=sys.stderr,
    )
    return 0
