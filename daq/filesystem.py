"""Whether a folder is on a network file system (NFS, SMB, sshfs, …), where SQLite's locks and WAL are not safe.

SQLite's WAL needs memory shared by every process of the database on one computer, and POSIX locks over NFS and SMB
are unreliable (https://www.sqlite.org/wal.html, https://www.sqlite.org/useovernet.html); ``O_APPEND`` is not atomic
between NFS clients either (each client computes the offset). :mod:`daq.run_index` asks :func:`network_share` to
keep its index on this computer and to append to a sidecar of this computer's own on such a folder.

Linux: the type of the mount that holds the folder (the longest mount point of ``/proc/self/mountinfo`` that is a
prefix of the resolved path; an over-mount, listed later, wins) among :data:`NETWORK_TYPES`. Windows: a UNC path or a
drive that ``GetDriveTypeW`` says is remote. Elsewhere (macOS, BSD) the type is not looked up: a folder counts as
local; ``CONTACTRIG_INDEX_DIR`` (:mod:`daq.run_index`) makes every folder count as shared.
"""

from __future__ import annotations

import os
import re
import sys

__all__ = ["MOUNTINFO", "NETWORK_TYPES", "mount_of", "network_share"]

#: File system types (as ``/proc/self/mountinfo`` names them, FUSE ones as ``fuse.<name>``) whose files other
#: computers write too, or whose locks are not those of this computer's kernel.
NETWORK_TYPES = frozenset({
    "nfs", "nfs4", "cifs", "smb3", "smb2", "smbfs", "9p", "afs", "coda", "ncpfs", "ceph", "fuse.ceph-fuse",
    "glusterfs", "fuse.glusterfs", "lustre", "gpfs", "beegfs", "orangefs", "vboxsf", "davfs", "fuse.davfs2",
    "fuse.sshfs", "fuse.rclone", "fuse.s3fs", "fuse.vmhgfs-fuse", "fuse.gvfsd-fuse", "fuse.smbnetfs",
})  # fmt: skip

#: The mount table read on Linux (the mounts this process sees).
MOUNTINFO = "/proc/self/mountinfo"
_ESCAPE = re.compile(r"\\([0-7]{3})")  # the kernel writes space, tab, newline and backslash as \040 \011 \012 \134


def mount_of(path: str, mountinfo: str) -> tuple[str, str] | None:
    """(mount point, file system type) of the mount holding the absolute, resolved ``path``, from the text of a
    ``/proc/PID/mountinfo`` (proc(5): ``ID PARENT MAJ:MIN ROOT MOUNT-POINT OPTIONS [OPTIONAL…] - TYPE SOURCE
    SUPER-OPTIONS``); None when no line holds it."""
    best: tuple[int, int, str, str] | None = None
    for k, line in enumerate(mountinfo.splitlines()):
        fields = line.split(" ")
        if "-" not in fields[6:-1]:  # the separator before the type
            continue
        point = _ESCAPE.sub(lambda m: chr(int(m.group(1), 8)), fields[4])
        kind = fields[fields.index("-", 6) + 1]
        inside = path == point or path.startswith(point.rstrip("/") + "/")
        if inside and (best is None or (len(point), k) > best[:2]):
            best = (len(point), k, point, kind)
    return (best[2], best[3]) if best is not None else None


def network_share(folder: str | os.PathLike[str]) -> str:
    """The network file system ``folder`` is on (its type, e.g. ``nfs4``, ``cifs``; on Windows ``UNC path`` or
    ``remote drive``), or "" when it is local or cannot be told."""
    path = os.path.realpath(folder)
    if sys.platform == "win32":
        return _windows(path)
    try:
        with open(MOUNTINFO, encoding="utf-8", errors="surrogateescape") as f:
            text = f.read()
    except OSError:
        return ""
    found = mount_of(path, text)
    return found[1] if found is not None and found[1] in NETWORK_TYPES else ""


if sys.platform == "win32":  # pragma: no cover - Windows only: not type-checked or run here

    def _windows(path: str) -> str:
        import ctypes

        plain = path[4:] if path.startswith("\\\\?\\") else path
        if plain.startswith("\\\\") or plain.upper().startswith("UNC\\"):
            return "UNC path"
        drive = os.path.splitdrive(plain)[0]
        try:
            remote = drive and ctypes.windll.kernel32.GetDriveTypeW(drive + "\\") == 4  # DRIVE_REMOTE
        except (AttributeError, OSError):
            return ""
        return "remote drive" if remote else ""
