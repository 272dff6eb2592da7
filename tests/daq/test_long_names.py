"""Session files of every legal name (issue 26, item 10): names of 242–255 bytes, ASCII and multi-byte UTF-8, are
written by ``import`` (and ``acquire``: the same publishing code, :mod:`daq.session_lock`) — the hidden temporary
name is shortened and hashed where ``.NAME.XXXXXXXX.tmp`` would pass NAME_MAX — and their stale temporaries, and
those of names with glob characters, are found and removed by the next writer."""

from __future__ import annotations

import os
import time

import pytest

from contactrig.cli.main import main
from daq.session_lock import temporary_beside

NAMES = ["a" * 239 + ".h5", "b" * 252 + ".h5", "ü" * 126 + ".h5", "€" * 84 + ".h5", "𝔸" * 63 + ".h5"]


@pytest.mark.parametrize("name", NAMES, ids=lambda n: f"{len(os.fsencode(n))}B")
def test_import_writes_a_session_of_a_long_name(name, tmp_path, capsys):
    assert 242 <= len(os.fsencode(name)) <= 255
    assert main(["import", "--tab1", "-o", str(tmp_path / name)]) == 0, capsys.readouterr().err
    assert os.listdir(tmp_path) == [name]


@pytest.mark.parametrize("name", ["c" * 252 + ".h5", "run[1]*?.h5"])
def test_stale_temporaries_of_long_and_glob_names_are_removed(name, tmp_path):
    target = tmp_path / name
    stale = temporary_beside(target)  # left by a killed writer: nobody holds it locked
    assert len(os.fsencode(stale.name)) <= 255
    old = time.time() - 3600
    os.utime(stale, (old, old))
    fresh = temporary_beside(target)
    assert not stale.exists() and fresh.exists()
