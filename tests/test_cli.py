"""The dispatcher: help works, imports stay light."""

import subprocess
import sys

from contactrig.cli.main import build_parser, main


def test_help_lists_subcommands(capsys):
    parser = build_parser()
    text = parser.format_help()
    assert "contactrig" in text


def test_no_command_prints_help_and_fails(capsys):
    assert main([]) == 2


def test_sims_and_analysis_import_without_pyvisa_or_matplotlib():
    code = (
        "import sys, sims, analysis, contactrig.core.scene, contactrig.core.validation, contactrig.cli.main;"
        "contactrig.cli.main.build_parser();"
        "bad = [m for m in ('pyvisa', 'matplotlib', 'pyvisa_sim') if m in sys.modules];"
        "print(bad); sys.exit(1 if bad else 0)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr


def test_report_demo_bench_and_simulate_offer_the_new_options(capsys):

    for argv, options in (
        (["report", "--help"], ("--compare-models", "--no-compare-models", "report.html")),
        (["demo", "--help"], ("--compare-models", "--no-compare-models")),
        (["bench", "--help"], ("--force",)),
        (["simulate", "--help"], ("--elastic",)),
    ):
        assert main(argv) == 0
        text = " ".join(capsys.readouterr().out.split())
        for option in options:
            assert option in text, (argv, option)
