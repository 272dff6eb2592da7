"""``contactrig instruments verify``: the day-one check against ``serve-sim`` over loopback (pyvisa-py), and the
bench-safety guarantee that SOUR:SWE:ABOR is the last command on every path, including a failure mid-check."""

from __future__ import annotations

import time

import pytest

pytest.importorskip("pyvisa_py")
import pyvisa

from contactrig.cli.main import main
from instruments.server import SimServer
from instruments.simulated import GPIB_ADDRESS, SimulatedBench, simulated_resource_manager
from instruments.transport import VisaTransport
from instruments.verify import CHECKS, verify


class Logged:
    """Wraps a transport and logs every message; ``interrupt_on`` raises KeyboardInterrupt when that text is sent."""

    def __init__(self, inner, interrupt_on: str = "") -> None:
        self.inner, self.interrupt_on, self.sent = inner, interrupt_on, []

    def _log(self, message: str) -> None:
        self.sent.append(message)
        if self.interrupt_on and self.interrupt_on in message:
            raise KeyboardInterrupt

    def write(self, message):
        self._log(message)
        self.inner.write(message)

    def query(self, message):
        self._log(message)
        return self.inner.query(message)

    def read(self):
        return self.inner.read()

    def close(self):
        self.inner.close()


def test_verify_passes_against_serve_sim_over_loopback(tmp_path):
    t0 = time.monotonic()
    with SimServer(port=0, bench=SimulatedBench(seed=1, time_scale=0.0)) as server:
        rm = pyvisa.ResourceManager("@py")
        transport = Logged(VisaTransport.open(server.address, rm, 2000))
        report = verify(transport, server.address)
    assert report.passed, [(c.name, c.error) for c in report.checks if not c.ran]
    assert [c.name for c in report.checks] == [name for name, *_ in CHECKS]
    assert transport.sent[-1] == "SOUR:SWE:ABOR" and report.transcript[-1]["message"] == "SOUR:SWE:ABOR"
    ident = report.checks[0].found
    assert "MODEL 6221" in ident["6221"] and "MODEL 2182A" in ident["2182A"]
    assert time.monotonic() - t0 < 30


def test_each_check_ends_with_abort_even_when_it_fails():
    bench = SimulatedBench(seed=1)
    bench.faults.silent.add("TRAC:DATA:SEL?")  # every buffer read times out
    transport = Logged(VisaTransport.open(GPIB_ADDRESS, simulated_resource_manager(bench), 100))
    report = verify(transport, GPIB_ADDRESS)
    failed = [c.name for c in report.checks if not c.ran]
    assert failed and not report.passed and report.source_left_idle
    assert transport.sent[-1] == "SOUR:SWE:ABOR"
    # every timed-out buffer read is followed by SOUR:SWE:ABOR before anything else is configured
    for i, message in enumerate(transport.sent):
        if message.startswith("TRAC:DATA:SEL?"):
            assert transport.sent[i + 1] == "SOUR:SWE:ABOR" or transport.sent[i + 1].startswith("SOUR:SWE:ABOR")


def test_ctrl_c_mid_check_ends_with_abort():
    transport = Logged(
        VisaTransport.open(GPIB_ADDRESS, simulated_resource_manager(SimulatedBench()), 500), interrupt_on="INIT:IMM"
    )
    with pytest.raises(KeyboardInterrupt):
        verify(transport, GPIB_ADDRESS)
    assert transport.sent[-1] == "SOUR:SWE:ABOR"


def test_unsafe_current_refused_before_anything_is_sent():
    transport = Logged(VisaTransport.open(GPIB_ADDRESS, simulated_resource_manager(SimulatedBench()), 500))
    with pytest.raises(ValueError, match="current_a"):
        verify(transport, GPIB_ADDRESS, current_a=0.01)
    assert transport.sent == []


def test_cli_verify_sim_writes_report(tmp_path, capsys):
    assert main(["instruments", "verify", "--sim", "-o", str(tmp_path)]) == 0
    assert (tmp_path / "verify.json").exists() and "compliance abort" in (tmp_path / "verify.md").read_text()
