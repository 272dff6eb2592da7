"""The live view: ``contactrig watch`` in another process while ``acquire`` writes, a SIGKILLed writer, the view as
one more writer of the acquisition drawing in a process of its own (a failing, stuck or killed view never stops or
delays it), and the status line."""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from analysis.watch import BlockRow, Guarded, LiveState, LiveView, render_png, state_from_session, status_line, watch
from daq.plan import SessionPlan
from tests.daq.conftest import small_scene
from tests.daq.sessions import load_quietly, write_session

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONUNBUFFERED": "1", "MPLBACKEND": "Agg"}
PNG = b"\x89PNG\r\n\x1a\n"


def _writer(out: Path, time_scale: float) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "tests.daq.acquire_script", str(out), str(time_scale)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=ENV,
    )  # fmt: skip


def _watcher(session: Path, png: Path, every: float = 0.2) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "contactrig", "watch", str(session), "--png", str(png), "--every", str(every)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV,
    )  # fmt: skip


def _wait_for_block(proc: subprocess.Popen, k: int, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        if line.startswith(f"block {k}/"):
            return
    proc.kill()
    raise AssertionError(f"the writer did not reach block {k}")


def _blocks_seen(status_lines: str) -> list[int]:
    return [int(ln.split("block ", 1)[1].split("/", 1)[0]) for ln in status_lines.splitlines() if "block " in ln]


def test_watcher_process_follows_a_session_acquired_in_another_process(tmp_path):
    out, png = tmp_path / "live.h5", tmp_path / "live.png"
    writer = _writer(out, 1.5)  # ~0.6 s per block, 12 blocks
    try:
        _wait_for_block(writer, 1)
        watcher = _watcher(out, png)
        rest, _ = writer.communicate(timeout=60)
        assert writer.returncode == 0, rest  # the writer is undisturbed: the whole plan, exit 0
        _, err = watcher.communicate(timeout=30)  # returns by itself once nobody writes the file
    finally:
        writer.kill()
    assert watcher.returncode == 0, err
    seen = _blocks_seen(err)
    assert "RUNNING" in err and "ETA" in err and err.splitlines()[-2].startswith("live.h5: SUCCESS")
    assert len(set(seen)) >= 3 and seen == sorted(seen) and seen[0] < 12 and seen[-1] == 12, err  # blocks appear
    assert png.read_bytes().startswith(PNG) and not list(tmp_path.glob(".*.tmp"))
    s = load_quietly(out)
    assert s.status == "success" and s.sealed and len(s.summary) == 12


def test_sigkill_of_the_writer_with_a_watcher_attached_leaves_a_readable_file(tmp_path):
    out, png = tmp_path / "kill.h5", tmp_path / "kill.png"
    writer = _writer(out, 1.0)
    try:
        _wait_for_block(writer, 1)
        watcher = _watcher(out, png, every=0.1)
        _wait_for_block(writer, 4)
        writer.send_signal(signal.SIGKILL)
        writer.wait(timeout=10)
        _, err = watcher.communicate(timeout=30)  # the watcher sees nobody holds the file any more and returns
    finally:
        writer.kill()
    assert watcher.returncode == 0, err
    assert "INCOMPLETE" in err.splitlines()[-2]
    s = load_quietly(out)
    assert s.status == "incomplete" and 4 <= len(s.summary) < 12
    assert list(s.summary["block"]) == list(range(len(s.summary)))


def _run(plan: SessionPlan, path: Path, *extra):
    from daq.acquire import drive
    from daq.session_file import SessionFile
    from daq.writers import FileWriter
    from tests.daq.conftest import make_link
    from tests.daq.sessions import start_record

    sf = SessionFile.create(path)
    try:
        outcome = drive(
            make_link(plan), plan.block_settings, __import__("daq.plan").plan.session_steps(plan),
            [FileWriter(sf), *extra], start_record(plan), plan.scene.text, blocks_planned=plan.blocks_planned,
        )  # fmt: skip
    finally:
        sf.close()
    return outcome


def test_live_view_inside_the_acquisition_draws_and_changes_nothing(tmp_path):
    plan = SessionPlan.from_scene(small_scene())
    _run(plan, tmp_path / "plain.h5")
    stream = io.StringIO()
    view = LiveView(tmp_path / "view.png", every=0.0, stream=stream)
    outcome = _run(plan, tmp_path / "viewed.h5", view)
    assert outcome.stop.status == "success" and not view.off, stream.getvalue()
    assert view.frames >= 1 and (tmp_path / "view.png").read_bytes().startswith(PNG)
    assert view.state.status == "success" and view.state.blocks_done == 6 and view.state.blocks_planned == 6
    a, b = load_quietly(tmp_path / "plain.h5"), load_quietly(tmp_path / "viewed.h5")
    assert list(a.summary["sha256"]) == list(b.summary["sha256"])  # the same blocks, byte for byte


class Boom(Exception):
    pass


def _raise(*args, **kwargs):
    raise Boom("plot failed\nsecond line")


class RaisingWriter:
    def start(self, start, scene_text):
        pass

    def exchanges(self, exchanges, block):
        _raise()

    def block(self, rec):
        _raise()

    def stop(self, stop):
        _raise()


@pytest.mark.parametrize("kind", ["draw", "guarded"])
def test_a_failing_plot_writer_is_reported_once_and_the_session_completes(tmp_path, kind):
    plan = SessionPlan.from_scene(small_scene())
    stream = io.StringIO()
    view = (
        LiveView(every=0.0, stream=stream, draw=_raise) if kind == "draw" else Guarded(RaisingWriter(), stream=stream)
    )
    outcome = _run(plan, tmp_path / "s.h5", view)
    assert outcome.stop.status == "success" and outcome.error is None
    s = load_quietly(tmp_path / "s.h5")
    assert s.status == "success" and len(s.summary) == 6
    text = stream.getvalue()
    assert view.off and text.count("live view off") == 1 and "Boom: plot failed" in text and "second" not in text


def test_a_window_without_a_display_turns_the_view_off(tmp_path, monkeypatch):
    import matplotlib

    monkeypatch.setattr(matplotlib, "get_backend", lambda: "agg")
    monkeypatch.setenv("MPLBACKEND", "agg")  # the view's process (spawned) sees the environment, not the patch
    stream = io.StringIO()
    view = LiveView(stream=stream)
    _run(SessionPlan.from_scene(small_scene()), tmp_path / "s.h5", view)
    assert view.off and "no display" in stream.getvalue() and load_quietly(tmp_path / "s.h5").status == "success"


def _stuck(state):
    time.sleep(600)  # a draw that never returns (a hung GUI, a deadlock): the view's process is stuck


class Paced:
    """A writer taking ``seconds`` per block (as the instruments would), so blocks still come while the view's
    process is up — and stuck."""

    def __init__(self, seconds):
        self.seconds = seconds

    def start(self, start, scene_text):
        pass

    def exchanges(self, exchanges, block):
        pass

    def block(self, rec):
        time.sleep(self.seconds)

    def stop(self, stop):
        pass


class Timed:
    """Wraps a writer and keeps how long each call took, as the acquisition sees it."""

    def __init__(self, writer):
        self.writer = writer
        self.seconds = {"start": [], "exchanges": [], "block": [], "stop": []}

    def _call(self, name, *args):
        t = time.perf_counter()
        getattr(self.writer, name)(*args)
        self.seconds[name].append(time.perf_counter() - t)

    def start(self, start, scene_text):
        self._call("start", start, scene_text)

    def exchanges(self, exchanges, block):
        self._call("exchanges", exchanges, block)

    def block(self, rec):
        self._call("block", rec)

    def stop(self, stop):
        self._call("stop", stop)


def test_a_stuck_view_process_never_holds_the_acquisition(tmp_path):
    stream = io.StringIO()
    view = LiveView(every=0.0, stream=stream, draw=_stuck, stop_timeout=1.0)
    timed = Timed(view)
    outcome = _run(SessionPlan.from_scene(small_scene()), tmp_path / "s.h5", Paced(0.5), timed)
    first, *rest = timed.seconds["block"]
    assert view.frames == 0  # the view's process took the first update and never came back from drawing it
    # the updates after it are merged while the queue is full, never waited for (measured: ~0.2 ms a block)
    assert len(rest) == 5 and max(rest) < 0.1, timed.seconds
    assert first < 2.0, timed.seconds  # the first block also spawns the view's process (~20 ms)
    (stop,) = timed.seconds["stop"]
    assert stop < 1.0 + 4.0, timed.seconds  # stop_timeout for the last frame (after the file is sealed), then ended
    assert outcome.stop.status == "success" and outcome.error is None
    s = load_quietly(tmp_path / "s.h5")
    assert s.status == "success" and s.sealed and len(s.summary) == 6
    text = stream.getvalue()
    assert view.off and text.count("live view off") == 1 and "not drawn within 1 s" in text, text
    assert view.state.blocks_done == 6 and not view.process.is_alive()


class KillTheView:
    """Kills the view's process after block ``at`` (SIGKILL on POSIX) and notes the first block at which the
    view was off."""

    def __init__(self, view, at):
        self.view, self.at, self.off_at = view, at, None

    def start(self, start, scene_text):
        pass

    def exchanges(self, exchanges, block):
        pass

    def block(self, rec):
        if self.view.off and self.off_at is None:
            self.off_at = rec.block
        if rec.block == self.at:
            self.view.process.kill()
            self.view.process.join(10)

    def stop(self, stop):
        pass


def test_a_killed_view_process_turns_the_view_off_once_and_the_session_completes_sealed(tmp_path):
    stream = io.StringIO()
    view = LiveView(tmp_path / "view.png", every=0.0, stream=stream)
    killer = KillTheView(view, at=1)
    outcome = _run(SessionPlan.from_scene(small_scene()), tmp_path / "s.h5", view, killer)
    assert outcome.stop.status == "success" and outcome.error is None
    s = load_quietly(tmp_path / "s.h5")
    assert s.status == "success" and s.sealed and len(s.summary) == 6
    text = stream.getvalue()
    assert killer.off_at == 2, text  # noticed at the next block, not only at the end
    assert view.off and text.count("live view off") == 1 and "view process ended unexpectedly" in text, text
    if sys.platform != "win32":
        assert "killed by SIGKILL" in text
    assert view.state.status == "success" and not view.process.is_alive()


_ORPHAN = """
import sys, time, types
import numpy as np
from analysis.watch import LiveView

view = LiveView(sys.argv[1], every=0.0, force=True)
view.start({"plan": {"blocks_planned": 3}}, "")
stats = types.SimpleNamespace(mean=1e-3, n=3, n_invalid=0)
view.block(types.SimpleNamespace(
    block=0, weight_kg=5.0, repeat=1, stats=stats, compliance=False, started="2026-01-01T00:00:00+00:00",
    time_s=np.arange(3.0), resistance_ohm=np.full(3, 1e-3), valid=np.ones(3, dtype=bool),
))
print(view.process.pid, flush=True)
time.sleep(600)
"""


def _gone(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] == "Z"  # a zombie: it has ended
    except FileNotFoundError:
        return True


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")
def test_the_view_process_ends_when_the_acquiring_process_is_killed(tmp_path):
    png = tmp_path / "orphan.png"
    parent = subprocess.Popen(
        [sys.executable, "-c", _ORPHAN, str(png)], cwd=ROOT, stdout=subprocess.PIPE, text=True, env=ENV
    )
    try:
        child = int(parent.stdout.readline())
        deadline = time.monotonic() + 30
        while not png.exists() and time.monotonic() < deadline:  # the view is up and has drawn
            time.sleep(0.05)
        assert png.exists() and not _gone(child)
        parent.send_signal(signal.SIGKILL)
        parent.wait(timeout=10)
        deadline = time.monotonic() + 10
        while not _gone(child) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _gone(child), "the view's process outlived the acquisition"
    finally:
        parent.kill()


def _row(block, w, rep, mean, started, compliance=False, n_invalid=0):
    return BlockRow(block, w, rep, mean, 8, n_invalid, compliance, started)


def test_status_line_eta_invalid_and_compliance():
    rows = (
        _row(0, 5.0, 1, 2e-3, 1000.0),
        _row(1, 5.0, 2, 2.1e-3, 1010.0, n_invalid=2),
        _row(2, 10.0, 1, float("nan"), 1020.0, compliance=True, n_invalid=8),
    )
    state = LiveState("s.h5", "running", rows, blocks_planned=6)
    assert state.eta_s(now=1025.0) == pytest.approx(3 * 10.0 - 5.0)
    line = status_line(state, now=1025.0)
    assert line == "s.h5: RUNNING  10 kg repeat 1  block 3/6  ETA 0:25  2 invalid  COMPLIANCE in block(s) 3 (excluded)"
    done = status_line(LiveState("s.h5", "success", rows[:2], blocks_planned=2))
    assert "ETA" not in done and "compliance: none" in done and "block 2/2" in done
    assert "ETA –" in status_line(LiveState("s.h5", "running", rows[:1], blocks_planned=6))


def test_watch_once_on_a_finished_file_and_the_snapshot_policy(tmp_path):
    plan = SessionPlan.from_scene(small_scene())
    path = tmp_path / "s.h5"
    write_session(plan, path)
    stream = io.StringIO()
    state = watch(path, png=tmp_path / "a.png", stream=stream)  # finished: draws once and returns
    assert state.status == "success" and state.blocks_done == 6 and stream.getvalue().count("\n") == 1
    assert state_from_session(load_quietly(path)).current_ohm.size == 8
    watch(path, png=tmp_path / "a.png", stream=stream)  # its own snapshot: rewritten without --force (issue 20)
    evil = LiveState("$\\x$ \x1b[2J", "running", (), current_ohm=np.array([1e-3]), current_valid=np.array([True]))
    render_png(evil, tmp_path / "evil.png")  # '$' would start mathtext, ESC would reach a terminal: both escaped
    assert (tmp_path / "evil.png").read_bytes().startswith(PNG)


@pytest.fixture
def sim_scene(tmp_path):
    from tests.daq.conftest import sim_scene_text

    path = tmp_path / "scene.toml"
    path.write_text(sim_scene_text())
    return path


def _acquire_live(scene, out, *live):
    from contactrig.cli.main import main

    return main(["acquire", str(scene), "--sim", "--yes", "--sim-speed", "inf", "-o", str(out), "--live", *live])


def test_acquire_live_writes_the_snapshot(sim_scene, tmp_path, capsys):
    png = tmp_path / "live.png"
    assert _acquire_live(sim_scene, tmp_path / "s.h5", str(png)) == 0
    assert "live view off" not in capsys.readouterr().err
    assert png.read_bytes().startswith(PNG) and load_quietly(tmp_path / "s.h5").status == "success"


def test_acquire_live_with_a_failing_plot_writer_completes_the_session(sim_scene, tmp_path, monkeypatch, capsys):
    import analysis.watch

    monkeypatch.setattr(analysis.watch, "render_png", _raise)
    assert _acquire_live(sim_scene, tmp_path / "s.h5", str(tmp_path / "live.png")) == 0
    err = capsys.readouterr().err
    assert err.count("live view off") == 1 and "Boom: plot failed" in err
    s = load_quietly(tmp_path / "s.h5")
    assert s.status == "success" and s.sealed and len(s.summary) == 6


def test_acquire_live_without_a_display_says_so_once_and_completes(sim_scene, tmp_path, monkeypatch, capsys):
    import matplotlib

    monkeypatch.setattr(matplotlib, "get_backend", lambda: "agg")
    monkeypatch.setenv("MPLBACKEND", "agg")
    assert _acquire_live(sim_scene, tmp_path / "s.h5") == 0
    err = capsys.readouterr().err
    assert err.count("live view off") == 1 and "no display" in err
    assert load_quietly(tmp_path / "s.h5").status == "success"


def _foreign_png(path: Path) -> None:
    """A PNG another program wrote: matplotlib's own, without the snapshot marker."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(1, 1))
    FigureCanvasAgg(fig)
    fig.savefig(path, format="png")


def test_a_snapshot_is_rewritten_but_nothing_else_is_overwritten_and_links_are_not_followed(tmp_path):
    """Issue 20 item 8: `watch --png P` rewrites the snapshot an earlier run left (marked in its PNG text chunks)
    without --force; another file at P — a foreign PNG, a link, even a link to a snapshot — is refused and left as
    it was; with --force a link itself is replaced, never what it points to."""
    from analysis.snapshot import SNAPSHOT_METADATA, is_own_snapshot, png_text

    path = tmp_path / "s.h5"
    write_session(SessionPlan.from_scene(small_scene()), path)
    snap, foreign, link = tmp_path / "snap.png", tmp_path / "figure.png", tmp_path / "link.png"
    watch(path, png=snap, stream=io.StringIO())
    assert png_text(snap.read_bytes()).items() >= SNAPSHOT_METADATA.items() and is_own_snapshot(snap)
    first = snap.stat().st_mtime_ns
    time.sleep(0.01)
    watch(path, png=snap, stream=io.StringIO())  # the earlier run's snapshot: no --force needed
    assert snap.stat().st_mtime_ns != first and is_own_snapshot(snap)
    _foreign_png(foreign)
    before = foreign.read_bytes()
    assert not is_own_snapshot(foreign)
    with pytest.raises(FileExistsError, match="use --force"):
        watch(path, png=foreign, stream=io.StringIO())
    assert foreign.read_bytes() == before
    link.symlink_to(snap)
    kept = snap.read_bytes()
    assert not is_own_snapshot(link)  # a link is never read through, let alone written through
    with pytest.raises(FileExistsError, match="use --force"):
        watch(path, png=link, stream=io.StringIO())
    watch(path, png=link, stream=io.StringIO(), force=True)
    assert not link.is_symlink() and is_own_snapshot(link) and snap.read_bytes() == kept


def test_watch_once_without_a_display_prints_the_status(tmp_path):
    """Issue 20 item 8: headless (MPLBACKEND=Agg: no window possible), `watch SESSION --once` prints the status
    text on stdout and exits 0; the note that there is no window goes to stderr."""
    path = tmp_path / "s.h5"
    write_session(SessionPlan.from_scene(small_scene()), path)
    proc = subprocess.run([sys.executable, "-m", "contactrig", "watch", str(path), "--once"], cwd=ROOT, env=ENV,
                          capture_output=True, text=True, timeout=120)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == status_line(state_from_session(load_quietly(path)))
    assert proc.stdout.startswith("s.h5: SUCCESS") and "block 6/6" in proc.stdout
    assert "no display" in proc.stderr and "Traceback" not in proc.stderr
