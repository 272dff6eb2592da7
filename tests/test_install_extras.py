"""Issue 20 item 9: a documented command works after the install the README gives for it, or its error names the
one ``pip install`` that fixes it; which extras are in the base install is decided in pyproject, with a reason."""

from __future__ import annotations

import re
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
PROJECT = tomllib.loads(PYPROJECT)["project"]
EXTRAS = PROJECT["optional-dependencies"]


def _name(requirement: str) -> str:
    return re.split(r"[<>=\[;! ]", requirement, maxsplit=1)[0].lower()


BASE = {_name(r) for r in PROJECT["dependencies"]}
ANY = BASE | {_name(r) for reqs in EXTRAS.values() for r in reqs}


@pytest.mark.parametrize("package", ["pyvisa-py", "openpyxl"])
def test_base_install_holds_the_visa_backend_and_openpyxl_with_a_reason(package):
    assert package in BASE
    lines = PYPROJECT.splitlines()
    at = next(i for i, ln in enumerate(lines) if ln.strip().startswith(f'"{package}'))
    assert lines[at - 1].lstrip().startswith("#")  # the comment just above says why
    reason = " ".join(ln for ln in lines[max(0, at - 5) : at] if ln.lstrip().startswith("#"))
    assert "Base, not an extra" in reason


def _pip_installs() -> list[tuple[str, str]]:
    """(file, what) of every ``pip install X`` a message or the README tells a user to run."""
    out = []
    files = [ROOT / "README.md", *(p for d in ("contactrig", "instruments", "daq", "sims", "analysis")
                                   for p in (ROOT / d).rglob("*.py")),
             *(ROOT / "contactrig" / "docs").rglob("*.md")]  # fmt: skip  (the manual holds the README's details)
    for path in files:
        for m in re.finditer(r"pip install (?:-e )?['\"]?([A-Za-z0-9_.\-]+(?:\[[^\]]*\])?)", path.read_text("utf-8")):
            out.append((path.name, m.group(1)))
    return out


def test_every_pip_install_named_exists():
    seen = _pip_installs()
    assert seen
    for where, what in seen:
        if what.startswith((".", "contactrig")):
            extras = re.findall(r"\[([^\]]*)\]", what)
            for extra in (e.strip() for group in extras for e in group.split(",")):
                assert EXTRAS.get(extra), f"{where}: pip install {what}: no such (non-empty) extra"
        else:
            assert _name(what) in ANY, f"{where}: pip install {what}: not a dependency in pyproject"


def test_optional_dask_names_its_pip_install(monkeypatch):
    from sims.ensemble import _run_dask

    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(ValueError, match=r"pip install 'contactrig\[dask\]'"):
        _run_dask(lambda t: t, [], "tcp://127.0.0.1:1", 1.0)


def test_base_install_opens_the_simulated_socket_bench_and_writes_xlsx():
    import importlib

    importlib.import_module("pyvisa_py")  # the @py backend the LAN path and serve-sim use
    importlib.import_module("openpyxl")  # export --to xlsx
