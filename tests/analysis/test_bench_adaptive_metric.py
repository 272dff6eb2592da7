"""The benchmark's "reaches the fixed plan's decisive rate at" figure (issue 27, tests/benchmarks/bench_adaptive.py),
checked against the definition written out directly: the earliest stop time t at which the share of sessions that
ended decisive by t is at least the fixed plan's rate."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

_PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_adaptive.py"
_spec = importlib.util.spec_from_file_location("bench_adaptive", _PATH)
assert _spec is not None and _spec.loader is not None
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)


def _by_definition(sessions, rate):
    n = len(sessions)
    for t in sorted({t for d, t, _ in sessions if d}):
        if sum(1 for d, u, _ in sessions if d and u <= t) / n >= rate - 1e-12:
            return t, sum(1 for d, u, w in sessions if d and w and u <= t) / n
    return math.nan, math.nan


def test_a_small_case_by_hand():
    # 8 sessions, 3 decisive at 10, 30 and 20 min (the 30-min one wrong): a fixed rate of 25 % is 2 sessions
    s = [(True, 600.0, False), (False, 100.0, False), (True, 1800.0, True), (True, 1200.0, False)]
    s += [(False, 50.0, False)] * 4
    assert bench.time_to_rate(s, 0.25) == (1200.0, 0.0)
    assert bench.time_to_rate(s, 0.375) == (1800.0, 1 / 8)
    assert all(math.isnan(x) for x in bench.time_to_rate(s, 0.5))  # only 3 of 8 decisive: never reached
    assert all(math.isnan(x) for x in bench.time_to_rate(s, 0.0))  # nothing to reach


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.booleans(), st.floats(0, 3600, allow_nan=False), st.booleans()), min_size=1, max_size=40),
       st.floats(0.001, 1.0))  # fmt: skip
def test_agrees_with_the_definition(sessions, rate):
    got, want = bench.time_to_rate(sessions, rate), _by_definition(sessions, rate)
    np.testing.assert_equal(np.array(got), np.array(want))
