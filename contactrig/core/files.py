"""Output files and folders: one policy for every command that writes.

* **Never replace without ``--force``.** An existing file is refused with the one message every command uses
  (``"<path> exists; use --force to overwrite it"``, the wording of ``contactrig acquire`` and ``import``):
  :func:`check_new_file` for one file, :func:`refuse_existing` for the set of files a command is about to write
  (checked before any work is done, so nothing is computed for nothing and nothing is half-replaced).
* **Atomic writes.** :func:`atomic_write` hands out a temporary file in a hidden staging folder inside the target's
  own folder (same file system) and renames it over the target only when writing succeeded; on any failure the
  staging folder is removed, so an error never leaves temporary files or a half-written target. The staging folder's
  name is short and fixed (``.contactrig-XXXXXXXX.tmp``) and the file in it has the target's own name, so every
  legal output name (up to ``NAME_MAX``, 255 bytes) can be written.
* **A set of files is replaced as one** (:func:`replace_together`: a report's text and its figures, an export's
  summary and readings). POSIX renames one name at a time, so no set of renames is atomic as a whole; a staging
  folder swapped in with one rename would need the set to be a folder of its own, and these outputs share the
  user's folder. So the set is written completely into the staging folder first, and then published in an order
  that never shows two sets mixed: with ``--force`` the old set is withdrawn first (its first file, the one a reader
  opens — ``report.md``, the summary CSV — before the rest), then the new files are moved in with that first file
  last. A kill at any moment leaves one set, complete, or part of one set without its first file (a missing report
  or summary, visibly incomplete) — never the old text beside new figures, never a new summary beside old readings.
* **Stale temporaries are removed.** The writer holds an exclusive ``flock`` on its staging folder while it lives;
  a kill (``SIGKILL``, power cut) ends the lock, and the next writer into the same folder removes every staging
  folder of ours that no process holds locked and that is older than :data:`STALE_AFTER_S`
  (:func:`remove_stale_temporaries`) — never another live writer's.
* **Output folders are created.** A missing output folder (``-o DIR``, or the folder of ``-o FILE``) is created
  with its parents (:func:`output_folder`); a *file* where a folder is expected, or a folder where a file is
  expected, is an error naming it.

This module imports only the standard library (and :mod:`contactrig.core.validation`).
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import stat
import tempfile
import time
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from contactrig.core.validation import SettingError

try:
    import fcntl
except ImportError:  # Windows: no flock; staging folders are then removed only by their own writer
    fcntl = None  # type: ignore[assignment]

__all__ = [
    "OutputExistsError",
    "atomic_write",
    "check_new_file",
    "exists_message",
    "output_folder",
    "refuse_existing",
    "remove_stale_temporaries",
    "replace_together",
    "sync_folder",
    "write_text_atomic",
]

#: Name of every staging folder (``mkdtemp``: prefix, 8 random characters, suffix; 24 bytes in all).
STAGE_PREFIX, STAGE_SUFFIX = ".contactrig-", ".tmp"
#: A staging folder younger than this is never taken for a killed writer's (it may not be locked yet), s.
STALE_AFTER_S = 30.0


def exists_message(path: str | os.PathLike[str]) -> str:
    """The one message for an existing output file (the same as ``contactrig acquire`` and ``import``)."""
    return f"{path} exists; use --force to overwrite it"


class OutputExistsError(FileExistsError):
    """An output file exists and ``--force`` was not given. Reads as its message alone (no ``[Errno 17]``)."""

    def __init__(self, path: str | os.PathLike[str]) -> None:
        super().__init__(errno.EEXIST, exists_message(path))
        self.path = Path(path)

    def __str__(self) -> str:
        return str(self.strerror)


def output_folder(directory: str | os.PathLike[str]) -> Path:
    """The output folder ``directory``, created with its parents when missing; a file of that name is an error."""
    out = Path(directory)
    if out.exists() and not out.is_dir():
        raise SettingError("output", str(out), "expected a folder; a file of that name exists")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SettingError("output", str(out), f"cannot create the folder ({exc.strerror or exc})") from None
    return out


def check_new_file(path: str | os.PathLike[str], *, force: bool = False) -> Path:
    """``path`` checked as an output file: not a folder, not an existing file unless ``force``; its folder is
    created when missing (:func:`output_folder`). Returns it as a :class:`~pathlib.Path`."""
    p = Path(path)
    size, limit = len(os.fsencode(p.name)), _name_max(p.parent)
    if size > limit:
        raise SettingError("output", str(p), f"a file name of at most {limit} bytes (this one has {size})")
    if p.is_dir():
        raise SettingError("output", str(p), "expected a file name; a folder of that name exists")
    if (p.exists() or p.is_symlink()) and not force:
        raise OutputExistsError(p)
    output_folder(p.parent if str(p.parent) else ".")
    return p


def _name_max(folder: Path) -> int:
    """The longest file name the file system of ``folder`` (or of its nearest existing parent) takes, bytes."""
    for f in (folder, *folder.parents):
        try:
            return int(os.pathconf(f if str(f) else ".", "PC_NAME_MAX"))
        except (OSError, ValueError, AttributeError):
            continue
    return 255


def refuse_existing(
    paths: Iterable[str | os.PathLike[str]],
    *,
    force: bool = False,
    inputs: Iterable[str | os.PathLike[str]] = (),
) -> list[Path]:
    """Check every file a command is about to write (:func:`check_new_file`) before it does any work; the first
    existing one is refused unless ``force``, and one that is (or links to) one of the command's ``inputs`` always,
    ``force`` or not: an output must never replace the file it is made from. Returns the paths."""
    from contactrig.core.validation import SettingError

    out = [check_new_file(p, force=force) for p in paths]  # its one-line errors first (a name too long, …)
    sources = [Path(i) for i in inputs if Path(i).exists()]
    for path in out:
        if sources and path.exists() and any(os.path.samefile(path, src) for src in sources):
            raise SettingError("-o", str(path), "a file other than the input it is made from")
    return out


@contextmanager
def atomic_write(path: str | os.PathLike[str], *, force: bool = False) -> Iterator[Path]:
    """Write ``path`` atomically: ``with atomic_write(p) as tmp: write(tmp)``.

    ``tmp`` is a fresh, empty file of ``path``'s name in a hidden staging folder in ``path``'s folder; when the block
    ends without an exception it is renamed over ``path`` (refused, as :func:`check_new_file`, if ``path`` exists
    and not ``force``), otherwise removed with its folder (:func:`replace_together` with one file).
    """
    target = Path(path)
    with replace_together(target.parent if str(target.parent) else ".", [target], force=force) as stage:
        tmp = stage / target.name
        tmp.touch()
        yield tmp


@contextmanager
def replace_together(
    root: str | os.PathLike[str], outputs: Sequence[str | os.PathLike[str]], *, force: bool = False
) -> Iterator[Path]:
    """Write a set of files that belong together and publish them as one: ``with replace_together(root, outputs)
    as stage:`` write each new file at its place relative to ``root`` inside ``stage``.

    ``outputs`` are every file the set may hold, all inside ``root``, the one a reader opens first (``report.md``,
    the summary) first; each is checked first (:func:`check_new_file`: refused if it exists and not ``force``).
    ``stage`` is a hidden staging folder in ``root``, held locked while it lives. When the block ends without an
    exception: with ``force`` (and more than one output) every existing file of ``outputs`` is withdrawn (the first
    one first; a file the new set does not hold is withdrawn too, so no old figure stays beside a new report), then
    the staged files are moved in, the first of ``outputs`` last; without ``force`` each is linked in only where its
    name is still free (a name taken meanwhile is refused, and what was moved in is taken back). The staging folder
    is removed in every case. See the module docstring for what a kill at any moment leaves.
    """
    top = output_folder(root)
    targets = [check_new_file(p, force=force) for p in outputs]
    rel = [_relative(t, top) for t in targets]
    stage = _Stage(top)
    try:
        yield stage.path
        staged = [r for r in rel if (stage.path / r).is_file()]
        extra = {p.relative_to(stage.path) for p in stage.path.rglob("*") if not p.is_dir()} - set(staged)
        if extra:
            raise ValueError(f"files written that are not outputs of the set: {sorted(map(str, extra))}")
        if force and len(targets) > 1:  # one file alone is replaced by its rename: nothing to mix with
            for t in targets:
                if os.path.lexists(t):
                    os.unlink(t)  # the file (or the link itself: never followed)
        moved: list[Path] = []
        try:
            for r in reversed(staged):
                _move_in(stage.path / r, top / r, force=force)
                moved.append(top / r)
        except BaseException:
            if not force:  # the names were free: they go back to how they were (what is there is ours, just made)
                for m in moved:
                    with contextlib.suppress(OSError):
                        os.unlink(m)
            raise  # with force: part of the new set without its first file, as a kill leaves it
        sync_folder(top)
    finally:
        stage.remove()


def _relative(target: Path, top: Path) -> Path:
    try:
        return Path(os.path.abspath(target)).relative_to(os.path.abspath(top))
    except ValueError:
        raise ValueError(f"{target} is not inside {top}") from None


def _move_in(src: Path, dst: Path, *, force: bool) -> None:
    if force:
        os.replace(src, dst)
        return
    try:
        os.link(src, dst)  # atomic, and fails on any existing name (a dangling link included)
    except FileExistsError:
        raise OutputExistsError(dst) from None
    except OSError as exc:
        if exc.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV, errno.EMLINK):
            raise
        if os.path.lexists(dst):  # a file system without hard links (FAT, some shares): check, then rename
            raise OutputExistsError(dst) from None
        os.replace(src, dst)


class _Stage:
    """A hidden staging folder in ``top`` (:data:`STAGE_PREFIX`), locked (``flock`` on the folder) from its creation
    until :meth:`remove`; stale ones of killed writers are removed first (:func:`remove_stale_temporaries`)."""

    def __init__(self, top: Path) -> None:
        remove_stale_temporaries(top)
        self.path = Path(tempfile.mkdtemp(prefix=STAGE_PREFIX, suffix=STAGE_SUFFIX, dir=top))
        self._fd: int | None = None
        try:
            self._fd = os.open(self.path, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
            if fcntl is not None:
                fcntl.flock(self._fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            pass  # no locks here (a network share): only the age tells a stale folder then

    def remove(self) -> None:
        shutil.rmtree(self.path, ignore_errors=True)
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


def remove_stale_temporaries(folder: str | os.PathLike[str]) -> list[Path]:
    """Remove the staging folders killed writers left in ``folder``: ours (:data:`STAGE_PREFIX`, a real folder, not
    a link), older than :data:`STALE_AFTER_S` and locked by no process — taken locked while removed, so no writer can
    take one up meanwhile. Returns those removed. Without ``flock`` (Windows) nothing is removed."""
    removed: list[Path] = []
    if fcntl is None:
        return removed
    try:
        candidates = list(Path(folder).glob(f"{STAGE_PREFIX}*{STAGE_SUFFIX}"))
    except OSError:
        return removed
    for p in candidates:
        try:
            st = os.lstat(p)
        except OSError:
            continue
        if not stat.S_ISDIR(st.st_mode) or time.time() - st.st_mtime < STALE_AFTER_S:
            continue  # not a folder of ours, or just made: its writer may not have locked it yet
        try:
            fd = os.open(p, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) | getattr(os, "O_NOFOLLOW", 0))
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            continue  # a live writer's
        try:
            shutil.rmtree(p, ignore_errors=True)
            removed.append(p)
        finally:
            os.close(fd)
    return removed


def sync_folder(folder: Path) -> None:
    """Make the renames durable: fsync the folder (where the platform allows opening one)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_text_atomic(path: str | os.PathLike[str], text: str, *, force: bool = False) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`atomic_write`); returns the path."""
    with atomic_write(path, force=force) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)
