"""mypy is part of the test suite: every package type-checks with zero errors (config in pyproject.toml)."""

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_mypy_clean():
    exe = shutil.which("mypy") or str(Path(sys.executable).parent / "mypy")
    if not Path(exe).exists() and shutil.which("mypy") is None:
        pytest.skip("mypy is not installed (install the 'test' extra)")
    out = subprocess.run([exe, "--no-error-summary"], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stdout + out.stderr
