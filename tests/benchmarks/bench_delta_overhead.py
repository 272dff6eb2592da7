"""Software overhead of one Delta block on the simulated bench with instrument time set to zero.

Run by hand:  python tests/benchmarks/bench_delta_overhead.py [--counts 10 100 1000 10000] [--repeats 3]

For each count it times, in one run (pair-wise against the baselines):
  chunked    driver reads the buffer with TRAC:DATA:SEL? in chunks sized as Keithley6221.open sizes them on GPIB/LAN
             for a 5 s timeout (fast_chunk_size: 10000), simulator serves replies in chunks
  single     one TRAC:DATA? for the whole buffer (simulator still serves in chunks; a driver subclass below)
  bytewise   chunked driver reads, but replies served by pyvisa-sim's own byte-by-byte session read (a library
             subclass below)
  replay     the same block replayed from a record (driver alone: no simulator, no VISA)
  pymeasure  PyMeasure's Keithley6221 (if installed) running a block with its own API: 12 messages (presence,
             abort, high, delay, count, sets, compliance abort, buffer size, arm, start, one status poll,
             TRAC:DATA?) against the same simulated bench; "vs pymeasure" is our chunked driver's time over it
             (target: <= 1.0 at >= 1000 readings)
and prints time per block and per reading, plus the error of the block mean against I·R (the physics check).
A last table times plain pyvisa-sim (unmodified Device, bytearray.pop(0) per byte) serving an N-pair reply from a
static YAML dialogue: the quadratic read the chunked path avoids.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

import numpy as np
import pyvisa
from pyvisa_sim.highlevel import SimVisaLibrary

from instruments.delta import DeltaSettings
from instruments.k6221 import Keithley6221, fast_chunk_size
from instruments.simulated import GPIB_ADDRESS, BenchVisaLibrary, SimulatedBench
from instruments.transport import RecordingTransport, ReplayTransport, VisaTransport

R_OHM = 5e-3
I_A = 1e-3


class SingleReadK6221(Keithley6221):
    """Baseline driver: the whole buffer with one ``TRAC:DATA?`` instead of chunks of ``TRAC:DATA:SEL?``."""

    def read_buffer(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        if n == 0:
            return np.empty(0), np.empty(0)
        return self._parse("TRAC:DATA?", n)


class BytewiseLibrary(BenchVisaLibrary):
    """Baseline library: the simulated bench's replies served by pyvisa-sim's own byte-by-byte session read."""

    def read(self, session, count):
        return SimVisaLibrary.read(self, session, count)


def run_block(count: int, single: bool, bytewise: bool = False, record: bool = False):
    bench = SimulatedBench(resistance_ohm=R_OHM, seed=1, time_scale=0.0)
    rm = pyvisa.ResourceManager((BytewiseLibrary if bytewise else BenchVisaLibrary).create(bench))
    transport = VisaTransport.open(GPIB_ADDRESS, rm, timeout_ms=60_000)
    rec = RecordingTransport(transport) if record else None
    # chunks as Keithley6221.open sizes them on GPIB/LAN for contactrig's default 5 s timeout
    k = (SingleReadK6221 if single else Keithley6221)(rec or transport, chunk_size=fast_chunk_size(5000))
    settings = DeltaSettings(high_a=I_A, count=count)
    t0 = time.perf_counter()
    block = k.run_delta(settings)
    dt = time.perf_counter() - t0
    k.close()
    return dt, block, (rec.exchanges if rec else None)


def pymeasure_block(count: int):
    """One block with PyMeasure's driver and its own API; None if pymeasure is not installed."""
    try:
        from pymeasure.instruments.keithley import Keithley6221 as PyMeasure6221
    except ImportError:
        return None
    bench = SimulatedBench(resistance_ohm=R_OHM, seed=1, time_scale=0.0)
    k = PyMeasure6221(
        GPIB_ADDRESS,
        visa_library=BenchVisaLibrary.create(bench),
        timeout=60_000,
        read_termination="\n",
        write_termination="\n",
    )
    t0 = time.perf_counter()
    assert k.delta_connected
    k.delta_abort()
    k.delta_high_source = I_A
    k.delta_delay = 2e-3
    k.delta_cycles = count
    k.delta_measurement_sets = 1
    k.delta_compliance_abort_enabled = True
    k.delta_buffer_points = count
    k.delta_arm()
    k.delta_start()
    while not int(k.operation_events) & 2:
        time.sleep(1e-3)
    values = np.array(k.delta_values)
    dt = time.perf_counter() - t0
    k.delta_abort()
    k.adapter.close()
    readings = values[0::2]
    assert readings.size == count
    return dt, float(np.mean(readings))


def count_messages(count: int) -> int:
    """Messages our driver sends for one block (recorded)."""
    return len(run_block(count, single=False, record=True)[2])


def replay_block(exchanges, count: int):
    chunk = fast_chunk_size(5000)
    k = Keithley6221(ReplayTransport(exchanges), clock=lambda: 0.0, sleep=lambda s: None, chunk_size=chunk)
    t0 = time.perf_counter()
    block = k.run_delta(DeltaSettings(high_a=I_A, count=count))
    return time.perf_counter() - t0, block


def plain_pyvisa_sim(n_pairs: int) -> float:
    import pyvisa

    reply = ",".join(["+5.000000E-06,+1.234000E+00"] * n_pairs)
    text = (
        'spec: "1.1"\ndevices:\n  d:\n    eom:\n      GPIB INSTR:\n        q: "\\n"\n        r: "\\n"\n'
        f'    dialogues:\n      - q: "TRAC:DATA?"\n        r: "{reply}"\n'
        "resources:\n  GPIB0::5::INSTR:\n    device: d\n"
    )
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"plain{n_pairs}.yaml"
        path.write_text(text)
        rm = pyvisa.ResourceManager(f"{path}@sim")
        res = rm.open_resource("GPIB0::5::INSTR", read_termination="\n", write_termination="\n", timeout=600_000)
        t0 = time.perf_counter()
        out = res.query("TRAC:DATA?")
        dt = time.perf_counter() - t0
        assert len(out) == len(reply)
        rm.close()
    return dt


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--counts", type=int, nargs="+", default=[10, 100, 1000, 10000])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--bytewise-max", type=int, default=10000, help="skip the bytewise baseline above this count")
    args = ap.parse_args()

    print(f"Delta block overhead, simulated bench, time_scale=0, median of {args.repeats}; R = {R_OHM} Ω, I = {I_A} A")
    print(f"{'count':>7} {'mode':>9} {'per block':>12} {'per reading':>13} {'vs chunked':>11} {'|mean/IR - 1|':>14}")
    summary = []
    for count in args.counts:
        rows = {}
        modes = [("chunked", False, False), ("single", True, False)]
        if count <= args.bytewise_max:
            modes.append(("bytewise", False, True))
        exchanges = None
        for name, single, bytewise in modes:
            times, block = [], None
            for _ in range(args.repeats):
                dt, block, ex = run_block(count, single, bytewise, record=(name == "chunked" and exchanges is None))
                exchanges = exchanges or ex
                times.append(dt)
            rows[name] = (statistics.median(times), block)
        rt = [replay_block(exchanges, count) for _ in range(args.repeats)]
        rows["replay"] = (statistics.median(t for t, _ in rt), rt[0][1])
        base = rows["chunked"][0]
        for name, (t, block) in rows.items():
            err = abs(block.mean / (I_A * R_OHM) - 1)
            print(
                f"{count:>7} {name:>9} {t * 1e3:>9.2f} ms {t / count * 1e6:>10.1f} µs {t / base:>10.2f}x {err:>14.2e}"
            )
        pm = [pymeasure_block(count) for _ in range(args.repeats)]
        if pm[0] is not None:
            t = statistics.median(x[0] for x in pm if x is not None)
            err = abs(pm[0][1] / (I_A * R_OHM) - 1)
            per = t / count * 1e6
            print(f"{count:>7} {'pymeasure':>9} {t * 1e3:>9.2f} ms {per:>10.1f} µs {t / base:>10.2f}x {err:>14.2e}")
            summary.append((count, count_messages(count), base, t))

    if summary:
        print("\nours (chunked) against PyMeasure's driver, same bench, instrument time 0")
        print(f"{'count':>7} {'our msgs':>9} {'ours':>10} {'pymeasure':>10} {'ours/pymeasure':>15}")
        for count, n_msgs, ours, theirs in summary:
            print(f"{count:>7} {n_msgs:>9} {ours * 1e3:>7.2f} ms {theirs * 1e3:>7.2f} ms {ours / theirs:>14.2f}x")

    print("\nplain pyvisa-sim 0.7 (byte-by-byte, bytearray.pop(0)) serving one N-pair TRAC:DATA? reply")
    for n in (1000, 5000, 20000):
        t = plain_pyvisa_sim(n)
        print(f"{n:>7} pairs {t:>8.3f} s  ({t / n * 1e6:.1f} µs per pair)")


if __name__ == "__main__":
    main()
