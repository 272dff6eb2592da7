"""The analysis modules import without pyvisa, h5py or matplotlib (those load only when used)."""

import subprocess
import sys


def test_analysis_modules_are_light():
    code = (
        "import sys\n"
        "import contactrig.cli.analysis, analysis.resistance, analysis.circuit\n"
        "import analysis.measured, analysis.normalisation\n"
        "import analysis.fit, analysis.figures, analysis.report, analysis.pipeline, analysis.demo\n"
        "bad = [m for m in ('pyvisa', 'h5py', 'matplotlib') if m in sys.modules]\n"
        "print(bad); sys.exit(1 if bad else 0)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr


def test_commands_without_figures_import_neither_matplotlib_nor_pyvisa(tmp_path):
    from tests.analysis.test_commands import _sweep_file

    sim = _sweep_file(tmp_path / "sim.h5", __import__("numpy").array([5.0, 10.0, 20.0, 30.0]))
    code = (
        "import sys, io, contextlib\n"
        "from contactrig.cli.main import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    rcs = [main(['circuit']), main(['fit', 'tab1', '--sim', sys.argv[1], '--json', '--bootstrap', '50'])]\n"
        "bad = [m for m in ('pyvisa', 'matplotlib') if m in sys.modules]\n"
        "print(rcs, bad); sys.exit(1 if bad or any(rcs) else 0)\n"
    )
    out = subprocess.run([sys.executable, "-c", code, str(sim)], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
