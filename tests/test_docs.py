"""The manual (``contactrig/docs``, MkDocs) and the README stay true to the code.

* The site builds with ``mkdocs build --strict``: a broken link or anchor, a page missing from the navigation or an
  API object that no longer exists fails (skipped only when the ``docs`` extra is not installed).
* Every ``contactrig …`` command written in a code block or in inline code of the manual or the README names a real
  subcommand and real options of the parser ``contactrig.cli.main.build_parser`` builds, and a value given to an
  option with fixed choices is one of them; every inline ``--option`` is an option of some command.
* Every Python block runs (a page's blocks in order, in one namespace, in an empty folder); one marked
  ``{.python .no-run}`` (hardware, long runs) is only compiled.
* Every scene key the readers accept is documented on the Scenes page and every documented key is accepted; every
  public module has an API entry; every command is in the README's map; the README stays a front page.

The expectations come from the code (the parser, the readers' key lists, the package tree), never from the docs.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import os
import pkgutil
import re
import subprocess
import sys
from collections.abc import Iterator
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "contactrig" / "docs"
README = ROOT / "README.md"
API_PACKAGES = ("contactrig.core", "instruments", "sims", "daq", "analysis")


def _pages() -> list[Path]:
    return sorted(DOCS.rglob("*.md"))


def _texts() -> list[Path]:
    """Everything a reader of the manual reads: the README, the pages, and sims/MODELS.md (the Contact models page)."""
    return [README, ROOT / "sims" / "MODELS.md", *_pages()]


# ---- Markdown: fenced blocks and inline code ------------------------------------------------------------------

_FENCE = re.compile(r"^(?P<indent>\s*)(?P<fence>`{3,})(?P<info>[^`]*)$")


@dataclasses.dataclass(frozen=True)
class Block:
    """A fenced code block: its info string (``python``, ``{.python .no-run}``, ``sh``, …), code and first line."""

    path: Path
    line: int
    info: str
    code: str

    @property
    def classes(self) -> set[str]:
        info = self.info.strip()
        if info.startswith("{"):
            return {c.lstrip(".") for c in info.strip("{}").split() if c.startswith(".")}
        return {info.split()[0]} if info else set()

    @property
    def where(self) -> str:
        return f"{_name(self.path)}:{self.line}"


def _name(path: Path) -> str:
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)


def fenced_blocks(path: Path, text: str | None = None) -> list[Block]:
    """The fenced code blocks of a Markdown text (indented ones inside lists too)."""
    lines = (path.read_text(encoding="utf-8") if text is None else text).splitlines()
    blocks: list[Block] = []
    i = 0
    while i < len(lines):
        m = _FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, fence = len(m["indent"]), m["fence"]
        body: list[str] = []
        j = i + 1
        while j < len(lines) and lines[j].strip() != fence:
            body.append(lines[j][indent:] if lines[j][:indent].strip() == "" else lines[j])
            j += 1
        blocks.append(Block(path, i + 1, m["info"].strip(), "\n".join(body) + "\n"))
        i = j + 1
    return blocks


def prose(text: str) -> str:
    """The text outside fenced blocks (lines of a fence blanked, so inline code spans can be searched)."""
    out: list[str] = []
    fence: str | None = None
    for line in text.splitlines():
        m = _FENCE.match(line)
        if fence is None and m:
            fence = m["fence"]
            out.append("")
        elif fence is not None:
            if line.strip() == fence:
                fence = None
            out.append("")
        else:
            out.append(line)
    return "\n".join(out)


_INLINE = re.compile(r"(?<!`)(`+)(?!`)(.+?)(?<!`)\1(?!`)")


def inline_code(text: str) -> list[str]:
    """Every inline code span of the prose (``like this``), with its backticks removed."""
    return [m.group(2).strip() for m in _INLINE.finditer(prose(text).replace("\\|", "|"))]


# ---- the real command line ---------------------------------------------------------------------------------


@cache
def parser() -> argparse.ArgumentParser:
    from contactrig.cli.main import build_parser

    return build_parser()


def _subcommands(p: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in p._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _options(p: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    return {s: a for a in p._actions for s in a.option_strings}


def _all_parsers(p: argparse.ArgumentParser | None = None) -> Iterator[argparse.ArgumentParser]:
    p = p or parser()
    yield p
    for sub in _subcommands(p).values():
        yield from _all_parsers(sub)


@cache
def every_option() -> frozenset[str]:
    return frozenset(s for p in _all_parsers() for s in _options(p))


_COMMAND = re.compile(r"(?:^|(?<=[\s/]))contactrig(?=\s|$)")
_PLACEHOLDER = re.compile(r"[A-Z]|…|\.\.\.|^<")


def _tokens(command: str) -> list[str]:
    """The words of one written command: cut at a comment or a shell operator; brackets and ``|`` alternatives
    (``[--to csv|xlsx]``, ``--compare-models|--no-compare-models``) are split into their words."""
    command = re.sub(r"\[[^\[\]]*\]", lambda m: m.group(0).replace(" | ", " "), command)  # [--sim F | --database D]
    command = re.split(r"\s#|\s&&\s|\s\|\s|;", command, maxsplit=1)[0]
    command = re.sub(r"[\[\]{}()]", " ", command)
    return command.split()


def check_command(command: str) -> list[str]:
    """Problems with one written command line (the words after ``contactrig``): an unknown subcommand, an option
    its parser does not have, a value outside an option's choices. Empty when it is right."""
    words = _tokens(command)
    problems: list[str] = []
    parsers = [parser()]
    names = ["contactrig"]
    positional_seen = False
    i = 0
    while i < len(words):
        word = words[i]
        if word.startswith("-") and len(word) > 1 and not re.match(r"^-\d", word):
            i += _check_option(word, words[i + 1] if i + 1 < len(words) else None, parsers, names, problems)
            continue
        subs = _subcommands(parsers[0])
        if subs and not positional_seen and not _PLACEHOLDER.search(word):
            alternatives = word.split("|")
            unknown = [a for a in alternatives if a not in subs]
            if unknown:
                problems.append(f"{' '.join(names)}: no subcommand {unknown[0]!r} (has: {', '.join(subs)})")
                return problems
            parsers = [subs[a] for a in alternatives]
            names.append(word)
        else:
            positional_seen = True
        i += 1
    return problems


def _check_option(word: str, following: str | None, parsers: list, names: list[str], problems: list[str]) -> int:
    """Check ``word`` (one or more ``|`` alternatives) against the current parsers; return the words consumed."""
    consumed = 1
    for alternative in re.split(r"[|/](?=-)", word):  # --a|--b, -o/--output
        name = re.sub(r"/?(…|\.\.\.)$", "", alternative.split("=", 1)[0])  # --sample/… (and more)
        actions = [a for p in parsers if (a := _options(p).get(name)) is not None]
        if len(actions) < len(parsers):
            problems.append(f"{' '.join(names)}: no option {name}")
            continue
        for action in actions:
            if action.choices is None or action.nargs == 0:
                continue
            value = alternative.split("=", 1)[1] if "=" in alternative else following
            if value is None:
                continue
            consumed = 1 if "=" in alternative else 2
            if _PLACEHOLDER.search(value) or value.startswith("-"):
                continue
            bad = [v for v in value.split("|") if v not in {str(c) for c in action.choices}]
            if bad:
                allowed = sorted(map(str, action.choices))
                problems.append(f"{' '.join(names)} {name}: {bad[0]!r} is not one of {allowed}")
    return consumed


def written_commands(path: Path) -> Iterator[tuple[str, str]]:
    """(where, command) for every ``contactrig …`` written in ``path``: code blocks other than Python (in ``text``
    blocks only the ``$ `` prompt lines, the rest is output) and inline code."""
    text = path.read_text(encoding="utf-8")
    for block in fenced_blocks(path, text):
        if block.classes & {"python", "pycon", "toml", "json"}:
            continue
        lines = block.code.splitlines()
        if "text" in block.classes:
            lines = [line[2:] for line in lines if line.startswith("$ ")]
        yield from ((block.where, c) for c in _join_continuations(lines))
    for span in inline_code(text):
        first = span.split()[0] if span.split() else ""
        if _COMMAND.search(span):
            yield _name(path), _COMMAND.split(span, maxsplit=1)[1]
        elif first in _subcommands(parser()) and len(span.split()) > 1 and span.split()[1].startswith("-"):
            yield _name(path), span


def _join_continuations(lines: list[str]) -> Iterator[str]:
    """Commands of a block: ``contactrig`` lines, each with its indented continuation lines (``   [--plot …]``)."""
    current: str | None = None
    for line in lines:
        if current is not None and line[:1].isspace() and line.lstrip()[:1] in "[-":
            current += " " + line.strip()
            continue
        if current is not None:
            yield current
        current = _COMMAND.split(line, maxsplit=1)[1] if _COMMAND.search(line) else None
    if current is not None:
        yield current


# ---- the checks of the checker ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("command", "problem"),
    [
        ("acquire --no-such-option", "no option --no-such-option"),
        ("aquire -o s.h5", "no subcommand 'aquire'"),
        ("instruments identify|probe GPIB0::12::INSTR", "no subcommand 'probe'"),
        ("export s.h5 [--to csv|ods]", "'ods' is not one of"),
        ("report s.h5 [--compare-models|--no-compare-model]", "no option --no-compare-model"),
        ("fit s.h5 --conversion=bulkk", "'bulkk' is not one of"),
        ("fit s.h5 [--sim sim.h5 | --databse db.h5]", "no option --databse"),
        ("acquire --address/--sampel/…", "no option --sampel"),
    ],
)
def test_the_command_check_finds_stale_names(command, problem):
    assert any(problem in p for p in check_command(command)), check_command(command)


@pytest.mark.parametrize(
    "command",
    [
        "instruments delta GPIB0::12::INSTR --current 1e-3 --count 100 --json",
        "export SESSION.h5 [--to csv|xlsx] [-o PATH] [--force]",
        "report SESSION.h5 -o DIR [--compare-models|--no-compare-models]",
        "--debug …",
        "fit tab1",
    ],
)
def test_the_command_check_passes_real_commands(command):
    assert check_command(command) == []


def test_blocks_and_inline_code_are_found(tmp_path):
    page = tmp_path / "p.md"
    page.write_text(
        "Run `contactrig fit tab1 --json`, or `acquire --sim`.\n\n"
        "- a list\n\n  ```sh\n  contactrig database -o db.h5\n                    [--plot fig2.png]\n  ```\n\n"
        "```text\n$ contactrig replay s.h5\ncontactrig replay: error: not an option --x\n```\n",
        encoding="utf-8",
    )
    commands = [c.strip() for _, c in written_commands(page)]
    assert commands == ["database -o db.h5 [--plot fig2.png]", "replay s.h5", "fit tab1 --json", "acquire --sim"]


# ---- the manual against the code ----------------------------------------------------------------------------


def test_every_written_command_exists():
    problems = [f"{where}: {p}" for path in _texts() for where, c in written_commands(path) for p in check_command(c)]
    assert not problems, "stale commands or options in the docs:\n" + "\n".join(problems)


def test_every_inline_option_exists():
    options = every_option()
    problems = []
    for path in _texts():
        for span in inline_code(path.read_text(encoding="utf-8")):
            if not span.startswith("--"):
                continue
            names = [alt.split("=", 1)[0] for word in _tokens(span) for alt in word.split("|")]
            problems += [f"{path.relative_to(ROOT)}: `{span}`: no command has {n}" for n in names if n.startswith("--")
                         and n not in options]
    assert not problems, "\n".join(problems)


_PYTHON_NAME = re.compile(r"^(?:contactrig|daq|sims|analysis|instruments)(?:\.\w+)+(?:\(\))?$")


def _resolves(name: str) -> bool:
    """Whether a dotted name (``daq.session_file.UPGRADES``, ``sims.rig.dynamics.settle()``) exists."""
    parts = name.removesuffix("()").split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj: object = importlib.import_module(".".join(parts[:i]))
        except ModuleNotFoundError:
            continue
        for attribute in parts[i:]:
            if not hasattr(obj, attribute):
                return False
            obj = getattr(obj, attribute)
        return True
    return False


def test_every_python_name_in_inline_code_exists():
    spans = [(path, s) for path in _texts() for s in inline_code(path.read_text(encoding="utf-8"))]
    names = [(path, s) for path, s in spans if _PYTHON_NAME.match(s)]
    assert len(names) > 20  # the check sees the manual's names (module paths, functions, constants)
    stale = [f"{_name(path)}: `{s}`" for path, s in names if not _resolves(s)]
    assert not stale, "names in the docs that the code no longer has:\n" + "\n".join(stale)
    assert not _resolves("daq.session_file.NO_SUCH_NAME") and not _resolves("sims.no_such_module")


def _python_pages() -> list[Path]:
    return [p for p in _texts() if any("python" in b.classes for b in fenced_blocks(p))]


@pytest.mark.parametrize("page", _python_pages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_python_examples_run(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    namespace: dict[str, object] = {"__name__": "__docs__"}
    for block in fenced_blocks(page):
        if "python" not in block.classes:
            continue
        code = compile(block.code, block.where, "exec")
        if "no-run" not in block.classes:
            exec(code, namespace)


def test_every_page_is_reachable_from_the_navigation():
    config = (ROOT / "contactrig" / "mkdocs.yml").read_text(encoding="utf-8")
    missing = [p.relative_to(DOCS).as_posix() for p in _pages() if p.relative_to(DOCS).as_posix() not in config]
    assert not missing, f"pages not in mkdocs.yml's nav: {missing}"


def _scene_keys() -> dict[str, set[str]]:
    """Every key each scene table accepts, from the readers themselves."""
    from analysis.circuit import CircuitSettings
    from contactrig.core.scene import SCENE_KEYS
    from daq.plan import INSTRUMENT_KEYS, SESSION_KEYS
    from instruments.delta import DeltaSettings
    from sims import surface
    from sims.database import DATABASE_KEYS
    from sims.materials import MATERIAL_KEYS
    from sims.press import PressSettings
    from sims.rig.settings import RigSettings

    return {
        "scene": set(SCENE_KEYS),
        "materials": set(MATERIAL_KEYS),
        "surfaces": {k for keys in surface._KIND_KEYS.values() for k in keys},
        "database": set(DATABASE_KEYS),
        "rig": {f.name for f in dataclasses.fields(RigSettings)},
        "press": {f.name for f in dataclasses.fields(PressSettings)},
        "circuit": set(CircuitSettings.keys()),
        "instrument": set(INSTRUMENT_KEYS),
        "delta": {f.name for f in dataclasses.fields(DeltaSettings)},
        "session": set(SESSION_KEYS),
    }


def _key_sections() -> list[tuple[set[str], str]]:
    """(tables, section text) for each ``### `[table]`…`` section of the Scenes page."""
    text = (DOCS / "scenes.md").read_text(encoding="utf-8").split("\n## Keys\n", 1)[1].split("\n## ", 1)[0]
    sections = re.split(r"^### ", text, flags=re.M)[1:]
    return [(set(re.findall(r"`\[(\w+)", s.splitlines()[0])), s) for s in sections]


def _documented_keys(section: str) -> set[str]:
    """The names in the ``key`` column of a section's table."""
    rows = [r for r in section.splitlines() if r.startswith("|")]
    header = [c.strip() for c in rows[0].strip("|").split("|")]
    column = header.index("key")
    cells = [re.split(r"(?<!\\)\|", r.strip().strip("|"))[column] for r in rows[2:]]
    return {k for cell in cells for k in re.findall(r"`(\w+)`", cell)}


def test_every_scene_key_is_documented_and_every_documented_key_exists():
    accepted = _scene_keys()
    sections = _key_sections()
    assert {t for tables, _ in sections for t in tables} == set(accepted), "a scene table without a section"
    problems = []
    for tables, section in sections:
        keys = set().union(*(accepted[t] for t in tables))
        documented = _documented_keys(section)
        problems += [f"[{'/'.join(sorted(tables))}] {k}: accepted, not documented" for k in sorted(keys - documented)]
        problems += [f"[{'/'.join(sorted(tables))}] {k}: documented, not accepted" for k in sorted(documented - keys)]
    assert not problems, "contactrig/docs/scenes.md:\n" + "\n".join(problems)


def _public_modules() -> set[str]:
    found: set[str] = set()
    for package in API_PACKAGES:
        found.add(package)
        spec = importlib.util.find_spec(package)
        assert spec is not None and spec.submodule_search_locations is not None
        for info in pkgutil.walk_packages(spec.submodule_search_locations, prefix=package + "."):
            if not any(part.startswith("_") for part in info.name.split(".")):
                found.add(info.name)
    return found


def test_every_public_module_has_an_api_entry():
    documented = {
        m for page in (DOCS / "api").glob("*.md") for m in re.findall(r"^::: ([\w.]+)", page.read_text(), flags=re.M)
    }
    public = _public_modules()
    assert not (public - documented), f"modules without an API entry: {sorted(public - documented)}"
    assert not (documented - public), f"API entries of no module: {sorted(documented - public)}"


def test_the_readme_map_names_every_command():
    text = README.read_text(encoding="utf-8")
    section = text.split("## Commands\n", 1)[1].split("\n## ", 1)[0].replace("\\|", "|")
    rows = [r for r in section.splitlines() if r.startswith("| `contactrig")]
    missing = []
    for name, sub in _subcommands(parser()).items():
        row = next((r for r in rows if f"`contactrig {name}" in r or f"`{name}`" in r), None)
        if row is None:
            missing.append(name)
            continue
        missing += [f"{name} {action}" for action in _subcommands(sub) if not re.search(rf"[ |]{action}\b", row)]
    assert not missing, f"commands missing from the README's map: {missing}"


def test_the_readme_is_a_front_page():
    text = README.read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 150, "the README is the front page: move details into contactrig/docs"
    for marker in ("<!-- quickstart:run -->", "<!-- quickstart:test -->", "<!-- architecture:rules -->"):
        assert marker in text
    test_line = text.split("<!-- quickstart:test -->", 1)[1].split("```", 2)[1]
    assert "docs" in re.search(r"\[([\w,]+)\]", test_line).group(1).split(","), "CI must install the docs extra"
    links = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", prose(text))
    broken = [link for link in links if "://" not in link and not (ROOT / link).exists()]
    assert not broken, f"README links to missing files: {broken}"


def test_figures_are_small_and_used():
    images = sorted((DOCS / "img").glob("*"))
    pages = "".join(p.read_text(encoding="utf-8") for p in _pages())
    assert images, "no figures in contactrig/docs/img"
    assert all(p.stat().st_size < 150_000 for p in images), [(p.name, p.stat().st_size) for p in images]
    assert sum(p.stat().st_size for p in images) < 1_000_000
    assert [p.name for p in images if f"img/{p.name}" not in pages] == []


# ---- the build ---------------------------------------------------------------------------------------------


def test_the_site_builds_strictly(tmp_path):
    missing = [m for m in ("mkdocs", "mkdocstrings", "mkdocstrings_handlers.python") if _absent(m)]
    if missing:
        pytest.skip(f"{', '.join(missing)} not installed: pip install -e '.[docs]'")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "mkdocs", "build", "--strict", "-q", "-f", str(ROOT / "contactrig" / "mkdocs.yml")]
    run = subprocess.run([*cmd, "-d", str(tmp_path / "site")], capture_output=True, text=True, timeout=180, env=env)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "WARNING" not in run.stderr, run.stderr
    site = tmp_path / "site"
    api = (site / "api" / "daq" / "index.html").read_text(encoding="utf-8")
    assert 'id="daq.session_file.load_session"' in api  # the API pages are rendered from the docstrings
    assert (site / "img" / "fig02_database.png").exists()
    # the manual works offline: every script and stylesheet it loads is served from the site itself (issue 26 item 5:
    # the theme's highlight.js came from a CDN, `hljs is not defined` without a network)
    pages = sorted(site.rglob("*.html"))
    external = {
        f"{page.relative_to(site)}: {src}"
        for page in pages
        for src in re.findall(r'<(?:script[^>]*\ssrc|link[^>]*\shref)="([^"]+)"', page.read_text(encoding="utf-8"))
        if re.match(r"(?i)(https?:)?//", src)
    }
    assert not external, sorted(external)[:5]
    index = (site / "index.html").read_text(encoding="utf-8")
    assert "assets/highlight/highlight.min.js" in index
    assert (site / "assets" / "highlight" / "highlight.min.js").exists()


def _absent(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is None
    except ModuleNotFoundError:
        return True
