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
    # the rest of the 6221 and 2182A SCPI summaries
    "FILT": "FILTER",
    "STAR": "START",
    "STOP": "STOP",
    "STEP": "STEP",
    "SPAN": "SPAN",
    "CENT": "CENTER",
    "SPAC": "SPACING",
    "LIST": "LIST",
    "APP": "APPEND",
    "WIDT": "WIDTH",
    "SDEL": "SDELAY",
    "INT": "INTERVAL",
    "LME": "LMEASURE",
    "RESP": "RESPONSE",
    "TRIP": "TRIPPED",
    "FREE": "FREE",
    "NOT": "NOTIFY",
    "MA1F": "MA1FACTOR",
    "MA0F": "MA0FACTOR",
    "LAT": "LATEST",
    "TEXT": "TEXT",
    "BORD": "BORDER",
    "SREG": "SREGISTER",
    "KEY": "KEY",
    "KCL": "KCLICK",
    "BEEP": "BEEPER",
    "VERS": "VERSION",
    "RES": "RESET",
    "LOC": "LOCAL",
    "REM": "REMOTE",
    "RWL": "RWLOCK",
    "BAUD": "BAUD",
    "POS": "POSETUP",
    "CODE": "CODE",
    "ALL": "ALL",
    "DIS": "DISABLE",
    "DIR": "DIRECTION",
    "ILIN": "ILINE",
    "TIM": "TIMER",
    "TRIG": "TRIGGER",
    "DIG": "DIGITS",
    "APER": "APERTURE",
    "REF": "REFERENCE",
    "ACQ": "ACQUIRE",
    "TEMP": "TEMPERATURE",
    "TC": "TCOUPLE",
    "RJUN": "RJUNCTION",
    "RSEL": "RSELECT",
    "SIM": "SIMULATED",
    "TRAN": "TRANSDUCER",
    "FAZ": "FAZERO",
    "SAMP": "SAMPLE",
    "SEQ": "SEQUENCE",
}
_BY_LONG = {v: k for k, v in _LONG.items()}
_BY_LONG["STATE"] = "STAT"  # STATe and STATus share the short form
_BY_LONG |= {"INTERLOCK": "INT", "CONTINUOUS": "CONT", "BEEP": "BEEP", "RWLS": "RWL"}  # other shared short forms

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
    "STAT:QUE:NEXT": "STAT:QUE",
    "STAT:QUES": "STAT:QUES:EVEN",
    "SOUR:CURR:AMPL": "SOUR:CURR",
    "SOUR:CURR:LEV:AMPL": "SOUR:CURR",
    "SOUR:CURR:LEV:IMM": "SOUR:CURR",
    "SOUR:WAVE:PMAR:LEV": "SOUR:WAVE:PMAR",
    "SOUR:CLE:IMM": "SOUR:CLE",
    "SOUR:CURR:FILT:STAT": "SOUR:CURR:FILT",
    "CALC1:KMAT:MA1F": "CALC1:KMAT:MMF",
    "CALC1:KMAT:MA0F": "CALC1:KMAT:MBF",
    "CALC1:DATA:LAT": "CALC1:DATA",
    "SENS:DATA:LAT": "SENS:DATA",
    "SYST:BEEP:IMM": "SYST:BEEP",
    "SENS:TEMP:TC:TYPE": "SENS:TEMP:TC",
    "TRIG:SEQ:SOUR": "TRIG:SOUR",
    "TRIG:SEQ:COUN": "TRIG:COUN",
    "TRIG:SEQ:DEL": "TRIG:DEL",
    "TRIG:SEQ:DEL:AUTO": "TRIG:DEL:AUTO",
    "TRIG:SEQ:TIM": "TRIG:TIM",
    "TRIG:SEQ:DIR": "TRIG:DIR",
    "TRIG:SEQ:ILIN": "TRIG:ILIN",
    "TRIG:SEQ:OLIN": "TRIG:OLIN",
    "TRIG:SEQ:OUTP": "TRIG:OUTP",
    "DISP:TEXT": "DISP:TEXT:DATA",
    "DISP:WIND2:TEXT": "DISP:WIND2:TEXT:DATA",
}
_HEADER = re.compile(r"\s*(:?[*A-Za-z][A-Za-z0-9_:*]*\??)\s*(.*)\Z", re.S)


@dataclass(frozen=True)
class Command:
    """One command of a message: canonical ``header`` (short form, no leading colon, ``?`` kept), raw ``params``."""

    header: str
    params: str
    raw: str
    #: the text holds a character that is not printable ASCII outside a quoted string (SCPI −101)
    invalid_character: bool = False

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

    Unparseable pieces come back with an empty header so the simulator can queue "Undefined header"; a piece with
    a character outside printable ASCII (tab allowed) that is not inside a quoted string is flagged
    ``invalid_character`` (IEEE 488.2 program messages are 7-bit ASCII; only string data may hold 8-bit bytes).
    Short messages are cached (a driver repeats the same few messages block after block).
    """
    if len(message) > _CACHED_LENGTH:
        return _parse(message)
    return list(_parse_cached(message))


_CACHED_LENGTH = 512
_OUTSIDE_QUOTES_BAD = re.compile(r"[^\t\x20-\x7e]")
_QUOTED = re.compile(r"\"[^\"]*\"|'[^']*'")


def _has_invalid_character(piece: str) -> bool:
    if not _OUTSIDE_QUOTES_BAD.search(piece):
        return False
    return bool(_OUTSIDE_QUOTES_BAD.search(_QUOTED.sub("", piece)))


@lru_cache(maxsize=1024)
def _parse_cached(message: str) -> tuple[Command, ...]:
    return tuple(_parse(message))


def _parse(message: str) -> list[Command]:
    commands: list[Command] = []
    path: list[str] = []
    for piece in _split_outside_quotes(message, ";"):
        if piece.strip():
            command, path = _parse_piece(piece, path)
            commands.append(command)
    return commands


def _parse_piece(piece: str, path: list[str]) -> tuple[Command, list[str]]:
    """One command of a compound message and the path the next one continues from."""
    if _has_invalid_character(piece):
        return Command("", piece.strip(), piece, invalid_character=True), path
    m = _HEADER.match(piece)
    if not m:
        return Command("", piece.strip(), piece), path
    header, params = m.group(1), m.group(2).strip()
    query = "?" if header.endswith("?") else ""
    header = header.rstrip("?")
    if header.startswith("*"):
        return Command(header.upper() + query, params, piece), path
    nodes = header[1:].split(":") if header.startswith(":") else path + header.split(":")
    if any(not n for n in nodes):
        return Command("", piece.strip(), piece), path
    nodes = [_canonical_node(n) for n in nodes]
    return Command(_canonical_path(nodes) + query, params, piece), nodes[:-1]


def _canonical_path(nodes: list[str]) -> str:
    """The header the simulator implements for these canonical nodes (optional nodes filled in or dropped)."""
    if nodes[:2] == ["SENS", "VOLT"] and len(nodes) > 2 and nodes[2] in ("DC", "CHAN1"):
        nodes = nodes[:2] + nodes[3:]
    if nodes[:2] == ["SENS", "VOLT"] and len(nodes) > 2 and nodes[2] == "CHAN1":
        nodes = nodes[:2] + nodes[3:]
    if nodes[0] == "SENS1":  # SENSe[1], DISPlay[:WINDow[1]], CALCulate[1]: optional suffixes and nodes
        nodes = ["SENS", *nodes[1:]]
    if nodes[0] == "DISP" and len(nodes) > 1 and nodes[1] in ("WIND", "WIND1"):
        nodes = ["DISP", *nodes[2:]]
    if nodes[0] == "CALC" and len(nodes) > 1:
        nodes = ["CALC1", *nodes[1:]]
    canon = ":".join(nodes)
    return _ALIASES.get(canon, canon)
