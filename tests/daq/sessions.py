"""Helpers that write small sessions through the real acquisition path (drive + FileWriter) on the simulated bench."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

from daq.acquire import drive
from daq.plan import SessionPlan, session_steps
from daq.session_file import Session, SessionFile, load_session
from daq.writers import FileWriter

from .conftest import make_link


def start_record(plan: SessionPlan) -> dict:
    return {"started": "2026-01-01T00:00:00.000+00:00", "operator": "tester", "host": "test", "plan": plan.describe()}


def write_session(plan: SessionPlan, path: Path, *, steps=None, link=None, prompter=None, interrupts=None, run=0):
    """Run ``plan`` (or ``steps``) on a simulated link into ``path``; return (outcome, link)."""
    link = link or make_link(plan)
    sf = SessionFile.create(path) if run == 0 else SessionFile.open_for_resume(path)
    kwargs = {}
    if prompter is not None:
        kwargs["prompter"] = prompter
    try:
        sf.run = run if run else sf.run
        outcome = drive(
            link,
            plan.block_settings,
            steps if steps is not None else session_steps(plan),
            [FileWriter(sf)],
            start_record(plan),
            plan.scene.text,
            run=sf.run,
            interrupts=interrupts,
            blocks_planned=plan.blocks_planned,
            **kwargs,
        )
    finally:
        sf.close()
    return outcome, link


def load_quietly(path: Path) -> Session:
    """``load_session`` without its warnings (incomplete or aborted sessions warn on purpose)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_session(path)


def written_commands(path: Path) -> list[str]:
    """Every command written to the instrument, in order, as recorded in the session file (read with h5py)."""
    import h5py

    with h5py.File(path, "r") as h5:
        kinds = h5["entry/exchanges/kind"].asstr()[:]
        messages = h5["entry/exchanges/message"].asstr()[:]
    return [m for k, m in zip(kinds, messages, strict=True) if k == "write"]


def _rewrite_stop(path: Path, edit) -> None:
    import h5py

    from daq.session_writer import _json_dataset

    with h5py.File(path, "a") as h5:
        stop = json.loads(h5["entry/stop/record"][()])
        edit(h5, stop)
        _json_dataset(h5["entry/stop"], "record", stop)


def unseal(path: Path) -> None:
    """Remove the stop record's seal, as files written before schema 3 have none (tests that fake older files)."""
    _rewrite_stop(path, lambda h5, stop: stop.pop("seal", None))


def reseal(path: Path) -> None:
    """Recompute the seal after a test edited the file: what a deliberate forgery (or a changed driver, for replay's
    own comparison) would look like — the seal is a checksum, not a signature."""
    from daq.session_reader import read_raw as _read_raw
    from daq.session_schema import seal as _seal

    def edit(h5, stop):
        stop.pop("seal", None)
        stop["seal"] = _seal(_read_raw(h5, path, stop_override=stop), stop)

    _rewrite_stop(path, edit)
