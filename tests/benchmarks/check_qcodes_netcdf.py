"""Open a session exported with ``contactrig export SESSION.h5 --to netcdf`` in QCoDeS, as a QCoDeS user does, and
print what QCoDeS sees (issue 29: "readable by ... the QCoDeS/xarray tool chain").

Needs only QCoDeS (and h5netcdf, which QCoDeS's netCDF loader uses), e.g. in a venv of its own, since QCoDeS is
not a dependency of contactrig:

    python3 -m venv /tmp/qcvenv && /tmp/qcvenv/bin/pip install qcodes h5netcdf
    contactrig acquire --sim --yes --sim-speed inf -o /tmp/q/a.h5
    contactrig export /tmp/q/a.h5 --to netcdf -o /tmp/q/a.nc
    /tmp/qcvenv/bin/python tests/benchmarks/check_qcodes_netcdf.py /tmp/q/a.nc

It loads the file with ``qcodes.dataset.load_from_netcdf`` (a throw-away database for QCoDeS's configuration),
checks the guid's format and that ``to_xarray_dataset()`` gives every variable of the file with the same values
(as xarray reads the file), makes the pandas frames, and prints the run's identity. Exit code 0 when all of it
works, 1 otherwise. The same round trip against the session's own values is ``test_qcodes_loads_the_export`` in
tests/analysis/test_session_dataset.py (it runs where QCoDeS is installed).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import warnings
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("netcdf", type=Path, help="a file written by contactrig export --to netcdf")
    args = ap.parse_args(argv)

    import numpy as np
    import qcodes
    import xarray as xr
    from qcodes.dataset import load_from_netcdf
    from qcodes.dataset.guids import parse_guid, validate_guid_format

    with tempfile.TemporaryDirectory() as tmp:
        q = load_from_netcdf(args.netcdf, path_to_db=Path(tmp) / "qcodes.db")
        validate_guid_format(q.guid)
        print(f"QCoDeS {qcodes.__version__}: loaded {args.netcdf}")
        print(f"  guid {q.guid} (time field: {parse_guid(q.guid)['time']} ms)")
        print(f"  exp_name {q.exp_name!r}, name {q.name!r}, sample_name {q.sample_name!r}")
        print(f"  run {q.run_timestamp()} .. completed {q.completed_timestamp()} (raw {q.run_timestamp_raw} .. "
              f"{q.completed_timestamp_raw})")  # fmt: skip
        deps = q.description.interdeps.dependencies
        print(f"  {len(deps)} dependent parameters; setpoints: "
              f"{sorted({s.name for v in deps.values() for s in v})}")  # fmt: skip
        station = q.snapshot["station"]["instruments"] if q.snapshot else {}
        models = {k: v["parameters"]["IDN"]["value"]["model"] for k, v in station.items()}
        print(f"  instruments in the snapshot: {models or 'none'}")
        print(f"  metadata keys: {len(q.metadata)}")
        x = q.to_xarray_dataset()
        with xr.open_dataset(args.netcdf, engine="h5netcdf") as f:
            bad = [str(v) for v in f.variables if not np.array_equal(np.asarray(x[v]), np.asarray(f[v]),
                                                                     equal_nan=f[v].dtype.kind == "f")]  # fmt: skip
        print(f"  to_xarray_dataset: {dict(x.sizes)}, {len(x.data_vars)} data variables; differing: {bad or 'none'}")
        frames = q.to_pandas_dataframe_dict()
        print(f"  to_pandas_dataframe_dict: {', '.join(f'{k} {v.shape}' for k, v in list(frames.items())[:3])}, …")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            one = q.to_pandas_dataframe()
        said = "; QCoDeS warns: " + str(caught[0].message).split(".")[0] if caught else ""
        print(f"  to_pandas_dataframe: {one.shape}{said}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
