"""Damaged and hostile session files (issue #16): bounded time, no traceback, no silent wrong, no injection.

The corpus (``tests/daq/hostile.py``) is generated from one good session at test time: truncations, bit flips,
zeroed pages, dtype and shape changes, deleted and added members, altered records, texts and values, a newer
schema, non-HDF5 content, a FIFO. ``load_session`` runs on every variant; the ``contactrig`` commands that read
sessions (replay, fit, report) run on a subset in real processes. The outcome is always either the good file's
results, unchanged, or a clear one-line error naming the file — never a hang, a traceback or a silent difference.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
import warnings
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from daq.errors import SessionFileError
from daq.plan import SessionPlan
from daq.session_file import load_session

from .conftest import ROOT, sim_scene_text
from .hostile import corpus
from .sessions import write_session

#: the deadline tests give load_session (the default, 10 s, is for files up to 50 MB; see daq.bounded)
TIMEOUT_S = 3.0
CORPUS = corpus()


@contextmanager
def bounded(seconds: float):
    """Fail the test (instead of hanging it) if the body takes longer than ``seconds``."""

    def expired(signum, frame):
        raise AssertionError(f"took more than {seconds} s")

    old = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    """A complete, sealed session of the packaged scene (3 weights × 2 blocks × 8 readings) on the simulated bench."""
    from contactrig.core.scene import parse_scene

    path = tmp_path_factory.mktemp("good") / "good.h5"
    plan = SessionPlan.from_scene(parse_scene(sim_scene_text(), "<test>"))
    outcome, _ = write_session(plan, path)
    assert outcome.stop.status == "success"
    return path


def _load(path: Path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        s = load_session(path, timeout=TIMEOUT_S)
    return s, [str(w.message) for w in caught]


@pytest.fixture(scope="module")
def base(good):
    s, notes = _load(good)
    assert s.sealed and s.complete and notes == []
    return s


def _identical(a, b) -> bool:
    try:
        for name in ("summary", "readings", "exchanges"):
            pd.testing.assert_frame_equal(getattr(a, name), getattr(b, name))
    except AssertionError:
        return False
    same = (a.start, a.stop, a.runs, a.scene_text, a.status, a.sealed, a.complete, a.imported)
    return same == (b.start, b.stop, b.runs, b.scene_text, b.status, b.sealed, b.complete, b.imported)


def _variant(good: Path, tmp_path: Path, name: str, make) -> Path:
    out = tmp_path / f"{name}.h5"
    make(good, out)
    return out


@pytest.mark.parametrize(("name", "expect", "make"), CORPUS, ids=[v[0] for v in CORPUS])
def test_load_session_on_a_damaged_or_altered_file(good, base, tmp_path, name, expect, make):
    out = _variant(good, tmp_path, name, make)
    t0 = time.monotonic()
    with bounded(TIMEOUT_S + 5):
        try:
            s, notes = _load(out)
        except (SessionFileError, OSError) as exc:
            message = str(exc)
            assert expect in ("error", "any"), f"{name}: refused although harmless: {message}"
            assert "\n" not in message and str(out) in message, message
            assert time.monotonic() - t0 < TIMEOUT_S + 2
            return
    assert expect != "error", f"{name}: accepted: status {s.status}, sealed {s.sealed}, notes {notes}"
    if expect == "flagged":
        assert not _identical(s, base) and not s.sealed and s.status in ("incomplete", "running")
        assert any("INCOMPLETE" in n or "UNSEALED" in n for n in notes), notes
    else:
        assert _identical(s, base), f"{name}: accepted with different content and no word"
        assert notes == []


def test_corpus_covers_the_issue_and_is_bounded_in_time(good, tmp_path):
    """The corpus has every kind of damage the issue lists, and the one variant that makes the HDF5 library loop
    (a zeroed page of the object headers) is cut off at the deadline."""
    names = " ".join(v[0] for v in CORPUS)
    for kind in ("truncated", "bit-flips", "zeroed-page", "2d", "as-strings", "deleted-", "scene-", "start-",
                 "exchange-", "schema-newer", "fifo", "random-bytes"):  # fmt: skip
        assert kind in names
    assert 60 <= len(CORPUS) <= 150
    hang = _variant(good, tmp_path, "zeroed-page-at-98%", dict((n, m) for n, _, m in CORPUS)["zeroed-page-at-98%"])
    t0 = time.monotonic()
    with bounded(10), pytest.raises(SessionFileError, match=r"did not finish within 1\.5 s"):
        load_session(hang, timeout=1.5)
    assert time.monotonic() - t0 < 4


def test_default_deadline_keeps_a_command_on_a_default_size_session_under_ten_seconds(monkeypatch):
    from daq.bounded import timeout_for

    monkeypatch.delenv("CONTACTRIG_READ_TIMEOUT_S", raising=False)
    assert timeout_for(1_000_000) <= 8.0 and timeout_for(4_000_000) <= 8.0  # + ~1 s interpreter start
    assert timeout_for(100_000_000) > 40  # big files (a slow share) get time in proportion
    monkeypatch.setenv("CONTACTRIG_READ_TIMEOUT_S", "2.5")
    assert timeout_for(1_000_000) == 2.5


# ---- the commands, in real processes ----------------------------------------------------------------------------

#: (variant, what the commands must do): a harmless change, a library loop, a 2-D column, an altered scene, a record
#: of the wrong JSON type, a FIFO, a truncated file
CLI_SUBSET = [
    ("extra-members", "same"),
    ("zeroed-page-at-98%", "error"),
    ("mean_ohm-2d", "error"),
    ("scene-clearance", "error"),
    ("start-record-as-int", "error"),
    ("fifo", "error"),
    ("truncated-to-50%", "error"),
]


def _contactrig(*args: str, timeout: float = 60.0) -> tuple[int, str, str]:
    env = {**os.environ, "CONTACTRIG_READ_TIMEOUT_S": str(TIMEOUT_S), "MPLBACKEND": "Agg"}
    try:
        p = subprocess.run(
            [sys.executable, "-m", "contactrig", *args],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=timeout,
            env=env,
        )
    except subprocess.TimeoutExpired:
        raise AssertionError(f"contactrig {' '.join(args)} did not end within {timeout} s") from None
    return p.returncode, p.stdout, p.stderr


def _commands(path: Path, out: Path) -> dict[str, list[str]]:
    # report without the boundary-element comparison: it runs on the scene's surfaces once the session has been read
    # and reads nothing more of the file (it took most of this test's time)
    return {
        "replay": ["replay", str(path)],
        "fit": ["fit", str(path), "--bootstrap", "0", "--json"],
        "report": ["report", str(path), "--bootstrap", "0", "--no-compare-models", "-o", str(out), "--force"],
    }


def _run_all(jobs: dict[str, list[str]]) -> dict[str, tuple[int, str, str]]:
    """Run the commands two at a time (the machine has two cores), each bounded."""
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(max_workers=2) as pool:
        futures = {key: pool.submit(_contactrig, *args) for key, args in jobs.items()}
        return {key: f.result() for key, f in futures.items()}


def _commands_for(name: str, expect: str) -> tuple[str, ...]:
    """The commands run on a variant. ``report`` reads a session through the very call ``fit`` makes
    (``contactrig.cli.analysis._analysis`` → ``analysis.pipeline.analyse_session`` → ``load_session``), so on a file
    refused while it is read it repeats ``fit`` under another name: it runs on the harmless variant (its own output)
    and on the library loop (its error line), ``replay`` and ``fit`` (two readers of their own) on every variant."""
    return ("replay", "fit", "report") if expect != "error" or name == "zeroed-page-at-98%" else ("replay", "fit")


def test_commands_on_damaged_files_give_one_line_errors_or_the_same_results(good, tmp_path):
    makers = {n: m for n, _, m in CORPUS}
    jobs = {}
    for name, expect in CLI_SUBSET:
        path = _variant(good, tmp_path, name, makers[name])
        commands = _commands(path, tmp_path / f"report-{name}")
        for command in _commands_for(name, expect):
            jobs[f"{name} {command}"] = commands[command]
    jobs["good fit"] = _commands(good, tmp_path / "report-good")["fit"]  # the numbers an unharmed file must give
    results = _run_all(jobs)
    for key, (_rc, out, err) in results.items():
        assert "Traceback" not in out + err, f"{key}:\n{err}"
    for name, expect in CLI_SUBSET:
        for command in _commands_for(name, expect):
            rc, out, err = results[f"{name} {command}"]
            if expect == "error":
                lines = err.strip().splitlines()
                assert rc == 2 and len(lines) == 1 and lines[0].startswith(f"contactrig {command}: error: "), (
                    f"{name} {command}: exit {rc}\n{err}"
                )
                assert name in lines[0]
            else:
                assert rc == 0, f"{name} {command}: exit {rc}\n{err}"
                if command == "fit":
                    good_rc, good_out, _ = results["good fit"]
                    assert good_rc == 0 and _numbers(good_out) and _numbers(out) == _numbers(good_out)


def _numbers(text: str) -> list[str]:
    """The numbers of a command's output (paths and timings aside), to compare two runs' results."""
    text = re.sub(r"\S*\.h5", "", text)
    return re.findall(r"-?\d+\.\d+(?:e-?\d+)?", text)


# ---- strings from files are data ----------------------------------------------------------------------------------

EVIL = "\x1b]0;owned\x07\x1b[2J\r\x1b[31mred\u202eevil\nsecond line"


def test_control_characters_from_a_file_never_reach_the_terminal(tmp_path):
    """A session whose stop reason (any string in a file) holds terminal escape sequences, a carriage return, a bidi
    override and a newline: ``replay`` prints it escaped, on one line; and an error naming a file whose name holds
    them is one escaped line too."""
    from daq.records import BlockRecord, StopRecord, now_iso
    from daq.session_file import SessionFile

    path = tmp_path / "evil.h5"
    with SessionFile.create(path) as sf:
        sf.write_start({"started": now_iso(), "operator": EVIL, "imported": True}, f"# {EVIL}\n")
        r = np.full(4, 5e-3)
        sf.append_block(BlockRecord(0, 0, 5.44, 1, "ohm", r, np.arange(4.0), r, np.ones(4, bool), now_iso()))
        sf.write_stop(StopRecord("aborted", EVIL, now_iso(), 2, 1, 4))
    s, _notes = _load(path)
    assert s.stop["reason"] == EVIL and s.start["operator"] == EVIL  # data are kept as they are …
    rc, _out, err = _contactrig("replay", str(path))
    # … and shown escaped: an imported session cannot be replayed, so this is an error naming the file
    assert (
        rc == 2 and "\x1b" not in err and "\x07" not in err and "\r" not in err and len(err.strip().splitlines()) == 1
    )

    weird = tmp_path / "bad\x1b[2Jname\n.h5"
    weird.write_bytes(b"not hdf5")
    rc, _out, err = _contactrig("replay", str(weird))
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "\x1b" not in err and "\\x1b[2Jname\\n.h5" in err


def test_replay_notes_are_escaped(good, tmp_path):
    """The notes ``replay`` prints come from the file (the stop reason of an aborted session): escaped."""
    from daq.records import StopRecord, now_iso
    from daq.session_file import SessionFile

    path = tmp_path / "aborted.h5"
    path.write_bytes(good.read_bytes())
    # a legitimately written session whose stop reason holds control characters: resume it and stop it at once
    sf = SessionFile.open_for_resume(path)
    sf.write_stop(StopRecord("aborted", EVIL, now_iso(), 6, 6, 48))
    sf.close()
    rc, out, err = _contactrig("replay", str(path))
    assert rc == 0, err
    assert "\x1b" not in out and "\x07" not in out and "\r" not in out and "\u202e" not in out
    note = [ln for ln in out.splitlines() if "session aborted" in ln]
    assert len(note) == 1 and "\\x1b]0;owned\\x07" in note[0] and "\\nsecond line" in note[0]


# ---- the rescue file ----------------------------------------------------------------------------------------------


def _failing_writer(tmp_path: Path):
    """A FileWriter whose session file refuses the next block like a full disk."""
    import errno

    from daq.errors import SessionWriteError
    from daq.records import now_iso
    from daq.session_file import SessionFile
    from daq.writers import FileWriter

    sf = SessionFile.create(tmp_path / "run.h5")
    sf.write_start({"started": now_iso()}, "")

    def full(rec):
        raise SessionWriteError(errno.ENOSPC, f"no space left on the device holding {sf.path}")

    sf.append_block = full
    return sf, FileWriter(sf)


def _block(n: int = 2):
    from daq.records import BlockRecord, now_iso

    r = np.linspace(1e-3, 2e-3, 16)
    return BlockRecord(n, 0, 5.44, 1, "V", r, np.arange(16.0), r, np.ones(16, bool), now_iso())


def test_rescue_file_never_follows_a_planted_symlink(tmp_path):
    """Symlinks planted under the rescue file's names — next to the session and at the old predictable place in the
    shared temporary folder — are neither followed nor replaced; the rescue goes to a fresh file, created
    exclusively next to the session, and the error says where."""
    import tempfile

    from daq.errors import SessionWriteError

    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    planted = [tmp_path / "run.block3.rescue.npz", Path(tempfile.gettempdir()) / "run.block3.rescue.npz"]
    for link in planted:
        if not link.is_symlink():
            link.symlink_to(victim)
    sf, writer = _failing_writer(tmp_path)
    try:
        with pytest.raises(SessionWriteError, match=r"block 3 was saved to (\S+\.rescue\.npz)") as err:
            writer.block(_block())
    finally:
        sf.close()
        planted[1].unlink()
    target = Path(re.search(r"saved to (\S+\.rescue\.npz)", str(err.value)).group(1))
    assert victim.read_text() == "precious" and planted[0].is_symlink() and os.readlink(planted[0]) == str(victim)
    assert target.parent == tmp_path and target.name == "run.block3.1.rescue.npz" and not target.is_symlink()
    assert (target.stat().st_mode & 0o777) == 0o600
    np.testing.assert_array_equal(np.load(target)["resistance_ohm"], _block().resistance_ohm)


def test_rescue_falls_back_to_a_private_folder(tmp_path, monkeypatch):
    """When the session's folder refuses the rescue file too (the full disk itself), it goes to a folder of its own
    (mode 0700, unpredictable name), never to a predictable name in the shared temporary folder."""
    from daq import writers
    from daq.errors import SessionWriteError

    real = writers._rescue_into

    def refuse_session_folder(rec, path, folder):
        if folder is not None:
            raise OSError(28, "No space left on device")
        return real(rec, path, folder)

    monkeypatch.setattr(writers, "_rescue_into", refuse_session_folder)
    sf, writer = _failing_writer(tmp_path)
    try:
        with pytest.raises(SessionWriteError, match=r"saved to (\S+)") as err:
            writer.block(_block())
    finally:
        sf.close()
    target = Path(re.search(r"saved to (\S+\.rescue\.npz)", str(err.value)).group(1))
    assert target.parent.name.startswith("contactrig-rescue-") and (target.parent.stat().st_mode & 0o777) == 0o700
    np.testing.assert_array_equal(np.load(target)["reading"], _block().reading)
    target.unlink()
    target.parent.rmdir()
