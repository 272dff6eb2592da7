"""Output files (issue 26, items 10 and 16): every legal output name can be written (the temporary name fits
NAME_MAX); a set of files is replaced as one (a kill at any moment leaves files of one set, and the file a reader
opens only beside the whole of its set); stale staging folders of killed writers are removed — only those, never a
live writer's."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from contactrig.cli.main import main
from contactrig.core.files import (
    STAGE_PREFIX,
    STALE_AFTER_S,
    atomic_write,
    remove_stale_temporaries,
    replace_together,
    write_text_atomic,
)

ROOT = Path(__file__).resolve().parents[2]
WRITER = Path(__file__).with_name("file_set_writer.py")

#: File names of 242–255 bytes, ASCII and multi-byte UTF-8 (2, 3 and 4 bytes a character).
LONG_NAMES = ["a" * 242, "b" * 250, "c" * 255, "ü" * 127 + "x", "€" * 85, "𝔸" * 63 + "abc", "é" * 121 + ".toml"]


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}


@pytest.mark.parametrize("name", LONG_NAMES, ids=lambda n: f"{len(os.fsencode(n))}B")
def test_every_legal_output_name_is_written(name, tmp_path):
    assert 242 <= len(os.fsencode(name)) <= 255
    path = write_text_atomic(tmp_path / name, "text")
    assert path.read_text() == "text"
    with atomic_write(tmp_path / name, force=True) as tmp:
        tmp.write_text("again")
    assert (tmp_path / name).read_text() == "again"
    assert sorted(os.listdir(tmp_path)) == [name]  # nothing else left behind


def test_a_long_name_on_the_command_line(tmp_path, capsys):
    name = "ü" * 122 + ".toml"  # 249 bytes
    assert main(["scene", "init", str(tmp_path / name)]) == 0
    assert (tmp_path / name).read_text(encoding="utf-8").startswith("#")
    capsys.readouterr()
    too_long = "ü" * 126 + ".toml"  # 257 bytes: refused in one line naming the option, the value and the limit
    assert main(["scene", "init", str(tmp_path / too_long)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "at most 255 bytes" in err and "257" in err, err


def test_a_set_is_published_with_its_first_file_last_and_old_files_withdrawn(tmp_path):
    outputs = [tmp_path / "report.md", tmp_path / "figures" / "a.png", tmp_path / "figures" / "b.png"]
    with replace_together(tmp_path, outputs) as stage:
        (stage / "figures").mkdir()
        for p in outputs:
            (stage / p.relative_to(tmp_path)).write_text("old")
    with pytest.raises(FileExistsError, match="use --force"):
        with replace_together(tmp_path, outputs) as stage:
            pass
    link_target = tmp_path / "elsewhere.txt"
    link_target.write_text("not ours")
    os.unlink(outputs[2])
    os.symlink(link_target, outputs[2])  # a link at an output name: replaced (withdrawn), never followed
    with replace_together(tmp_path, outputs, force=True) as stage:
        (stage / "figures").mkdir()
        (stage / "report.md").write_text("new")
        (stage / "figures" / "a.png").write_text("new")  # b.png is not in the new set
    assert outputs[0].read_text() == outputs[1].read_text() == "new"
    assert not os.path.lexists(outputs[2]) and link_target.read_text() == "not ours"
    assert not list(tmp_path.rglob(f"{STAGE_PREFIX}*"))
    with pytest.raises(ValueError, match="not outputs"), replace_together(tmp_path, outputs, force=True) as stage:
        (stage / "stray.txt").write_text("x")
    assert outputs[0].read_text() == "new" and not list(tmp_path.rglob(f"{STAGE_PREFIX}*"))


def test_a_failed_write_changes_nothing(tmp_path):
    outputs = [tmp_path / "a.csv", tmp_path / "a-readings.csv"]
    for p in outputs:
        p.write_text("old")
    with pytest.raises(RuntimeError), replace_together(tmp_path, outputs, force=True) as stage:
        (stage / "a.csv").write_text("new")
        raise RuntimeError("the writer failed")
    assert [p.read_text() for p in outputs] == ["old", "old"]
    assert sorted(os.listdir(tmp_path)) == ["a-readings.csv", "a.csv"]


def test_a_name_taken_while_writing_is_refused_and_nothing_is_left(tmp_path):
    outputs = [tmp_path / "a.csv", tmp_path / "a-readings.csv"]
    with pytest.raises(FileExistsError, match=r"a\.csv exists"), replace_together(tmp_path, outputs) as stage:
        for p in outputs:
            (stage / p.name).write_text("ours")
        outputs[0].write_text("another program's")  # the first file (moved in last) appears meanwhile
    assert outputs[0].read_text() == "another program's" and not outputs[1].exists()
    assert sorted(os.listdir(tmp_path)) == ["a.csv"]


def _check(folder: Path, n: int) -> tuple[int, ...]:
    """The generations of the files there: one generation only; the head only beside all of its parts."""
    names = sorted(p.name for p in folder.iterdir() if not p.name.startswith(STAGE_PREFIX))
    gens = {int((folder / name).read_text()) for name in names}
    assert len(gens) <= 1, f"two sets side by side: {[(nm, (folder / nm).read_text()) for nm in names]}"
    if "head.txt" in names:
        assert len(names) == n + 1, f"the head without its whole set: {names}"
    return tuple(sorted(gens))


def test_a_writer_killed_at_random_moments_leaves_one_set(tmp_path):
    """A real writer replaces a set of 4 files again and again on a slow disk (each rename, link and unlink 20 ms)
    and is killed (SIGKILL) at a random moment, 12 times; each time the folder holds files of one generation only,
    and the head only with its whole set."""
    n = 3
    rng = random.Random(26)
    seen = []
    for k in range(12):
        env = {**_env(), "GENERATION": str(100 * (k + 1))}
        proc = subprocess.Popen([sys.executable, str(WRITER), str(tmp_path), str(n)], env=env, stdout=subprocess.PIPE)
        try:
            assert proc.stdout is not None
            proc.stdout.readline()  # the first set is in: kill during a later replacement
            time.sleep(rng.uniform(0.0, 0.4))
            proc.send_signal(signal.SIGKILL)
            proc.wait()
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        seen.append(_check(tmp_path, n))
    stale = [p for p in tmp_path.iterdir() if p.name.startswith(STAGE_PREFIX)]
    for p in stale:  # as if the next writer came STALE_AFTER_S later
        os.utime(p, (time.time() - STALE_AFTER_S - 5,) * 2)
    write_text_atomic(tmp_path / "other.txt", "x")
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(STAGE_PREFIX)]


def test_stale_staging_folders_are_removed_and_nothing_else(tmp_path):
    old = time.time() - STALE_AFTER_S - 5
    # a killed writer's staging folder (a real process, SIGKILL while it writes)
    proc = subprocess.Popen([sys.executable, str(WRITER), str(tmp_path), "hold"], env=_env(), stdout=subprocess.PIPE)
    assert proc.stdout is not None and proc.stdout.readline().strip() == b"holding"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    (killed,) = [p for p in tmp_path.iterdir() if p.name.startswith(STAGE_PREFIX)]
    # a live writer's, as old; a fresh unlocked one (its writer may not have locked it yet); things not ours
    live = subprocess.Popen([sys.executable, str(WRITER), str(tmp_path), "hold"], env=_env(), stdout=subprocess.PIPE)
    try:
        assert live.stdout is not None and live.stdout.readline().strip() == b"holding"
        (held,) = [p for p in tmp_path.iterdir() if p.name.startswith(STAGE_PREFIX) and p != killed]
        fresh = tmp_path / f"{STAGE_PREFIX}fresh0001.tmp"
        fresh.mkdir()
        foreign_file = tmp_path / f"{STAGE_PREFIX}notes.tmp"
        foreign_file.write_text("a file, not a staging folder")
        elsewhere = tmp_path / "elsewhere"
        elsewhere.mkdir()
        (elsewhere / "keep.txt").write_text("keep")
        link = tmp_path / f"{STAGE_PREFIX}link0001.tmp"
        link.symlink_to(elsewhere)
        for p in (killed, held, foreign_file):
            os.utime(p, (old, old))
        os.utime(link, (old, old), follow_symlinks=False)
        write_text_atomic(tmp_path / "out.txt", "x")  # any writer into the folder cleans up first
        assert not killed.exists()
        assert held.is_dir() and fresh.is_dir() and foreign_file.is_file() and link.is_symlink()
        assert (elsewhere / "keep.txt").read_text() == "keep"
        assert remove_stale_temporaries(tmp_path) == []
    finally:
        live.kill()
        live.wait()
