"""Fakes for driver tests: a scripted transport (PyMeasure ``expected_protocol`` style) and a fake clock."""

from __future__ import annotations

import pytest

READ = object()  # marks an expected bare read in a script

#: The 6221's pinned-state read-back query and the answer of an instrument that took every setting (spelled out
#: here, from the manual's commands, not taken from the driver).
SOURCE_STATE_QUERY = "SOUR:DELT:CSW?;:SENS:AVER:STAT?;:CALC1:STAT?;:TRAC:FEED?;:TRAC:TST:FORM?"
SOURCE_READBACK = "0;0;0;SENS1;ABS"
#: The 2182A's relayed read-back query (NPLC, channel, digital filter, analog filter, autozero) and its answer at
#: NPLC 1.
VOLTMETER_STATE_QUERY = ":SENS:VOLT:NPLC?;:SENS:CHAN?;:SENS:VOLT:DFIL:STAT?;:SENS:VOLT:LPAS?;:SYST:AZER?"
VOLTMETER_READBACK = "+1.000000E+00;1;0;0;1"


class FakeClock:
    """Monotonic clock advanced only by ``sleep``; ``on_sleep`` may inject an exception (e.g. Ctrl-C)."""

    def __init__(self) -> None:
        self.t = 0.0
        self.sleeps: list[float] = []
        self.on_sleep = None

    def __call__(self) -> float:
        return self.t

    def sleep(self, dt: float) -> None:
        self.sleeps.append(dt)
        self.t += dt
        if self.on_sleep is not None:
            self.on_sleep(len(self.sleeps))


class ScriptedTransport:
    """Serves a list of ``(command, reply)`` pairs in order and fails on any other command.

    A pair with reply ``None`` is a write; ``(READ, reply)`` is a bare read.
    """

    def __init__(self, pairs: list[tuple[object, str | None]]) -> None:
        self.pairs = list(pairs)
        self.sent: list[str] = []
        self.closed = False

    def _next(self, kind: str, message: str | None) -> str | None:
        assert self.pairs, f"unexpected {kind} {message!r}: the script is exhausted (sent so far: {self.sent})"
        command, reply = self.pairs.pop(0)
        if kind == "read":
            assert command is READ, f"expected {command!r}, the driver read"
        else:
            self.sent.append(message)
            assert command == message, f"expected {command!r}, the driver sent {kind} {message!r}"
            assert (reply is None) == (kind == "write"), (
                f"{message!r}: expected a {'write' if reply is None else 'query'}"
            )
        return reply

    def write(self, message: str) -> None:
        self._next("write", message)

    def query(self, message: str) -> str:
        return self._next("query", message)

    def read(self) -> str:
        return self._next("read", None)

    def close(self) -> None:
        self.closed = True


def split_message(message: str) -> list[str]:
    """The commands of a compound SCPI message: split on ``;`` outside quotes, leading ``:`` dropped."""
    parts, buf, quoted = [], "", False
    for ch in message:
        if ch == '"':
            quoted = not quoted
        if ch == ";" and not quoted:
            parts.append(buf)
            buf = ""
        else:
            buf += ch
    return [p.strip().lstrip(":") for p in [*parts, buf] if p.strip()]


def _is_query(command: str) -> bool:
    return command.split(" ", 1)[0].endswith("?")


class ResponderTransport:
    """Answers queries from a table (value or callable), command by command within compound messages (the
    replies of one message joined by ``;``, as an instrument does); logs every command in ``sent`` and every
    message in ``messages``. A table key that is itself a compound query answers its parts with the parts of its
    reply.

    The 2182A relay answers the default settings' read-back (NPLC = 1 and the pinned state), and so does the 6221's
    state read-back, unless the table says otherwise.
    """

    def __init__(self, replies: dict[str, object]) -> None:
        table = {
            "SYST:COMM:SER:ENT?": VOLTMETER_READBACK + "\r",
            SOURCE_STATE_QUERY: SOURCE_READBACK,
            "*OPC?": "1",
            "STAT:MEAS:EVEN?": "0",
            **replies,
        }
        self.replies: dict[str, object] = {}
        for key, reply in table.items():
            keys = split_message(key)
            if len(keys) > 1 and isinstance(reply, str):
                self.replies.update(zip(keys, reply.split(";"), strict=True))
            else:
                self.replies[key] = reply
        self.sent: list[str] = []
        self.messages: list[str] = []
        self.closed = False

    def write(self, message: str) -> None:
        self.messages.append(message)
        self.sent.extend(split_message(message))

    def query(self, message: str) -> str:
        self.messages.append(message)
        out = []
        for command in split_message(message):
            self.sent.append(command)
            if _is_query(command):
                reply = self.replies[command]
                out.append(reply() if callable(reply) else reply)
        return ";".join(out)

    def read(self) -> str:
        raise AssertionError("unexpected read")

    def close(self) -> None:
        self.closed = True


@pytest.fixture
def clock() -> FakeClock:
    return FakeClock()
