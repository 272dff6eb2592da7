"""``contactrig instruments …`` subcommands (registered by ``contactrig.cli.main``): a thin layer over the drivers.

``identify`` works with any registered instrument pair (``--pair``, :mod:`instruments.pairs`); ``delta`` runs one
Delta block on the Keithley 6221/2182A; ``serve-sim`` serves the simulated bench on a TCP socket like the 6221's LAN
port. ``--visa-library`` (e.g. ``@py`` for pyvisa-py) picks the VISA library wherever instruments are opened.

Nothing heavy is imported at module level: pyvisa and numpy load only when a command runs.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import TYPE_CHECKING

from contactrig.cli.options import add_deprecated_alias, add_json_option

if TYPE_CHECKING:
    from instruments.block import Block
    from instruments.pairs import InstrumentPair, PairDriver

SIM_DEFAULT_ADDRESS = "GPIB0::12::INSTR"


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this package's subcommands to ``subparsers``."""
    parser = subparsers.add_parser(
        "instruments",
        help="talk to the Keithley 6221/2182A (or the simulated bench)",
        description="Identify the 6221/2182A pair or run one Delta block. --sim uses the simulated bench.",
    )
    sub = parser.add_subparsers(dest="instruments_command", metavar="ACTION")
    parser.set_defaults(handler=lambda args: _help(parser))

    ident = sub.add_parser("identify", help="*IDN? of the 6221 and (relayed) the 2182A, or of another pair")
    _common(ident)
    ident.add_argument("--pair", default=None, help="registered instrument pair (default: the 6221/2182A)")
    add_json_option(ident, "the two identities")
    ident.set_defaults(handler=identify_command)

    delta = sub.add_parser("delta", help="run one Delta block and print its statistics")
    _common(delta)
    delta.add_argument("--current", type=float, required=True, metavar="A", help="high current in A (low = -high)")
    delta.add_argument("--count", type=int, required=True, metavar="N", help="Delta readings, 1 … 65536")
    delta.add_argument("--delay", type=float, default=2e-3, metavar="S", help="delay per step in s (default 0.002)")
    delta.add_argument("--nplc", type=float, default=1.0, help="2182A integration time in PLC (default 1)")
    delta.add_argument("--compliance", type=float, default=10.0, metavar="V", help="compliance in V (default 10)")
    delta.add_argument("--unit", choices=("V", "OHMS"), default="V", help="reading unit (default V)")
    delta.add_argument("--json", action="store_true", help="print readings and statistics as JSON")
    delta.set_defaults(handler=delta_command)

    ver = sub.add_parser(
        "verify",
        help="day-one check: run on the real pair what the manuals leave open; write a transcript and a report",
        description=(
            "Runs the checks of instruments.verify (status bits of a compliance abort, *OPC? and Delta, relay "
            "framing, OHMS divisor, arming without a 2182A, rate against NPLC, RANG:AUTO in Delta, timestamp "
            "resolution) and writes verify.json (with the transcript) and verify.md. Checks that drive current "
            "use --current (default 100 µA, at most 1 mA) with a 1 V compliance: connect a load of at most 1 kΩ. "
            "The source is left idle (SOUR:SWE:ABOR) whatever happens."
        ),
    )
    _common(ver)
    ver.add_argument("--current", type=float, default=1e-4, metavar="A", help="test current (default 1e-4 A)")
    ver.add_argument(
        "-o", "--output", default="verify-report", metavar="DIR", help="report directory (default verify-report)"
    )
    add_deprecated_alias(ver, "--out", "-o/--output", "output")
    ver.set_defaults(handler=verify_command)

    serve = sub.add_parser(
        "serve-sim",
        help="serve the simulated 6221/2182A on a TCP socket (LF-terminated, like the 6221's LAN port 1394)",
        description=(
            "Serve the simulated bench at TCPIP0::HOST::PORT::SOCKET until Ctrl-C. Only loopback hosts unless "
            "--allow-remote (the simulator has no authentication)."
        ),
    )
    serve.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    serve.add_argument("--port", type=int, default=1394, help="TCP port (default 1394; 0 = a free one)")
    serve.add_argument("--allow-remote", action="store_true", help="allow a host other than loopback")
    serve.add_argument("--seed", type=int, default=0, help="noise seed of the simulated bench")
    serve.add_argument("--resistance", type=float, default=5e-3, metavar="OHM", help="sample resistance (5e-3)")
    serve.add_argument(
        "--sim-speed", type=_speed, default=1.0, metavar="X",
        help="simulated instrument time runs X times faster than real (1 = real pace, inf = no waiting; default 1), "
        "as acquire --sim-speed",
    )  # fmt: skip
    add_deprecated_alias(serve, "--time-scale", "--sim-speed X (X = 1/time-scale)", "sim_speed", _inverse_scale)
    serve.set_defaults(handler=serve_sim_command)


def _speed(text: str) -> float:
    from contactrig.cli.sessions import _speed as speed

    return speed(text)


def _inverse_scale(text: str) -> float:
    """Deprecated ``--time-scale S`` (real s per instrument s; 0 = instant) as a ``--sim-speed``: 1/S."""
    s = float(text)
    if not s >= 0 or s == math.inf:
        raise ValueError("expected real seconds per instrument second >= 0")
    return math.inf if s == 0 else 1.0 / s


def _help(parser: argparse.ArgumentParser) -> int:
    parser.print_help()
    return 2


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("address", nargs="?", metavar="ADDRESS", help="VISA address of the 6221 (e.g. GPIB0::12::INSTR)")
    p.add_argument("--sim", action="store_true", help="use the simulated bench (default address GPIB0::12::INSTR)")
    p.add_argument("--timeout-ms", type=int, default=5000, help="VISA timeout in ms (default 5000)")
    p.add_argument("--seed", type=int, default=0, help="noise seed of the simulated bench (with --sim)")
    p.add_argument(
        "--visa-library",
        default="",
        metavar="LIB",
        help="VISA library to open ADDRESS with, e.g. @py (pyvisa-py) or a path to NI-VISA (default: pyvisa's choice)",
    )


def _open(args: argparse.Namespace, pair: InstrumentPair) -> PairDriver:
    """The pair's driver at ADDRESS (or on its simulated bench with --sim), checked before anything is opened."""
    import time

    from contactrig.core.validation import SettingError, check_int
    from instruments.transport import VisaTransport

    check_int("--timeout-ms", args.timeout_ms, 1, 3_600_000)
    check_int("--seed", args.seed, 0, 2**63 - 1)
    address = args.address
    rm = None
    if address is not None and "::" not in address:
        raise SettingError(
            "ADDRESS", address, "expected a VISA resource such as GPIB0::12::INSTR or TCPIP0::<ip>::1394::SOCKET"
        )
    if args.sim:
        if args.visa_library:
            raise SettingError("--visa-library", args.visa_library, "leave it out with --sim (the simulated bench)")
        address = address or SIM_DEFAULT_ADDRESS
        rm = pair.simulate(seed=args.seed, time_scale=0.0).resource_manager
    elif not address:
        what = f"give the {pair.source_name}'s VISA address, or --sim for the simulated bench"
        raise SettingError("ADDRESS", None, what)
    transport = VisaTransport.open(address, rm, args.timeout_ms, visa_library=args.visa_library)
    options = {"chunk_size": transport.serial.chunk_size(args.timeout_ms)} if transport.serial is not None else {}
    try:
        return pair.open_driver(transport, clock=time.monotonic, sleep=time.sleep, **options)
    except BaseException:  # nothing was sent, but the connection must not leak
        transport.close()
        raise


def identify_command(args: argparse.Namespace) -> int:
    """Print the identity of the source and of the voltmeter."""
    from contactrig.core.text import escape_terminal
    from instruments.pairs import DEFAULT_PAIR, get_pair

    with _open(args, get_pair(args.pair or DEFAULT_PAIR)) as k:
        ident = k.identify()
    if args.json:
        print(json.dumps({"source": ident.source, "voltmeter": ident.voltmeter}))
        return 0
    print(f"source:    {escape_terminal(ident.source)}")  # replies are data: no control character reaches the terminal
    print(f"voltmeter: {escape_terminal(ident.voltmeter)}")
    return 0


def delta_command(args: argparse.Namespace) -> int:
    """Run one Delta block; print mean, SD, SEM, N and the invalid count (or JSON with --json)."""
    from contactrig.core.validation import SettingError
    from instruments.delta import DeltaSettings
    from instruments.pairs import DEFAULT_PAIR, get_pair

    try:  # validated before any connection is opened
        settings = DeltaSettings(
            high_a=args.current,
            count=args.count,
            delay_s=args.delay,
            nplc=args.nplc,
            compliance_v=args.compliance,
            unit=args.unit,
        )
    except SettingError as exc:
        flag = _FLAGS.get(exc.field)
        if flag is None:
            raise
        raise SettingError(f"{flag} ({exc.field})", exc.value, exc.allowed) from None
    with _open(args, get_pair(DEFAULT_PAIR)) as k:
        block = k.run_block(settings)
    print(format_block(block, as_json=args.json))
    return 0


def verify_command(args: argparse.Namespace) -> int:
    """Run the day-one checks; print the Markdown report; exit 0 if every check ran and the source is idle."""
    from pathlib import Path

    from contactrig.core.text import escape_terminal
    from contactrig.core.validation import check_range
    from instruments.pairs import DEFAULT_PAIR, get_pair
    from instruments.verify import verify, write_report

    current = check_range("--current", args.current, 0.0, 1e-3, lo_open=True, unit="A")
    driver = _open(args, get_pair(DEFAULT_PAIR))
    transport = driver.transport  # type: ignore[attr-defined]
    report = verify(transport, args.address or SIM_DEFAULT_ADDRESS, current_a=current)
    driver._closed = True  # type: ignore[attr-defined]  # verify closed the transport after its last SOUR:SWE:ABOR
    js, md = write_report(report, Path(args.output))
    print(escape_terminal(report.markdown(), keep_newlines=True))  # it quotes instrument replies
    print(f"written: {js} and {md}")
    if report.passed:
        return 0
    print(f"contactrig instruments verify: error: a check failed or could not run; see {md}", file=sys.stderr)
    return 2  # the exit-code contract: 0 done, 1 stopped early, 2 error


def serve_sim_command(args: argparse.Namespace) -> int:
    """Serve the simulated bench until Ctrl-C (a clean stop: exit 0)."""
    import sys

    from contactrig.core.validation import check_int, check_range
    from instruments.server import SimServer
    from instruments.simulated import SimulatedBench

    check_int("--seed", args.seed, 0, 2**63 - 1)
    speed = args.sim_speed  # > 0 or inf, checked by _speed
    scale = 0.0 if math.isinf(speed) else check_range("--sim-speed", 1.0 / speed, 0.0)  # real s per instrument s
    bench = SimulatedBench(resistance_ohm=args.resistance, seed=args.seed, time_scale=scale)
    server = SimServer(args.host, args.port, bench=bench, allow_remote=args.allow_remote).start()
    print(f"serving the simulated 6221/2182A at {server.address} (Ctrl-C stops)", flush=True)
    try:
        server.serve_until_stopped()
    except KeyboardInterrupt:
        print("stopped", file=sys.stderr, flush=True)
    return 0


_FLAGS = {
    "high_a": "--current",
    "low_a": "--current",
    "count": "--count",
    "delay_s": "--delay",
    "nplc": "--nplc",
    "compliance_v": "--compliance",
    "unit": "--unit",
}


def _num(x: float) -> float | None:
    return None if not math.isfinite(x) else float(x)


def format_block(block: Block, as_json: bool = False) -> str:
    """Text (or JSON) summary of a block (:class:`instruments.block.Block`); NaN becomes JSON null."""
    from instruments.block import block_statistics

    st = block_statistics(block.readings, block.valid)
    if as_json:
        from contactrig.cli.options import json_units

        return json.dumps(
            {
                "units": json_units(readings=block.unit, mean=block.unit, sd=block.unit, sem=block.unit),
                "readings": [_num(x) for x in block.readings.tolist()],
                "mean": _num(st.mean),
                "sd": _num(st.sd),
                "sem": _num(st.sem),
                "n": st.n,
                "n_invalid": st.n_invalid,
                "unit": block.unit,
            }
        )
    u = block.unit
    mean_ohm = block_statistics(block.resistance_ohm(), block.valid).mean
    return "\n".join(
        [
            f"mean      {st.mean:.6e} {u}",
            f"SD        {st.sd:.3e} {u}",
            f"SEM       {st.sem:.3e} {u}",
            f"N         {st.n}",
            f"invalid   {st.n_invalid}",
            f"R (mean)  {mean_ohm:.6e} Ω",
        ]
    )
