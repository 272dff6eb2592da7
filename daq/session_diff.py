"""Why two sessions differ: scene, overrides, instrument identities and settings, software versions, side by side.

``contactrig sessions A.h5 --diff B.h5`` and the console call :func:`session_diff`. Both files are read with the one
bounded reader (:func:`daq.index.session_and_entry`) and described as the run index describes them
(:func:`daq.run_index.record_of`); nested settings are compared key by key (``settings.pinned_state.2182A.:SYST:AZER
ON``), so a difference is named by the setting, not by its table. The last fit of each (``contactrig fit``'s verdict,
best model and analysis version, beside the session: :func:`daq.run_index.last_fit`) is compared too.
"""

from __future__ import annotations

import difflib
from pathlib import Path
from typing import Any

from contactrig.core.text import escape_terminal

__all__ = ["COMPARED", "format_diff", "session_diff"]

#: What is compared, in this order (top-level keys of :func:`daq.run_index.session_record`).
COMPARED = ("status", "sample", "operator", "scene", "scene_sha256", "overrides", "instruments", "settings",
            "software", "fit")  # fmt: skip
_SCENE_LINES = 40


def _flat(value: Any, prefix: str) -> dict[str, Any]:
    if isinstance(value, dict) and value:
        out: dict[str, Any] = {}
        for k in sorted(value, key=str):
            out.update(_flat(value[k], f"{prefix}.{k}"))
        return out
    return {prefix: value}


def session_diff(a: str | Path, b: str | Path, *, timeout: float | None = None) -> dict[str, Any]:
    """``{"a": path, "b": path, "differences": [{"field", "a", "b"}…], "same": n, "scene_lines": […],
    "notes": […]}``: every compared field (dotted) whose values differ (a value missing on one side is null there),
    the number of fields that agree, and the lines of the scene text that differ (``- `` in A, ``+ `` in B). A file
    that cannot be read is refused (:class:`~daq.errors.SessionFileError` naming it), as for every command."""
    from daq.index import session_and_entry
    from daq.run_index import last_fit, record_of

    sides = []
    for path in (Path(a), Path(b)):
        session, entry = session_and_entry(path, timeout=timeout)
        if session is None:
            from daq.errors import SessionFileError

            raise SessionFileError(entry.note or f"{path}: not a readable session ({entry.status})")
        record = record_of(path, session, entry)
        fit = last_fit(path, record["content_id"])
        record["fit"] = {k: fit[k] for k in ("verdict", "best", "analysis_version")} if fit else None
        sides.append((record, session.scene_text))
    (ra, sa), (rb, sb) = sides
    fa = {k: v for key in COMPARED for k, v in _flat(ra.get(key), key).items()}
    fb = {k: v for key in COMPARED for k, v in _flat(rb.get(key), key).items()}
    differences = [{"field": k, "a": fa.get(k), "b": fb.get(k)} for k in _ordered(fa, fb) if fa.get(k) != fb.get(k)]
    lines = [ln.rstrip("\n") for ln in difflib.ndiff(sa.splitlines(), sb.splitlines()) if ln.startswith(("- ", "+ "))][
        :_SCENE_LINES
    ]
    return {
        "a": str(a), "b": str(b), "differences": differences, "same": len(set(fa) | set(fb)) - len(differences),
        "scene_lines": lines, "notes": [],
    }  # fmt: skip


def _ordered(fa: dict[str, Any], fb: dict[str, Any]) -> list[str]:
    keys = list(fa) + [k for k in fb if k not in fa]
    return sorted(keys, key=lambda k: (COMPARED.index(k.split(".")[0]), k))


def _show(value: Any) -> str:
    return "—" if value is None else str(value)


def format_diff(diff: dict[str, Any]) -> str:
    """The diff as aligned text for the terminal (every string from the files escaped)."""
    rows = [[escape_terminal(c) for c in (d["field"], _show(d["a"]), _show(d["b"]))] for d in diff["differences"]]
    head = ["field", "A: " + escape_terminal(diff["a"]), "B: " + escape_terminal(diff["b"])]
    widths = [min(60, max(len(r[i]) for r in [head, *rows])) for i in range(3)]
    out = ["  ".join(c.ljust(w) for c, w in zip(head, widths, strict=True)).rstrip()]
    out += ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in rows]
    if not rows:
        out.append("(no differences)")
    out.append(f"{diff['same']} field(s) the same")
    if diff["scene_lines"]:
        out.append("scene text:")
        out += [f"  {escape_terminal(ln)}" for ln in diff["scene_lines"]]
    out += [f"note: {n}" for n in diff["notes"]]
    return "\n".join(out)
