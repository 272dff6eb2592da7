"""The console's guards: the access token, the origin of state-changing requests, and which files may be served.

It controls a current source, so (after Jupyter's model): a random token, printed once and stored 0600, is needed
by every request (compared in constant time); a state-changing request must also come from the console's own
origin (no cross-site request forgery); the Host header must be one the console answers to (DNS rebinding; off
loopback, the names are listed with ``--allowed-host``); only regular files under the console's folder are served — a
path that is absolute, climbs out (``..``) or passes through a symbolic link is refused. Each console stores its token
in a file of its own port (two consoles on one machine do not overwrite each other's).
"""

from __future__ import annotations

import hmac
import ipaddress
import os
import re
import secrets
import stat
from pathlib import Path, PurePosixPath

__all__ = [
    "TOKEN_FILE_NAME",
    "check_host_name",
    "check_token",
    "new_token",
    "remove_token",
    "resolve_under",
    "same_origin",
    "store_token",
]

_HOST_NAME = re.compile(r"^(?=.{1,253}$)[a-z0-9]([a-z0-9-]{0,61}[a-z0-9])?(\.[a-z0-9]([a-z0-9-]{0,61}[a-z0-9])?)*\.?$")

TOKEN_FILE_NAME = "console-token"


def new_token() -> str:
    """A fresh random token (256 bits, URL-safe)."""
    return secrets.token_urlsafe(32)


def check_token(given: str | None, token: str) -> bool:
    """``given`` is the token (constant-time comparison; None or empty is never)."""
    if not given:
        return False
    return hmac.compare_digest(given.encode("utf-8", "surrogatepass"), token.encode("utf-8"))


def store_token(token: str, folder: Path, port: int | None = None) -> Path:
    """Write the token to ``folder``/console-token-PORT (without a port: console-token), mode 0600 from its creation,
    never through a link; the folder is created private (0700)."""
    folder.mkdir(parents=True, exist_ok=True, mode=0o700)
    path = folder / (TOKEN_FILE_NAME if port is None else f"{TOKEN_FILE_NAME}-{port}")
    tmp = folder / f".{TOKEN_FILE_NAME}.{secrets.token_hex(6)}"
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600)
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(token + "\n")
    os.replace(tmp, path)
    return path


def remove_token(path: Path, token: str) -> None:
    """Remove the stored token file when it still holds ``token`` (another console may have taken the port since)."""
    try:
        if path.read_text(encoding="utf-8").strip() == token:
            path.unlink()
    except OSError:
        pass


def check_host_name(text: str) -> str:
    """A name a browser may use for the console in its Host header (``--allowed-host``): a DNS name or an IP
    address, without scheme or port; lower-cased (IPv6 without brackets). ValueError names the option."""
    name = text.strip().lower()
    bare = name[1:-1] if name.startswith("[") and name.endswith("]") else name
    try:
        return str(ipaddress.ip_address(bare))
    except ValueError:
        pass
    if not _HOST_NAME.match(name):
        raise ValueError(f"--allowed-host = {text!r}: expected a host name or IP address (no scheme, no port)")
    return name


def same_origin(origin: str | None, host: str | None, allowed_hosts: frozenset[str]) -> bool:
    """A state-changing request's ``Origin`` is the console itself: ``http://HOST`` where HOST is the request's
    ``Host`` header and one the console answers to (a missing Origin is refused)."""
    if not origin or not host or host not in allowed_hosts:
        return False
    return hmac.compare_digest(origin, f"http://{host}")


def resolve_under(root: Path, relative: str) -> Path | None:
    """The regular file ``relative`` names under ``root``, or None: refused are absolute paths, ``..``, empty or
    hidden parts, NUL, a symbolic link anywhere on the way, and anything that is not a regular file."""
    if not relative or "\x00" in relative or "\\" in relative:
        return None
    pure = PurePosixPath(relative)
    if pure.is_absolute() or any(part in ("", ".", "..") or part.startswith(".") for part in pure.parts):
        return None
    path = root
    for part in pure.parts:
        path = path / part
        try:
            st = os.lstat(path)
        except OSError:
            return None
        if stat.S_ISLNK(st.st_mode):
            return None
    if not stat.S_ISREG(os.lstat(path).st_mode):
        return None
    real_root, real = os.path.realpath(root), os.path.realpath(path)
    if os.path.commonpath([real_root, real]) != real_root:
        return None
    return path
