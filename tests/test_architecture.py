"""The layering written in README.md ("Architecture") holds: every import of every module obeys it.

The rules are written once, in the README block after ``<!-- architecture:rules -->``; this test parses that block
and every module's imports (AST, including imports inside functions and under ``TYPE_CHECKING``) and fails on a
forbidden edge, naming the module, the line and the rule.
"""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("contactrig", "instruments", "sims", "daq", "analysis")


def _rules() -> dict[str, tuple[set[str], set[str]]]:
    """layer → (layers it may import, outside packages it must not import), from the README block."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = text.split("<!-- architecture:rules -->", 1)[1].split("```", 2)[1]
    rules: dict[str, tuple[set[str], set[str]]] = {}
    for line in block.splitlines():
        m = re.match(r"^\s*([\w.]+)\s+may import\s+(.*?)\s*(?:;\s*never\s+(.*))?$", line)
        if m:
            allowed = {x.strip() for x in m.group(2).split(",") if x.strip() and x.strip() != "nothing of ours"}
            banned = {x.strip() for x in (m.group(3) or "").split(",") if x.strip()}
            rules[m.group(1)] = (allowed, banned)
    return rules


RULES = _rules()
LAYERS = sorted(RULES, key=len, reverse=True)  # "contactrig.core" before "contactrig"


def _layer(module: str) -> str | None:
    for layer in LAYERS:
        if module == layer or module.startswith(layer + "."):
            return layer
    return None


def _modules() -> list[tuple[str, Path]]:
    out = []
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            rel = path.relative_to(ROOT).with_suffix("")
            parts = list(rel.parts)
            if parts[-1] == "__init__":
                parts.pop()
            out.append((".".join(parts), path))
    return out


def _imports(module: str, path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative import: resolve against this module's package
                base = module.split(".")[: -node.level] if path.name != "__init__.py" else module.split(".")
                if path.name == "__init__.py" and node.level > 1:
                    base = base[: -(node.level - 1)]
                target = ".".join([*base, node.module] if node.module else base)
            else:
                target = node.module or ""
            found.append((node.lineno, target))
            # ``from sims import rig`` imports the module sims.rig
            found += [(node.lineno, f"{target}.{a.name}") for a in node.names if _layer(f"{target}.{a.name}")]
    return found


def test_rules_are_written_down():
    assert {"contactrig.core", "instruments", "sims", "daq", "analysis", "contactrig.cli"} <= set(RULES), RULES
    for layer, (allowed, _) in RULES.items():
        assert allowed <= set(RULES), f"{layer}: unknown layer in {allowed}"


def test_every_module_belongs_to_a_layer():
    stray = [m for m, _ in _modules() if _layer(m) is None and m != "contactrig" and m != "contactrig.__main__"]
    assert not stray, f"modules outside every layer of README 'Architecture': {stray}"


def _violations() -> list[str]:
    bad = []
    for module, path in _modules():
        layer = _layer(module)
        if layer is None:
            continue
        allowed, banned = RULES[layer]
        for lineno, target in _imports(module, path):
            top = target.split(".")[0]
            other = _layer(target)
            where = f"{path.relative_to(ROOT)}:{lineno}"
            if other is not None and other != layer and other not in allowed:
                bad.append(f"{where}: {layer} imports {target} ({other} is not among {sorted(allowed)})")
            if top in banned:
                bad.append(f"{where}: {layer} imports {target} (never {top})")
    return bad


def test_no_forbidden_import_edge():
    bad = _violations()
    assert not bad, "forbidden imports (README 'Architecture'):\n" + "\n".join(bad)


def test_no_two_layers_import_each_other():
    for a, (allowed_a, _) in RULES.items():
        for b in allowed_a:
            assert a not in RULES[b][0], f"{a} and {b} may import each other: the rules have a cycle"


def test_the_checker_catches_a_forbidden_edge(tmp_path, monkeypatch):
    """The check itself can fail: a physics module importing the session layer is reported."""
    fake = tmp_path / "sims" / "bad.py"
    fake.parent.mkdir()
    fake.write_text("from daq.session_file import load_session\nimport h5py\n", encoding="utf-8")
    imports = _imports("sims.bad", fake)
    allowed, banned = RULES["sims"]
    assert any(_layer(t) == "daq" and "daq" not in allowed for _, t in imports)
    assert any(t.split(".")[0] in banned for _, t in imports)


@pytest.mark.parametrize("package", ["sims", "analysis", "contactrig.core"])
def test_light_packages_import_without_heavy_libraries(package):
    """Importing every module of a package loads none of its banned libraries (beyond what the AST shows)."""
    import subprocess

    _, banned = RULES[package]
    heavy = sorted(banned | {"pyvisa", "matplotlib"}) if package != "contactrig.core" else sorted(banned)
    mods = [m for m, _ in _modules() if _layer(m) == package]
    code = (
        "import importlib, sys\n"
        f"for m in {mods!r}: importlib.import_module(m)\n"
        f"print(sorted(set({heavy!r}) & set(sys.modules)))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]", f"{package} loads {out.stdout.strip()} on import"
