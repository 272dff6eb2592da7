"""The session file, as one import: the schema (:mod:`daq.session_schema`), the writer (:mod:`daq.session_writer`)
and the checking reader (:mod:`daq.session_reader`)."""

from __future__ import annotations

from daq.session_reader import Session, exchange_list, load_session
from daq.session_schema import FORMAT_NAME, SCHEMA_VERSION, UPGRADES, software_versions
from daq.session_writer import SessionFile

__all__ = [
    "FORMAT_NAME",
    "SCHEMA_VERSION",
    "UPGRADES",
    "Session",
    "SessionFile",
    "exchange_list",
    "load_session",
    "software_versions",
]
