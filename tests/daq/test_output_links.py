"""A symbolic link at an output name is never followed for writing (issue 19, item 2): the session file of
``acquire`` and ``import -o`` obeys the rule of every other output — refused without ``--force``, and with it the
link itself is replaced by the new file while what it points to stays as it was. ``--resume`` continues a session
only under its own name."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

from contactrig.cli.main import main

from .conftest import small_sim_scene
from .sessions import load_quietly


@pytest.fixture(scope="module")
def scene(tmp_path_factory) -> Path:
    return small_sim_scene(tmp_path_factory.mktemp("links"), count=4, repeats=1)


def _acquire(scene: Path, out: Path, *extra: str) -> int:
    return main(["acquire", str(scene), "-o", str(out), "--sim", "--yes", "--sim-speed", "inf", *extra])


def _import(out: Path, *extra: str) -> int:
    return main(["import", "--tab1", "-o", str(out), *extra])


WRITERS = {"acquire": _acquire, "import": lambda scene, out, *extra: _import(out, *extra)}


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.parametrize("command", sorted(WRITERS))
def test_dangling_link_is_refused_then_replaced_never_followed(scene, tmp_path, capsys, command):
    write = WRITERS[command]
    link, aim = tmp_path / "s.h5", tmp_path / "elsewhere" / "aim.h5"
    aim.parent.mkdir()
    link.symlink_to(aim)
    assert write(scene, link) == 2
    assert "exists; use --force" in capsys.readouterr().err
    assert link.is_symlink() and not aim.exists()
    assert write(scene, link, "--force") == 0
    assert not link.is_symlink() and link.is_file() and not aim.exists()  # the link replaced, its aim not created
    assert load_quietly(link).status == "success"


@pytest.mark.parametrize("command", sorted(WRITERS))
def test_link_to_an_existing_file_is_replaced_and_the_file_kept(scene, tmp_path, capsys, command):
    write = WRITERS[command]
    aim = tmp_path / "precious.dat"
    aim.write_bytes(b"not to be overwritten\n" * 100)
    before = _sha(aim)
    link = tmp_path / "s.h5"
    link.symlink_to(aim)
    assert write(scene, link) == 2
    assert "exists; use --force" in capsys.readouterr().err
    assert link.is_symlink() and _sha(aim) == before
    assert write(scene, link, "--force") == 0
    assert not link.is_symlink() and _sha(aim) == before
    assert load_quietly(link).status == "success"


def test_resume_through_a_link_is_refused(scene, tmp_path, capsys):
    real = tmp_path / "real.h5"
    assert _acquire(scene, real) == 0
    before = _sha(real)
    link = tmp_path / "s.h5"
    link.symlink_to(real)
    assert _acquire(scene, link, "--resume") == 2
    err = capsys.readouterr().err
    assert "nothing to resume" in err or "symbolic link" in err, err
    assert _sha(real) == before


def test_resume_through_a_link_to_an_incomplete_session_is_refused(scene, tmp_path, capsys):
    """The link check itself (an incomplete session, which could be continued under its own name)."""
    import h5py

    real = tmp_path / "real.h5"
    assert _acquire(scene, real) == 0
    with h5py.File(real, "a") as h5:  # as a killed run leaves it: no stop record
        del h5["entry/stop"]
    before = _sha(real)
    link = tmp_path / "s.h5"
    link.symlink_to(real)
    assert _acquire(scene, link, "--resume") == 2
    assert "is a symbolic link" in capsys.readouterr().err
    assert _sha(real) == before
    assert _acquire(scene, real, "--resume") == 0  # under its own name it continues


def test_verify_report_replaces_links_never_follows_them(tmp_path):
    """``instruments verify`` writes verify.json/verify.md over earlier ones: a link there is replaced too."""
    from instruments.verify import VerifyReport, write_report

    aim = tmp_path / "aim.txt"
    aim.write_text("keep")
    (tmp_path / "verify.json").symlink_to(aim)
    (tmp_path / "verify.md").symlink_to(tmp_path / "nowhere.md")
    write_report(VerifyReport("SIM::1", 1e-3, [], [], True), tmp_path)
    assert aim.read_text() == "keep" and not (tmp_path / "nowhere.md").exists()
    assert not (tmp_path / "verify.json").is_symlink() and not (tmp_path / "verify.md").is_symlink()
    assert '"address": "SIM::1"' in (tmp_path / "verify.json").read_text()
