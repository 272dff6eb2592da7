"""The analysis modules import without pyvisa, h5py or matplotlib (those load only when used)."""

import subprocess
import sys


def test_analysis_modules_are_light():
    code = (
        "import sys\n"
        "import analysis.commands, analysis.resistance, analysis.circuit, analysis.measured, analysis.normalisation\n"
        "import analysis.fit, analysis.figures, analysis.report, analysis.pipeline, analysis.demo\n"
        "bad = [m for m in ('pyvisa', 'h5py', 'matplotlib') if m in sys.modules]\n"
        "print(bad); sys.exit(1 if bad else 0)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
