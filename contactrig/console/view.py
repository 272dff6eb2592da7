"""What the console's pages show of a session, made by the functions the terminal uses, so the page and the terminal
say the same thing: block numbers from :func:`daq.records.block_number` (1-based), resistances formatted by
:func:`daq.engine.format_mean_ohm` and :func:`daq.engine.format_ohm` (the SEM with the SI prefix that shows it,
``± 4.67 nΩ``), and a session being written by another process (``contactrig acquire`` in a terminal) followed from
its file with ``contactrig watch``'s state (:func:`analysis.watch.state_from_session`, its status line and ETA).

Units: resistance in Ω, weight in kg, times in s.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import Any

__all__ = ["block_row", "fit_curves", "follow", "strict_json", "summary_rows"]

#: summary columns a page gets per block (the rest stay in the file)
BLOCK_COLUMNS = ("block", "run", "weight_kg", "repeat", "mean_ohm", "sem_ohm", "n", "n_invalid", "compliance")


def _finite(x: Any) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def block_row(block: int, run: int, weight_kg: float, repeat: int, mean_ohm: float | None, sem_ohm: float | None,
              n: int, n_invalid: int, compliance: bool) -> dict[str, Any]:  # fmt: skip
    """One block as a page shows it: the stored values (``block``: 0-based position in the plan, as the file has
    it; NaN → None) with ``number`` (1-based, as the terminal prints it) and ``mean_text``/``sem_text`` (the
    terminal's formatting; empty where there is no value)."""
    from daq.engine import format_mean_ohm, format_ohm
    from daq.records import block_number

    mean, sem = _finite(mean_ohm), _finite(sem_ohm)
    return {
        "block": int(block), "number": block_number(int(block)), "run": int(run), "weight_kg": float(weight_kg),
        "repeat": int(repeat), "mean_ohm": mean, "sem_ohm": sem, "n": int(n), "n_invalid": int(n_invalid),
        "compliance": bool(compliance), "mean_text": "" if mean is None else format_mean_ohm(mean),
        "sem_text": "" if sem is None else format_ohm(sem),
    }  # fmt: skip


def summary_rows(summary: Any) -> list[dict[str, Any]]:
    """:func:`block_row` of every row of a session's summary table (``Session.summary``)."""
    k = len(summary)
    col = {c: summary[c].tolist() if c in summary.columns else [0] * k for c in BLOCK_COLUMNS}
    return [block_row(col["block"][i], col["run"][i], col["weight_kg"][i], col["repeat"][i], col["mean_ohm"][i],
                      col["sem_ohm"][i], col["n"][i], col["n_invalid"][i], bool(col["compliance"][i]))
            for i in range(k)]  # fmt: skip


def _command(session: Any) -> str:
    runs = [r for r in session.runs if isinstance(r, dict)] if isinstance(session.runs, list) else []
    last = runs[-1] if runs else session.start
    return str(last.get("command") or "")


def follow(path: Path, now: float | None = None) -> dict[str, Any]:
    """The state of the session file ``path`` as ``contactrig watch`` sees it, read lock-free while another process
    writes it (:func:`daq.session_file.load_session`): status, the watch status line, blocks so far, blocks planned,
    the ETA [s] (None: not yet known, or not running), the last block's readings, the command that writes it and what
    the reader said (``warnings``)."""
    from analysis.watch import state_from_session, status_line
    from daq.session_file import load_session

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "RUNNING session" is what this page is for; the notes are in the state
        session = load_session(path, timeout=30)
    state = state_from_session(session)
    readings = [_finite(x) for x in state.current_ohm[-2000:].tolist()]
    return {
        "file": path.name, "status": session.status, "running": session.status == "running",
        "status_line": status_line(state, now), "eta_s": state.eta_s(now), "blocks": summary_rows(session.summary),
        "blocks_planned": state.blocks_planned, "readings_ohm": readings, "command": _command(session),
        "host": str(session.start.get("host") or ""), "sample": str(session.start.get("sample") or ""),
        "warnings": list(session.warnings), "adaptive": _adaptive(session),
    }  # fmt: skip


def _adaptive(session: Any) -> dict[str, Any] | None:
    """An adaptive session's evidence and, once ended, its stop reason, from the file
    (:func:`analysis.adaptive_session.session_state`, strict JSON: non-finite numbers null); None for a fixed plan,
    ``{"error": …}`` when the design cannot be rebuilt from the file (the page says so)."""
    from analysis.adaptive_session import session_state

    if not isinstance(session.start, dict) or not isinstance(session.start.get("adaptive"), dict):
        return None
    try:
        state = session_state(session)
    except Exception as exc:  # a damaged or newer record: said on the page, the rest of the page stays
        return {"error": f"the adaptive record could not be read: {type(exc).__name__}: {exc}"}
    return None if state is None else strict_json(state)


def strict_json(value: Any) -> Any:
    """``value`` (the analysis's JSON-like state) as strict JSON: a non-finite number becomes null."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {str(k): strict_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict_json(v) for v in value]
    return value


def fit_curves(fit_json: dict[str, Any]) -> list[dict[str, Any]]:
    """Each model's fitted resistance at the measured weights, from ``contactrig fit --json`` (``models.*.points``:
    R = R_s + s·x(A), the fit's own prediction): ``[{model, weight_kg, fitted_ohm}]`` in the fit's order, the
    ranking's first model first; ``model`` is the model's display label (:func:`sims.models.model_label`)."""
    from sims.models import model_label

    models = fit_json.get("models") if isinstance(fit_json, dict) else None
    if not isinstance(models, dict):
        return []
    ranking = [m for m in fit_json.get("ranking") or [] if m in models]
    order = ranking + [m for m in models if m not in ranking]
    out = []
    for name in order:
        points = models[name].get("points") or {}
        w, r = points.get("weight_kg") or [], points.get("fitted_ohm") or []
        pairs = sorted((float(a), _finite(b)) for a, b in zip(w, r, strict=False))
        out.append({"model": model_label(str(name)), "weight_kg": [a for a, _ in pairs],
                    "fitted_ohm": [b for _, b in pairs]})  # fmt: skip
    return out
