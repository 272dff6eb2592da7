"""Scene files and the height maps they name are untrusted input (issue 19, item 3): regular files only, within a
stated size, read within a time bound, before any parsing; every refusal one line naming the key, exit 2."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from contactrig.cli.main import main
from contactrig.core import inputs
from contactrig.core.inputs import read_input_bytes, read_text_file
from contactrig.core.scene import default_scene_text, load_scene, read_height_map
from contactrig.core.validation import SettingError

LINER = 'kind = "gaussian"\nn = 512\npixel_m = 10e-6\nsq_m = 0.4e-6\ncorrelation_m = 80e-6\nseed = 1'


def _map_scene(folder: Path, path: str) -> Path:
    """The default scene with a measured liner map at ``path``."""
    text = default_scene_text()
    assert LINER in text
    scene = folder / "scene.toml"
    scene.write_text(text.replace(LINER, f'kind = "file"\npath = "{path}"\npixel_m = 10e-6', 1), encoding="utf-8")
    return scene


def test_read_text_file_names_the_key(tmp_path):
    good = tmp_path / "a.txt"
    good.write_text("x = 1\n", encoding="utf-8")
    assert read_text_file("scene", good) == "x = 1\n"
    with pytest.raises(SettingError, match=r"^scene = .*file not found"):
        read_text_file("scene", tmp_path / "missing.txt")
    binary = tmp_path / "b.bin"
    binary.write_bytes(b"\xff\xfe\x00\x81")
    with pytest.raises(SettingError, match="not a UTF-8 text file"):
        read_text_file("path", binary)
    with pytest.raises(SettingError, match="this is a folder"):
        read_text_file("path", tmp_path)


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/urandom", "/dev/null"])
def test_devices_are_refused_unread(tmp_path, device):
    if not os.path.exists(device):
        pytest.skip(f"no {device}")
    link = tmp_path / "map.txt"
    link.symlink_to(device)
    for path in (device, link):  # the device itself and a link to it: what the path ends at decides
        with pytest.raises(SettingError, match=r"^\[surfaces.liner\] path = .*regular file.*character device"):
            read_height_map(path, key="surfaces.liner.path")


def test_a_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "map.fifo"
    os.mkfifo(fifo)
    with pytest.raises(SettingError, match="FIFO"):  # nobody writes to it: opening it blocking would hang forever
        read_input_bytes("scene", fifo, max_bytes=100, timeout_s=1.0)


def test_size_limits_are_checked_before_reading(tmp_path, monkeypatch):
    big = tmp_path / "big.toml"
    big.write_bytes(b"#" * 101)
    with pytest.raises(SettingError, match=r"at most 100 bytes; this one has 101 bytes"):
        read_input_bytes("scene", big, max_bytes=100)
    assert read_input_bytes("scene", big, max_bytes=101) == b"#" * 101
    with pytest.raises(SettingError, match=r"^scene = .*at most 4 MiB; this one has 4194305 bytes"):
        big.write_bytes(b"#" * (inputs.SCENE_MAX_BYTES + 1))
        load_scene(big)


def test_a_height_map_has_at_most_the_largest_grid(tmp_path, monkeypatch):
    monkeypatch.setattr(inputs, "HEIGHT_MAP_MAX_SIDE", 4)
    monkeypatch.setattr("contactrig.core.scene.HEIGHT_MAP_MAX_SIDE", 4)
    f = tmp_path / "map.txt"
    f.write_text("1 2 3 4\n" * 4, encoding="utf-8")
    assert read_height_map(f).shape == (4, 4)
    f.write_text("1 2 3 4 5\n" * 4, encoding="utf-8")
    with pytest.raises(SettingError, match=r"map.txt:1'.*at most 4 rows and columns"):
        read_height_map(f)
    f.write_text("1 2 3 4\n" * 5, encoding="utf-8")
    with pytest.raises(SettingError, match=r"map.txt:5'.*at most 4 rows and columns"):
        read_height_map(f)


def test_reading_stops_at_its_time_bound(tmp_path, monkeypatch):
    f = tmp_path / "slow.txt"
    f.write_bytes(b"1 2\n" * 10)
    clock = iter(np.arange(0.0, 100.0, 10.0))  # every look at the clock: 10 s later
    monkeypatch.setattr(inputs.time, "monotonic", lambda: float(next(clock)))
    monkeypatch.setattr(inputs, "_CHUNK", 4)
    with pytest.raises(SettingError, match=r"reading took longer than 5 s"):
        read_input_bytes("path", f, max_bytes=1000, timeout_s=5.0)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(content=st.binary(max_size=300) | st.text(alphabet=" \t\n,;#0123456789.e+-naifx", max_size=300))
def test_any_height_map_file_reads_as_numbers_or_one_setting_error(tmp_path, content):
    f = tmp_path / "map.txt"
    f.write_bytes(content if isinstance(content, bytes) else content.encode())
    try:
        z = read_height_map(f, key="surfaces.liner.path")
    except SettingError as exc:
        assert "\n" not in str(exc) and str(exc).startswith("[surfaces.liner] path = ")
    else:
        assert z.ndim == 2 and z.size >= 1 and z.dtype == np.float64 and not z.flags.writeable


def test_cli_refuses_device_maps_in_one_line(tmp_path, capsys):
    scene = _map_scene(tmp_path, "/dev/zero")
    for argv in (["simulate", str(scene)], ["database", str(scene), "-o", str(tmp_path / "db.h5")]):
        assert main(argv) == 2
        _, err = capsys.readouterr()
        assert err.count("\n") == 1 and "Traceback" not in err
        assert "[surfaces.liner] path = '/dev/zero'" in err and "regular file of at most 256 MiB" in err
    assert not (tmp_path / "db.h5").exists()


def test_cli_on_a_fifo_scene_and_a_fifo_map_ends_at_once(tmp_path):
    """In a child process with a time limit: the bug was a hang."""
    fifo = tmp_path / "scene.toml"
    os.mkfifo(fifo)
    map_fifo = tmp_path / "map.fifo"
    os.mkfifo(map_fifo)
    (tmp_path / "m").mkdir()
    scene = _map_scene(tmp_path / "m", str(map_fifo))
    code = "import sys; from contactrig.cli.main import main; sys.exit(main(sys.argv[1:]))"
    for target, key in ((fifo, "scene = "), (scene, "[surfaces.liner] path = ")):
        r = subprocess.run([sys.executable, "-c", code, "simulate", str(target)], capture_output=True, text=True,
                           timeout=60)  # fmt: skip
        assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
        assert key in r.stderr and "FIFO" in r.stderr
