"""``contactrig`` subcommands of the ``analysis`` package (registered by ``contactrig.cli.main``).

``circuit`` (seed eq. 23–25 design calculator), ``fit`` (measured R(W) against every model's simulated A(W)),
``figures``, ``report`` and ``demo``. Nothing heavy is imported here: each handler imports what it needs.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from contactrig.cli.options import add_max_memory_option, add_models_option
from contactrig.cli.progress import add_quiet_option, progress_bar
from contactrig.core.text import escape_terminal

_TAB1 = "tab1"
_FOLDER = "created when missing; existing files are refused without --force"


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this package's subcommands to ``subparsers``."""
    c = subparsers.add_parser(
        "circuit",
        help="measuring-circuit design calculator (seed eq. 23-25): R_T, current, voltage across the contact",
        description="Seed eq. 23-25: R_T = ζh/A, I = U/(R_T + R_s + R_piston + R_liner + R_added), U_c = R_T·I. "
        "Defaults come from the scene's [circuit] table, or with --paper from the inputs that reproduce the "
        "paper's design example (about 120 mA and 13.4 nV); options override single values.",
    )
    src = c.add_mutually_exclusive_group()
    src.add_argument("--scene", help="scene TOML (default: the packaged default scene)")
    src.add_argument("--paper", action="store_true", help="start from the paper's design example (13.4 nV)")
    c.add_argument("--resistivity", type=float, metavar="OHM_M", help="ζ, resistivity [Ω·m]")
    c.add_argument("--height", type=float, metavar="M", help="h_R, electric contact height [m]")
    c.add_argument("--area", type=float, metavar="M2", help="A_R, contact area [m²]")
    c.add_argument("--voltage", type=float, metavar="V", help="U_R, source voltage [V]")
    c.add_argument("--added-resistance", type=float, metavar="OHM", help="R_P, added resistor [Ω]")
    c.add_argument("--series-resistance", type=float, metavar="OHM", help="R_s, leads and other contacts [Ω]")
    c.add_argument("--piston-resistance", type=float, metavar="OHM", help="piston body resistance [Ω]")
    c.add_argument("--liner-resistance", type=float, metavar="OHM", help="liner body resistance [Ω]")
    c.add_argument(
        "--current", type=float, metavar="A", help="drive with a current source (e.g. the 6221) instead of --voltage"
    )
    c.add_argument("--json", action="store_true", help="print JSON")
    c.set_defaults(handler=_circuit)

    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("session", metavar="SESSION.h5", help=f"session file, or '{_TAB1}' for the seed paper's Tab. 1")
    common.add_argument("--sim", metavar="SIM.h5", help="rig sweep file (default: simulate the session's scene now)")
    common.add_argument(
        "--database", metavar="DB.h5", default=None,
        help="contact database file from `contactrig database -o`: the rig (or press) is simulated now on it instead "
        "of building the database again; refused when made for other surfaces or materials (see --allow-mismatch)",
    )  # fmt: skip
    add_models_option(common, default="all in the sweep")
    add_max_memory_option(common)
    common.add_argument(
        "--conversion", choices=("bulk", "holm", "physical"), default="bulk",
        help="area → resistance: bulk = seed eq. 23 ζh/A (default), holm = Holm single spot ζ√π/(2√A), an upper "
        "bound on the clean-metal constriction, physical = R_s + σ_f/A + Barber + band constriction (the last two "
        "computed from the scene's resistivities; on a press, Holm's spot of the contact radius)",
    )  # fmt: skip
    common.add_argument(
        "--weighting", choices=("relative", "repeats", "pooled", "blocks"), default="relative",
        help="σ per weight: pooled relative SD × R̄/√n (default), each weight's own SEM (needs many repeats), "
        "pooled SD, or within-block SEM (single repeats)",
    )  # fmt: skip
    common.add_argument(
        "--interval", choices=("studentized", "percentile"), default="studentized",
        help="bootstrap interval: studentized bootstrap-t (default; holds 95%% with 6 series) or percentile",
    )  # fmt: skip
    common.add_argument("--bootstrap", type=int, default=2000, metavar="N", help="bootstrap resamples (0: none)")
    common.add_argument("--seed", type=int, default=0, help="bootstrap random seed")
    common.add_argument(
        "--allow-mismatch", action="store_true",
        help="compare even when the simulation's scene differs from the session's (refused otherwise; the "
        "override is recorded in the output)",
    )  # fmt: skip

    f = subparsers.add_parser(
        "fit",
        parents=[common],
        help="fit R = R_s + s·h/A(W) per model, rank the models, say whether the data discriminate",
    )
    f.add_argument("--json", action="store_true", help="print the fits as JSON")
    f.add_argument(
        "--no-record", dest="record", action="store_false",
        help="do not record the verdict beside the session (.contactrig-fits.jsonl; on a network share this "
        "computer's .contactrig-fits.HOST.jsonl; read by `contactrig sessions`)",
    )  # fmt: skip
    f.set_defaults(handler=_fit)

    g = subparsers.add_parser(
        "figures",
        parents=[common],
        help="draw every figure of the analysis.figures registry (PNG and a vector format)",
    )
    g.add_argument("-o", "--output", required=True, metavar="DIR", help=f"folder for the figures ({_FOLDER})")
    g.add_argument("--format", choices=("svg", "pdf"), default="svg", help="vector format written beside the PNG")
    g.add_argument("--force", action="store_true", help="overwrite existing figure files")
    g.set_defaults(handler=_figures)

    r = subparsers.add_parser(
        "report", parents=[common],
        help="Markdown and self-contained HTML report with tables, figures, provenance",
    )  # fmt: skip
    r.add_argument(
        "-o", "--output", required=True, metavar="DIR",
        help=f"folder for report.md, report.html and figures/ ({_FOLDER})",
    )  # fmt: skip
    r.add_argument("--force", action="store_true", help="overwrite an existing report and its figures")
    r.add_argument(
        "--compare-models", action=argparse.BooleanOptionalAction, default=None,
        help="ask the boundary-element reference which contact model it favours on the scene's surface "
        "(5–10 s on two cores, measured). Default: on when the simulation's surfaces are the scene's (its "
        "fingerprint records them and they match), off otherwise",
    )  # fmt: skip
    add_quiet_option(r)
    r.set_defaults(handler=_report)

    d = subparsers.add_parser(
        "demo",
        help="the main job in one command: simulate, acquire on the simulated bench, replay, fit, figures, report",
    )
    d.add_argument("-o", "--output", default="contactrig-demo", metavar="DIR", help=f"output folder ({_FOLDER})")
    d.add_argument("--bootstrap", type=int, default=2000, metavar="N", help="bootstrap resamples (0: none)")
    d.add_argument("--force", action="store_true", help="overwrite the files of an earlier demo in DIR")
    d.add_argument(
        "--compare-models", action=argparse.BooleanOptionalAction, default=True,
        help="ask the boundary-element reference which contact model it favours (default: on)",
    )  # fmt: skip
    add_quiet_option(d)
    add_max_memory_option(d)
    d.set_defaults(handler=_demo)


def _circuit(args: argparse.Namespace) -> int:
    from analysis.circuit import CircuitSettings, paper_design_example
    from contactrig.core.scene import load_scene

    base = paper_design_example() if args.paper else CircuitSettings.from_scene(load_scene(args.scene))
    settings = base.replace(
        resistivity_ohm_m=args.resistivity,
        contact_height_m=args.height,
        contact_area_m2=args.area,
        source_voltage_v=args.voltage,
        added_resistance_ohm=args.added_resistance,
        series_resistance_ohm=args.series_resistance,
        piston_resistance_ohm=args.piston_resistance,
        liner_resistance_ohm=args.liner_resistance,
    )
    d = settings.design(current_a=args.current)
    if args.json:
        from contactrig.cli.options import json_units

        print(json.dumps({"units": json_units(), "inputs": settings.__dict__, "result": d.as_dict()}, indent=2))
        return 0
    s = settings
    if args.current:
        drive = f"current source I = {d.current_a:g} A"
    else:
        drive = f"voltage source U_R = {s.source_voltage_v:g} V"
    print(f"inputs: ζ = {s.resistivity_ohm_m:g} Ω·m, h_R = {s.contact_height_m:g} m, A_R = {s.contact_area_m2:g} m², "
          f"{drive}")  # fmt: skip
    print(f"        R_added = {s.added_resistance_ohm:g} Ω, R_series = {s.series_resistance_ohm:g} Ω, "
          f"R_piston = {s.piston_resistance_ohm:g} Ω, R_liner = {s.liner_resistance_ohm:g} Ω")  # fmt: skip
    print(f"R_T  (eq. 23) = {d.contact_resistance_ohm:.4g} Ω")
    print(f"R_loop        = {d.loop_resistance_ohm:.6g} Ω")
    print(f"I    (eq. 24) = {d.current_a:.4g} A  ({d.current_a * 1e3:.4g} mA)")
    print(f"U_c  (eq. 25) = {d.contact_voltage_v:.4g} V  ({d.contact_voltage_v * 1e9:.4g} nV)")
    if args.current:
        print(f"source must supply U = {d.source_voltage_v:.4g} V (compliance)")
    for w in d.warnings:
        print(f"warning: {w}", file=sys.stderr)
    return 0


#: HDF5's format signature; it sits at byte 0 or, after a user block, at 512, 1024, 2048 … (the HDF5 spec).
_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: Tables of a contactrig scene (contactrig.core.scene); a TOML file holding any of them is a scene.
_SCENE_TABLES = ("scene", "materials", "surfaces", "database", "rig", "press", "circuit", "instrument", "delta",
                 "session")  # fmt: skip


def _is_hdf5(head: bytes) -> bool:
    offsets = [0] + [512 << k for k in range(12)]
    return any(head[o : o + len(_HDF5_SIGNATURE)] == _HDF5_SIGNATURE for o in offsets)


def _refuse_scene_file(path: str, command: str) -> None:
    """``fit``/``figures``/``report`` take a session file or ``tab1``: a TOML scene passed instead is named as such.

    Decided by the file's content, whatever its suffix: not HDF5 (no signature where HDF5 puts it) and TOML with
    scene tables. Anything else goes on to the session reader, which says what is wrong with it. Only regular files
    of scene size are read (a FIFO or a device is left to the reader, which refuses it unopened)."""
    import os
    import stat
    import tomllib

    from contactrig.core.inputs import SCENE_MAX_BYTES

    try:
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode) or st.st_size > SCENE_MAX_BYTES:
            return
        with open(path, "rb") as fh:
            head = fh.read(SCENE_MAX_BYTES)
    except OSError:
        return
    if _is_hdf5(head):
        return
    try:
        data = tomllib.loads(head.decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError):
        return
    if any(isinstance(data.get(name), dict) for name in _SCENE_TABLES):
        raise ValueError(
            f"{path} is a scene file (TOML), not a session: {command} takes SESSION.h5 (a session file) or "
            f"'{_TAB1}', with the scene given by the session (recorded in it) or --sim SIM.h5 (a simulation of it)"
        )


def _analysis(args: argparse.Namespace) -> Any:
    if args.session != _TAB1:
        _refuse_scene_file(args.session, args.command)  # before anything is read or simulated
    kw = {
        "conversion": args.conversion,
        "weighting": args.weighting,
        "n_boot": args.bootstrap,
        "seed": args.seed,
        "boot_interval": args.interval,
        "allow_mismatch": args.allow_mismatch,
        "database_path": args.database,
    }
    if args.session == _TAB1:
        from analysis.pipeline import analyse_tab1

        return analyse_tab1(sim_path=args.sim, models=args.models, **kw)
    from analysis.pipeline import analyse_session

    return analyse_session(args.session, args.sim, models=args.models, **kw)


def _fit(args: argparse.Namespace) -> int:
    a = _analysis(args)
    cmp = a.comparison
    if cmp is None:
        raise ValueError("; ".join(n for n in a.left_out if n.startswith("no fit")))
    if args.session != _TAB1 and args.record:
        _record_verdict(args.session, cmp)
    if args.json:
        from contactrig.cli.options import json_units

        d = {"units": json_units(scale="Ω·m (s of R = R_s + s·x(A))", R_series_se="Ω", scale_se="Ω·m"),
             **cmp.as_dict()}  # fmt: skip
        d["measured"] = {k: v for k, v in a.measured_info.items() if k in ("path", "kind", "complete", "status")}
        d["simulation"] = a.sim_info.get("source")
        d["warnings"] = list(a.warnings)
        d["left_out"] = list(a.left_out)
        d["scene_mismatch"] = {
            "differences": a.fingerprint.get("differences", []),
            "allowed": a.fingerprint.get("allowed"),
        }
        print(json.dumps(d, indent=2))
        _print_caveats(a)
        return 0
    if not a.measured_info.get("complete", True):
        print("INCOMPLETE SESSION: no stop record; analysing the blocks on disk", file=sys.stderr)
    _print_fit_table(a)
    print(escape_terminal(cmp.statement))
    _print_caveats(a)
    return 0


def _record_verdict(session: str, cmp: Any) -> None:
    """The fit's verdict beside the session, for the run index (:func:`daq.run_index.record_fit`: the folder's
    .contactrig-fits.jsonl); a folder that cannot take it is said on stderr, the fit stands."""
    from daq.run_index import record_fit

    statement = str(cmp.statement)
    verdict = statement[statement.rfind("Verdict:") :] if "Verdict:" in statement else statement
    try:
        record_fit(session, discriminates=bool(cmp.discriminates), best=str(cmp.ranking[0]), statement=verdict)
    except (OSError, ValueError) as exc:
        print(escape_terminal(f"note: the verdict was not recorded beside the session ({exc})"), file=sys.stderr)


def _print_fit_table(a: Any) -> None:
    from analysis.resistance import resistance_unit
    from sims.models import model_label

    cmp = a.comparison
    best = cmp.best
    boot = best.intervals.bootstrap
    k, unit = resistance_unit(best.points.measured_ohm)
    print(escape_terminal(f"{a.title}: {cmp.n_weights} weights × {cmp.n_repeats} independent repeats; simulation: "
                          f"{a.sim_info.get('source')}"))  # fmt: skip
    print(f"R = R_s + s·x(A), conversion {a.conversion}, weighting {best.weighting}, "
          f"{boot.n_boot} bootstrap resamples ({boot.resampling})")  # fmt: skip
    r_head, rmse_head = f"R_s [{unit}]", f"RMSE [{unit}]"
    d_head = "Δ" + cmp.criterion
    s_head = "s [Ω·m²]" if best.estimate.scale_units == "ohm*m2" else "s [Ω·m]"
    print(f"{'model':<20} {r_head:>18} {s_head:>22} {'χ²/dof':>8} {'AIC':>8} {d_head:>7} {rmse_head:>10}")
    for name in cmp.ranking:
        f = cmp.fits[name]
        e, g = f.estimate, f.goodness
        print(
            f"{escape_terminal(model_label(name)):<20} {e.R_series_ohm * k:>9.4g} ± {e.R_series_se * k:<6.2g}"
            f" {e.scale:>12.4g} ± {e.scale_se:<7.2g} {g.reduced_chi2:>8.3g} {g.aic:>8.5g}"
            f" {cmp.delta_aic[name]:>7.3g} {g.rmse_ohm * k:>10.3g}" + ("" if f.physical else "  UNPHYSICAL")
        )
    if any(cmp.delta_aic[n] == 0 for n in cmp.ranking[1:]):
        print(f"{d_head} = 0: a tie (the criteria agree within {cmp.tie_tolerance:g} of their size: round-off)")
    t_ci, b_ci = best.intervals.t.R_series_ohm, boot.R_series_ohm
    boot_text = f"[{b_ci[0] * k:.3g}, {b_ci[1] * k:.3g}] {unit}" if boot.available else boot.note
    label = escape_terminal(model_label(best.model))
    print(f"{label}: R_s {round(best.intervals.level * 100)}% t-interval [{t_ci[0] * k:.3g}, "
          f"{t_ci[1] * k:.3g}] {unit}, {boot.method} bootstrap {boot_text}; "
          f"goodness of fit against {best.goodness.reference}")  # fmt: skip
    print(escape_terminal(f"errors: {best.estimate.error_rule}"))
    if a.conversion == "physical":
        _print_shares(best)
    for note in cmp.series_notes:
        print(escape_terminal(f"series: {note}"))


def _print_shares(fit: Any) -> None:
    """Each term's share of the measured mean per weight (the physical model's terms), for the best model."""
    from sims.models import model_label

    names = list(fit.shares)
    print(escape_terminal(f"{model_label(fit.model)}: share of the measured mean R per weight [%] (residual: "
                          "measured − fitted, the part no term explains; each row adds up to 100 %)"))  # fmt: skip
    print(f"{'weight [kg]':>11} " + " ".join(f"{n:>9}" for n in names))
    for i, w in enumerate(fit.points.weight_kg):
        print(f"{w:11g} " + " ".join(f"{100 * float(fit.shares[n][i]):9.2f}" for n in names))


def _print_caveats(a: Any) -> None:
    """Everything that qualifies the result, on stderr: data notes, what was left out, model-validity warnings,
    unphysical fits, an allowed scene mismatch (text from files with its control characters made visible)."""
    lines = [f"note: {w}" for w in a.measured_info.get("warnings", [])]
    lines += [f"left out: {n}" for n in a.left_out]
    lines += [f"warning: {w}" for w in a.warnings]
    if a.comparison is not None:
        from sims.models import model_label

        for name in a.comparison.ranking:
            lines += [
                f"warning: {model_label(name)} fit is UNPHYSICAL: {why}" for why in a.comparison.fits[name].unphysical
            ]
    if a.fingerprint.get("allowed"):
        lines.append(
            "warning: scene mismatch allowed (--allow-mismatch): " + "; ".join(a.fingerprint.get("differences", []))
        )
    for line in lines:
        print(escape_terminal(line), file=sys.stderr)


def _figures(args: argparse.Namespace) -> int:
    from analysis.figures import figure_specs, planned_figures, write_figures
    from contactrig.core.files import output_folder, refuse_existing

    formats = ("png", args.format)
    refuse_existing(planned_figures(output_folder(args.output), "", formats), force=args.force)  # before any work
    a = _analysis(args)
    written = write_figures(a, args.output, formats=formats, force=args.force)
    for spec in figure_specs():
        if spec.key in written:
            print(escape_terminal(f"{spec.key}: " + ", ".join(str(p) for p in written[spec.key])))
        else:
            print(f"{spec.key}: not drawn ({spec.missing or 'no data for it in this analysis'})", file=sys.stderr)
    _print_caveats(a)
    return 0


def _report(args: argparse.Namespace) -> int:
    from analysis.pipeline import compare_models_by_default, rank_against_bem, with_report_extras
    from analysis.report import report_outputs, write_report
    from contactrig.core.files import output_folder, refuse_existing

    out = output_folder(args.output)
    refuse_existing(report_outputs(out, [])[:2], force=args.force)  # report.md, report.html: before any work
    a = _analysis(args)
    compare, why_not = compare_models_by_default(a) if args.compare_models is None else (args.compare_models, "")
    ranking = None
    if compare:
        with progress_bar("report: BEM reference", quiet=args.quiet) as progress:
            ranking = rank_against_bem(a.scene, list(a.areas_m2), progress=progress)
    note = "" if compare else (why_not or "not run (--no-compare-models)")
    a = with_report_extras(a, ranking=ranking, ranking_note=note)
    path = write_report([a], out, force=args.force)
    if not a.measured_info.get("complete", True):
        print("INCOMPLETE SESSION: the report says so at the top", file=sys.stderr)
    _print_caveats(a)
    if ranking is not None:
        from analysis.compare_models import favoured

        print(escape_terminal(favoured(ranking)))
    print(escape_terminal(f"report: {path} and {path.with_suffix('.html')}"))
    return 0


def _demo(args: argparse.Namespace) -> int:
    from analysis.demo import run_demo

    with progress_bar("demo: BEM reference", quiet=args.quiet) as progress:
        result = run_demo(args.output, n_boot=args.bootstrap, stream=sys.stdout, force=args.force,
                          compare=args.compare_models, progress=progress)  # fmt: skip
    print(escape_terminal(f"report: {result.report} and {result.report.with_suffix('.html')}"))
    return 0
