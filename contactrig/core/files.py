"""Output files and folders: one policy for every command that writes.

* **Never replace without ``--force``.** An existing file is refused with the one message every command uses
  (``"<path> exists; use --force to overwrite it"``, the wording of ``contactrig acquire`` and ``import``):
  :func:`check_new_file` for one file, :func:`refuse_existing` for the set of files a command is about to write
  (checked before any work is done, so nothing is computed for nothing and nothing is half-replaced).
* **Atomic writes.** :func:`atomic_write` hands out a temporary file in the target's own folder (same file
  system) and renames it over the target only when writing succeeded; on any failure the temporary file is
  removed, so a crash or an error never leaves ``*.partial``/``*.tmp`` files or a half-written target.
* **Output folders are created.** A missing output folder (``-o DIR``, or the folder of ``-o FILE``) is created
  with its parents (:func:`output_folder`); a *file* where a folder is expected, or a folder where a file is
  expected, is an error naming it.

This module imports only the standard library (and :mod:`contactrig.core.validation`).
"""

from __future__ import annotations

import errno
import os
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from contactrig.core.validation import SettingError

__all__ = [
    "OutputExistsError",
    "atomic_write",
    "check_new_file",
    "exists_message",
    "output_folder",
    "refuse_existing",
    "write_text_atomic",
]


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
    if p.is_dir():
        raise SettingError("output", str(p), "expected a file name; a folder of that name exists")
    if (p.exists() or p.is_symlink()) and not force:
        raise OutputExistsError(p)
    output_folder(p.parent if str(p.parent) else ".")
    return p


def refuse_existing(paths: Iterable[str | os.PathLike[str]], *, force: bool = False) -> list[Path]:
    """Check every file a command is about to write (:func:`check_new_file`) before it does any work; the first
    existing one is refused unless ``force``. Returns the paths."""
    return [check_new_file(p, force=force) for p in paths]


@contextmanager
def atomic_write(path: str | os.PathLike[str], *, force: bool = False) -> Iterator[Path]:
    """Write ``path`` atomically: ``with atomic_write(p) as tmp: write(tmp)``.

    ``tmp`` is a fresh temporary file in ``path``'s folder; when the block ends without an exception it is renamed
    over ``path`` (refused, as :func:`check_new_file`, if ``path`` exists and not ``force``), otherwise removed.
    """
    target = check_new_file(path, force=force)
    fd, name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    tmp = Path(name)
    os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes it private; the target gets the usual permissions
    try:
        yield tmp
        if target.exists() and not force:  # appeared while we were writing
            raise OutputExistsError(target)
        os.replace(tmp, target)
    finally:
        tmp.unlink(missing_ok=True)


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def write_text_atomic(path: str | os.PathLike[str], text: str, *, force: bool = False) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`atomic_write`); returns the path."""
    with atomic_write(path, force=force) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)
