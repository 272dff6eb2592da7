"""Issue 29, "a folder on a network share": nothing SQLite is kept on a share (WAL needs memory shared on one
computer, POSIX locks over NFS/SMB are unreliable: https://www.sqlite.org/wal.html,
https://www.sqlite.org/useovernet.html), and each computer appends to sidecars of its own (O_APPEND is not atomic
between NFS clients); every reader merges every computer's sidecars."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import socket
import subprocess
import sys

import pytest

from contactrig.cli.main import main
from daq import filesystem
from daq import run_index as ri
from daq.session_diff import session_diff

from .conftest import ROOT
from .run_files import write_run

# proc(5): ID PARENT MAJ:MIN ROOT MOUNT-POINT OPTIONS [OPTIONAL...] - TYPE SOURCE SUPER-OPTIONS; a space in a mount
# point is written \040
MOUNTS = """\
22 1 8:1 / / rw,relatime shared:1 - ext4 /dev/sda1 rw
30 22 0:40 / /mnt/lab rw,relatime shared:5 - nfs4 nas:/export/lab rw,vers=4.2,addr=10.0.0.2
31 30 8:2 / /mnt/lab/local\\040disk rw,relatime shared:6 - ext4 /dev/sdb1 rw
32 22 0:41 / /home/ann/lab\\040share rw,relatime - cifs //nas/share rw,vers=3.1.1
33 22 8:3 / /mnt/lab2 rw,relatime shared:7 - xfs /dev/sdc1 rw
34 22 8:4 / /srv rw,relatime - ext4 /dev/sdd1 rw
35 34 0:42 / /srv/data rw,relatime master:3 - nfs nas:/data rw
36 22 0:43 / /mnt/over rw,relatime - nfs nas:/old rw
37 22 8:5 / /mnt/over rw,relatime - ext4 /dev/sde1 rw
38 22 0:44 / /media/ssh rw,nosuid - fuse.sshfs ann@lab:/data rw,user_id=0
"""


@pytest.mark.parametrize(
    ("path", "mount"),
    [
        ("/mnt/lab", ("/mnt/lab", "nfs4")),
        ("/mnt/lab/2026/run.h5", ("/mnt/lab", "nfs4")),
        ("/mnt/lab/local disk/runs", ("/mnt/lab/local disk", "ext4")),  # a local disk mounted inside the share
        ("/mnt/lab/local disk2", ("/mnt/lab", "nfs4")),  # not under "local disk": a name that only begins like it
        ("/mnt/lab2/runs", ("/mnt/lab2", "xfs")),  # the share's sibling, whose name begins like it
        ("/home/ann/lab share/x", ("/home/ann/lab share", "cifs")),
        ("/srv/data/sub", ("/srv/data", "nfs")),  # a share mounted inside a local disk
        ("/srv/other", ("/srv", "ext4")),
        ("/mnt/over/x", ("/mnt/over", "ext4")),  # mounted over the share: the later line is on top
        ("/media/ssh/a", ("/media/ssh", "fuse.sshfs")),
        ("/", ("/", "ext4")),
    ],
)
def test_the_mount_of_a_path_is_the_longest_mount_point_holding_it(path, mount):
    assert filesystem.mount_of(path, MOUNTS) == mount


def test_a_network_type_is_a_share_and_a_local_one_is_not(tmp_path, monkeypatch):
    table = tmp_path / "mountinfo"
    table.write_text(MOUNTS + f"40 22 0:50 / {_escaped(tmp_path / 'share')} rw - nfs4 nas:/x rw\n", encoding="utf-8")
    monkeypatch.setattr(filesystem, "MOUNTINFO", str(table))
    (tmp_path / "share" / "a b").mkdir(parents=True)
    (tmp_path / "local").mkdir()
    assert filesystem.network_share(tmp_path / "share" / "a b") == "nfs4"
    assert filesystem.network_share(tmp_path / "local") == ""  # under the root's ext4
    assert {"nfs", "nfs4", "cifs", "smb3", "9p", "fuse.sshfs", "ceph", "lustre"} <= filesystem.NETWORK_TYPES
    assert not {"ext4", "xfs", "btrfs", "tmpfs", "overlay", "zfs"} & filesystem.NETWORK_TYPES
    monkeypatch.setattr(filesystem, "MOUNTINFO", str(tmp_path / "absent"))  # no mount table: local
    assert filesystem.network_share(tmp_path / "share") == ""


def _escaped(path) -> str:
    """A mount point as mountinfo writes it (octal escapes for space, tab, newline, backslash)."""
    return "".join(f"\\{ord(c):03o}" if c in " \t\n\\" else c for c in os.path.realpath(path))


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    base = tmp_path_factory.mktemp("share-runs")
    write_run(base / "a.h5", sample="bronze", operator="ann")
    write_run(base / "c.h5", sample="steel", operator="bob", nplc="2.0", started="2026-01-02T10:00:00.000+00:00")
    for f in base.glob("*.h5"):
        t = f.stat().st_mtime - 60  # settled: the index trusts their stamps
        os.utime(f, (t, t))
    return base


@pytest.fixture
def share(sessions, tmp_path, monkeypatch):
    """A copy of the sessions in a folder the mount table says is on NFS, a cache home of its own."""
    folder = tmp_path / "lab share"
    shutil.copytree(sessions, folder)
    table = tmp_path / "mountinfo"
    table.write_text(MOUNTS + f"40 22 0:50 / {_escaped(folder)} rw - nfs4 nas:/lab rw\n", encoding="utf-8")
    monkeypatch.setattr(filesystem, "MOUNTINFO", str(table))
    monkeypatch.delenv(ri.INDEX_DIR_ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    return folder


def _expected_index(folder, cache) -> str:
    """Where the documented rule puts the index: <cache>/<sha256(host + newline + resolved folder)[:16]>.sqlite."""
    key = f"{socket.gethostname()}\n{os.path.realpath(folder)}"
    return str(cache / (hashlib.sha256(key.encode()).hexdigest()[:16] + ".sqlite"))


def _sqlite_in(folder) -> list[str]:
    return sorted(str(p) for p in folder.rglob("*") if ".sqlite" in p.name)


def test_on_a_share_the_index_is_kept_on_this_computer_and_nothing_is_lost(share, tmp_path, capsys):
    cache = tmp_path / "cache" / "contactrig" / "index"
    rows, refreshed = ri.query(share)
    index = _expected_index(share, cache)
    assert str(refreshed.index) == index and os.path.isfile(index)
    assert refreshed.notes == [f"{share} is on a network share (nfs4): its index is kept on this computer, {index}"]
    assert (cache.stat().st_mode & 0o777) == 0o700
    assert sorted(os.path.basename(r["path"]) for r in rows) == ["a.h5", "c.h5"]
    # tags, remarks and fits go to this computer's own sidecars; search, listing and diff read them
    host = "".join(c if c.isalnum() or c in "._-" else "_" for c in socket.gethostname())
    assert main(["sessions", str(share / "a.h5"), "--tag", "rehoned", "--remark", "liner re-honed"]) == 0
    ri.record_fit(share / "c.h5", discriminates=True, best="hertz", statement="Verdict: hertz", who="ann")
    assert sorted(p.name for p in share.glob(".contactrig-*")) == [
        f".contactrig-fits.{host}.jsonl", f".contactrig-notes.{host}.jsonl"
    ]  # fmt: skip
    assert [r["sample"] for r in ri.query(share, ["tag=rehoned"])[0]] == ["bronze"]
    assert [r["sample"] for r in ri.query(share, ["text~honed"])[0]] == ["bronze"]
    assert [r["sample"] for r in ri.query(share, ["verdict=discriminates"])[0]] == ["steel"]
    capsys.readouterr()
    assert main(["sessions", str(share), "--where", "operator=ann"]) == 0
    out, err = capsys.readouterr()
    assert "rehoned" in out and "a.h5" in out and "c.h5" not in out
    assert err.splitlines()[0] == "note: " + refreshed.notes[0]
    diff = session_diff(share / "a.h5", share / "c.h5")
    assert {"field": "fit.verdict", "a": None, "b": "discriminates"} in diff["differences"]
    assert _sqlite_in(share) == [] and not list(share.glob(".contactrig-index*"))
    # the cache is a cache: deleting it loses nothing
    for f in cache.iterdir():
        f.unlink()
    rows = ri.query(share, ["tag=rehoned"])[0]
    assert [(r["sample"], [t["text"] for t in r["tags"]], r["remarks"][0]["text"]) for r in rows] == [
        ("bronze", ["rehoned"], "liner re-honed")
    ]  # fmt: skip
    assert ri.indexed_rows(share) == ri.fresh_scan(share)
    assert _sqlite_in(share) == []


def test_a_local_folder_keeps_its_index_and_plain_sidecars(sessions, tmp_path, monkeypatch):
    folder = tmp_path / "local"
    shutil.copytree(sessions, folder)
    monkeypatch.delenv(ri.INDEX_DIR_ENV, raising=False)
    monkeypatch.setattr(filesystem, "MOUNTINFO", str(tmp_path / "absent"))
    _, refreshed = ri.query(folder)
    assert refreshed.index == folder / ri.INDEX_NAME and refreshed.notes == []
    ri.add_mark(folder / "a.h5", "tag", "here", who="ann")
    names = {p.name for p in folder.glob(".contactrig-*") if not p.name.startswith(ri.INDEX_NAME + "-")}
    assert names == {ri.INDEX_NAME, ri.SIDECAR_NAME}


def test_the_override_keeps_every_index_in_its_folder(sessions, tmp_path, monkeypatch):
    folder = tmp_path / "runs"
    shutil.copytree(sessions, folder)
    cache = tmp_path / "indexes"
    monkeypatch.setenv(ri.INDEX_DIR_ENV, str(cache))
    monkeypatch.setattr(filesystem, "MOUNTINFO", str(tmp_path / "absent"))  # a local folder
    _, refreshed = ri.query(folder)
    index = _expected_index(folder, cache)
    assert str(refreshed.index) == index
    assert refreshed.notes == [
        f"{folder} is treated as shared ({ri.INDEX_DIR_ENV} is set): its index is kept on this computer, {index}"
    ]
    assert _sqlite_in(folder) == []


@pytest.mark.parametrize("bad", ["link", "under a file", "relative", "default is a link"])
def test_an_index_folder_that_cannot_be_used_falls_back_to_a_scan(share, tmp_path, monkeypatch, capsys, bad):
    real = tmp_path / "real"
    real.mkdir()
    if bad == "link":
        cache = tmp_path / "link"
        os.symlink(real, cache)
        why = f"the index folder {cache} is a symbolic link: not followed"
    elif bad == "under a file":
        (tmp_path / "file").write_text("x")
        cache = tmp_path / "file" / "index"
        why = f"the index folder {cache} cannot be created (Not a directory)"
    elif bad == "relative":
        cache = "indexes"
        why = "the index folder indexes is not an absolute path"
    else:  # no override: the folder is shared because the mount table says so; the user's cache is a link
        cache = tmp_path / "cache" / "contactrig" / "index"
        cache.parent.mkdir(parents=True)
        os.symlink(real, cache)
        why = f"the index folder {cache} is a symbolic link: not followed"
    if bad != "default is a link":
        monkeypatch.setenv(ri.INDEX_DIR_ENV, str(cache))
    reason = (
        f"{share} is on a network share (nfs4)"
        if bad == "default is a link"
        else f"{share} is treated as shared ({ri.INDEX_DIR_ENV} is set)"
    )
    before = sorted(p.name for p in share.iterdir())
    assert main(["sessions", str(share)]) == 0
    out, err = capsys.readouterr()
    assert "a.h5" in out and "c.h5" in out
    assert err.splitlines() == [f"note: {reason}: {why}; the folder was scanned instead"]
    assert sorted(p.name for p in share.iterdir()) == before and list(real.iterdir()) == []
    assert not os.path.exists("indexes") and not (ROOT / "indexes").exists()


# Each child is one computer: its own host name and cache, the same share (as the mount table says).
_COMPUTER = """
import json, socket, sys
host, table, folder, n = sys.argv[1:5]
socket.gethostname = lambda: host
from daq import filesystem, run_index as ri
filesystem.MOUNTINFO = table
if int(n):
    for i in range(int(n)):
        ri.add_mark(folder + "/a.h5", "tag", f"{host.split()[0]}-{i}", who=host)
else:
    rows, refreshed = ri.query(folder)
    print(json.dumps({"tags": sorted(t["text"] for r in rows for t in r["tags"]), "index": str(refreshed.index)}))
"""


def test_two_computers_tag_one_session_on_a_share_each_in_its_own_file(share, tmp_path):
    hosts = ["labpc1", "lab pc/2"]

    def run(host, n):
        env = {**os.environ, "PYTHONPATH": str(ROOT), "XDG_CACHE_HOME": str(tmp_path / f"cache-{host[-1]}")}
        return subprocess.Popen(
            [sys.executable, "-c", _COMPUTER, host, filesystem.MOUNTINFO, str(share), str(n)],
            cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip

    writers = [run(h, 8) for h in hosts]  # at the same time
    for p in writers:
        _, err = p.communicate(timeout=120)
        assert p.returncode == 0, err[-2000:]
    files = {p.name: p.read_text().splitlines() for p in share.glob(".contactrig-notes*")}
    assert sorted(files) == [".contactrig-notes.lab_pc_2.jsonl", ".contactrig-notes.labpc1.jsonl"]
    assert [json.loads(line)["text"] for line in files[".contactrig-notes.labpc1.jsonl"]] == [
        f"labpc1-{i}" for i in range(8)
    ]
    assert [json.loads(line)["text"] for line in files[".contactrig-notes.lab_pc_2.jsonl"]] == [
        f"lab-{i}" for i in range(8)
    ]
    every = sorted([f"labpc1-{i}" for i in range(8)] + [f"lab-{i}" for i in range(8)])
    readers = [run(h, 0) for h in hosts]
    listed = []
    for p in readers:
        out, err = p.communicate(timeout=120)
        assert p.returncode == 0, err[-2000:]
        listed.append(json.loads(out))
    assert [got["tags"] for got in listed] == [every, every]
    assert listed[0]["index"] != listed[1]["index"]  # each computer its own index, none on the share
    assert all(got["index"].startswith(str(tmp_path / "cache-")) for got in listed)
    assert _sqlite_in(share) == []


def test_a_folder_copied_from_a_share_keeps_every_computers_marks(share, tmp_path, monkeypatch):
    ri.add_mark(share / "a.h5", "tag", "mine", who="ann")
    sidecar = next(share.glob(".contactrig-notes.*.jsonl"))
    other = json.loads(sidecar.read_text())
    other.update(text="theirs", who="bob", at="2020-01-01T00:00:00.000+00:00")  # earlier: listed first
    (share / ".contactrig-notes.otherpc.jsonl").write_text(json.dumps(other) + "\n")
    copy = tmp_path / "copy"
    shutil.copytree(share, copy)
    monkeypatch.setattr(filesystem, "MOUNTINFO", str(tmp_path / "absent"))  # the copy is local
    assert [m["text"] for m in ri.marks_in(copy)] == ["theirs", "mine"]
    rows = ri.query(copy, ["tag=theirs"])[0]
    assert [t["text"] for t in rows[0]["tags"]] == ["theirs", "mine"]
    assert (copy / ri.INDEX_NAME).exists()
