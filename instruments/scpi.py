"""SCPI message parsing for the simulated bench, spelled the way the real instruments accept it.

Case-insensitive headers, long or short mnemonics (``SOURce:DELTa:DELay`` = ``SOUR:DELT:DEL``), an optional
leading colon, compound messages split on ``;`` outside quoted strings, and the SCPI path rule: after ``;`` a
header that does not start with ``:`` or ``*`` continues at the level of the previous command. Optional nodes
(``INIT[:IMMediate]``, ``STATus:OPERation[:EVENt]?``, ``SYSTem:ERRor[:NEXT]?``, ``SENSe:VOLTage[:DC]``) are
filled in so that every command reaches the simulator in one canonical short form.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import lru_cache

__all__ = ["Command", "parse_message", "split_params", "unquote"]

# Long forms of the mnemonics the simulated 6221 and 2182A know; the short form is the canonical one.
_LONG = {
    "ABOR": "ABORT",
    "ACT": "ACTUAL",
    "AMPL": "AMPLITUDE",
    "ARM": "ARM",
    "AUTO": "AUTO",
    "AVER": "AVERAGE",
    "CALC": "CALCULATE",
    "AZER": "AZERO",
    "CAB": "CABORT",
    "CHAN": "CHANNEL",
    "CLE": "CLEAR",
    "CONT": "CONTROL",
    "COMM": "COMMUNICATE",
    "COMP": "COMPLIANCE",
    "COND": "CONDITION",
    "COUN": "COUNT",
    "CSW": "CSWITCH",
    "CURR": "CURRENT",
    "DATA": "DATA",
    "DC": "DC",
    "DEL": "DELAY",
    "DFIL": "DFILTER",
    "DELT": "DELTA",
    "ELEM": "ELEMENTS",
    "ENAB": "ENABLE",
    "ENT": "ENTER",
    "ERR": "ERROR",
    "EVEN": "EVENT",
    "FEED": "FEED",
    "FORM": "FORMAT",
    "FRES": "FRESH",
    "FUNC": "FUNCTION",
    "HIGH": "HIGH",
    "IMM": "IMMEDIATE",
    "ISH": "ISHIELD",
    "INIT": "INITIATE",
    "KMAT": "KMATH",
    "LEV": "LEVEL",
    "LOW": "LOW",
    "LPAS": "LPASS",
    "MBF": "MBFACTOR",
    "LSYN": "LSYNC",
    "LTE": "LTEARTH",
    "MEAS": "MEASUREMENT",
    "MMF": "MMFACTOR",
    "NEXT": "NEXT",
    "NPLC": "NPLCYCLES",
    "NVPR": "NVPRESENT",
    "OPER": "OPERATION",
    "OUTP": "OUTPUT",
    "POIN": "POINTS",
    "PRES": "PRESET",
    "RANG": "RANGE",
    "SEL": "SELECTED",
    "SEND": "SEND",
    "SENS": "SENSE",
    "SER": "SERIAL",
    "SOUR": "SOURCE",
    "STAT": "STATUS",
    "SWE": "SWEEP",
    "SYST": "SYSTEM",
    "TCON": "TCONTROL",
    "TRAC": "TRACE",
    "TST": "TSTAMP",
    "UNIT": "UNIT",
    "VOLT": "VOLTAGE",
    "WAVE": "WAVE",
    "WIND": "WINDOW",
    # added for the rest of the documented command set (status, waveform, display, 2182A)
    "QUE": "QUEUE",
    "QUES": "QUESTIONABLE",
    "DISP": "DISPLAY",
    "FREQ": "FREQUENCY",
    "OFFS": "OFFSET",
    "DCYC": "DCYCLE",
    "DUR": "DURATION",
    "TIME": "TIME",
    "CYCL": "CYCLES",
    "PMAR": "PMARKER",
    "OLIN": "OLINE",
    "TYPE": "TYPE",
    "LFR": "LFREQUENCY",
    "READ": "READ",
    "FETC": "FETCH",
    "DCON": "DCONDUCTANCE",
    "PDEL": "PDELTA",
}
_BY_LONG = {v: k for k, v in _LONG.items()}
_BY_LONG["STATE"] = "STAT"  # STATe and STATus share the short form

# Optional nodes: canonical path without them -> the path the simulator implements.
_ALIASES = {
    "INIT": "INIT:IMM",
    "STAT:OPER": "STAT:OPER:EVEN",
    "STAT:MEAS": "STAT:MEAS:EVEN",
    "SYST:ERR:NEXT": "SYST:ERR",
    "SOUR:CURR:LEV": "SOUR:CURR",
    "SOUR:CURR:LEV:IMM:AMPL": "SOUR:CURR",
    "SENS:AVER": "SENS:AVER:STAT",
    "CALC": "CALC1",
    "CALC:STAT": "CALC1:STAT",
    "CALC:KMAT:MMF": "CALC1:KMAT:MMF",
    "CALC:KMAT:MBF": "CALC1:KMAT:MBF",
    "SYST:AZER:STAT": "SYST:AZER",
    "SENS:VOLT:DFIL": "SENS:VOLT:DFIL:STAT",
    "SENS:VOLT:LPAS:STAT": "SENS:VOLT:LPAS",
    "CALC2:IMM:DATA": "CALC2:DATA",
    "OUTP:STAT": "OUTP",
    "UNIT:VOLT": "UNIT",
    "UNIT:VOLT:DC": "UNIT",
    "STAT:QUE:NEXT": "STAT:QUE",
    "STAT:QUES": "STAT:QUES:EVEN",
    "SOUR:CURR:AMPL": "SOUR:CURR",
    "SOUR:CURR:LEV:AMPL": "SOUR:CURR",
    "SOUR:CURR:LEV:IMM": "SOUR:CURR",
    "SOUR:WAVE:PMAR:LEV": "SOUR:WAVE:PMAR",
}
_HEADER = re.compile(r"\s*(:?[*A-Za-z][A-Za-z0-9_:*]*\??)\s*(.*)\Z", re.S)


@dataclass(frozen=True)
class Command:
    """One command of a message: canonical ``header`` (short form, no leading colon, ``?`` kept), raw ``params``."""

    header: str
    params: str
    raw: str

    @property
    def is_query(self) -> bool:
        return self.header.endswith("?")

    @property
    def text(self) -> str:
        """Canonical text: header, and parameters after one space."""
        return f"{self.header} {self.params}" if self.params else self.header


def _split_outside_quotes(text: str, sep: str) -> list[str]:
    parts, buf, quote = [], [], ""
    for ch in text:
        if quote:
            buf.append(ch)
            if ch == quote:
                quote = ""
        elif ch in "\"'":
            quote = ch
            buf.append(ch)
        elif ch == sep:
            parts.append("".join(buf))
            buf = []
        else:
            buf.append(ch)
    parts.append("".join(buf))
    return parts


def split_params(params: str) -> list[str]:
    """Split a parameter list on commas outside quoted strings; strip blanks."""
    if not params.strip():
        return []
    return [p.strip() for p in _split_outside_quotes(params, ",")]


def unquote(param: str) -> str:
    """The content of a SCPI string parameter; a doubled quote inside stands for one quote."""
    p = param.strip()
    if len(p) >= 2 and p[0] == p[-1] and p[0] in "\"'":
        q = p[0]
        return p[1:-1].replace(q + q, q)
    return p


@lru_cache(maxsize=4096)
def _canonical_node(node: str) -> str:
    up = node.upper()
    m = re.fullmatch(r"([A-Z]+)(\d*)", up)
    if not m:
        return up
    word, suffix = m.groups()
    if word in _LONG:
        return word + suffix
    if word in _BY_LONG:
        return _BY_LONG[word] + suffix
    return up


def parse_message(message: str) -> list[Command]:
    """Split a (possibly compound) program message into canonical commands, applying the SCPI path rule.

    Unparseable pieces come back with an empty header so the simulator can queue "Undefined header". Parsed
    messages are cached (a driver repeats the same few messages block after block).
    """
    return list(_parse_cached(message))


@lru_cache(maxsize=1024)
def _parse_cached(message: str) -> tuple[Command, ...]:
    return tuple(_parse(message))


def _parse(message: str) -> list[Command]:
    commands: list[Command] = []
    path: list[str] = []
    for piece in _split_outside_quotes(message, ";"):
        if not piece.strip():
            continue
        m = _HEADER.match(piece)
        if not m:
            commands.append(Command("", piece.strip(), piece))
            continue
        header, params = m.group(1), m.group(2).strip()
        query = header.endswith("?")
        if query:
            header = header[:-1]
        if header.startswith("*"):
            commands.append(Command(header.upper() + ("?" if query else ""), params, piece))
            continue
        if header.startswith(":"):
            nodes = header[1:].split(":")
        else:
            nodes = path + header.split(":")
        if any(not n for n in nodes):
            commands.append(Command("", piece.strip(), piece))
            continue
        nodes = [_canonical_node(n) for n in nodes]
        path = nodes[:-1]
        if nodes[:2] == ["SENS", "VOLT"] and len(nodes) > 2 and nodes[2] == "DC":
            nodes = nodes[:2] + nodes[3:]
        if nodes[:2] == ["SENS", "VOLT"] and len(nodes) > 2 and nodes[2] == "CHAN1":
            nodes = nodes[:2] + nodes[3:]
        canon = ":".join(nodes)
        canon = _ALIASES.get(canon, canon)
        commands.append(Command(canon + ("?" if query else ""), params, piece))
    return commands
