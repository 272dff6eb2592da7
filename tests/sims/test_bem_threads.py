"""Issue 28, target 1 ("every core"): the BEM solver's element-wise passes run in cache-sized blocks of rows on the
``workers`` threads (:meth:`sims.bem_backend.Backend.rows`), and the fields do not depend on the thread count.

The solutions themselves are checked against outside references in tests/sims/test_bem.py (Westergaard, Hertz) and
tests/sims/test_bem_backend.py (a bound-constrained quadratic program); here: the blocks cover every row once and in
order, the work of a solve is spread over every worker, and 1 or 3 workers give bit-identical fields (the blocks
depend on the grid only, so every sum is taken in the same order).
"""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from sims import bem, bem_backend

from .test_bem import rough_surface


@pytest.mark.parametrize("n", [4, 256, 1024, 2050])
@pytest.mark.parametrize("workers", [1, 2, 3, 16])
def test_rows_cover_every_row_once_in_order(n, workers):
    be = bem_backend.get_backend("cpu", workers)
    seen = be.rows(lambda r: (r.start, r.stop), n)
    starts = [a for a, _ in seen]
    assert starts[0] == 0 and seen[-1][1] == n
    assert all(b == a for (_, b), a in zip(seen[:-1], starts[1:], strict=True))  # contiguous, in order
    assert all(b > a for a, b in seen)


def test_rows_spread_the_blocks_over_every_worker_and_the_namespace_path_makes_one_call():
    n = 1024  # 33 cache-sized blocks
    calls: list[int] = []
    lock = threading.Lock()

    def record(r: slice) -> int:
        with lock:
            calls.append(threading.get_ident())
        time.sleep(0.002)  # a block's work: the groups overlap in time
        return r.start

    be = bem_backend.get_backend("cpu", 3)
    starts = be.rows(record, n)
    assert starts == sorted(starts) and len(starts) > 3
    assert len(set(calls)) == 3 and threading.get_ident() in calls  # the caller takes one group
    assert bem_backend.get_backend("cpu", 1).rows(lambda r: threading.get_ident(), n) == [threading.get_ident()] * len(
        starts
    )
    generic = bem_backend.get_backend(workers=3, xp=np)
    assert generic.rows(lambda r: r, n) == [slice(None)]


def test_the_element_wise_work_of_a_solve_runs_on_every_worker(monkeypatch):
    threads: set[int] = set()
    original = bem_backend.Backend.rows

    def rows(self, fn, *shape):  # the rows and the row width
        def traced(r):
            threads.add(threading.get_ident())
            return fn(r)

        return original(self, traced, *shape)

    monkeypatch.setattr(bem_backend.Backend, "rows", rows)
    n = 256  # three blocks of rows
    z = rough_surface(n, seed=3)
    res = bem.solve_contact(z, 1.0 / n, 1.0, 0.0025, tol=1e-8, workers=2)
    assert res.success
    assert len(threads) == 2 and threading.get_ident() in threads
    threads.clear()
    bem.solve_contact(z, 1.0 / n, 1.0, 0.0025, tol=1e-8, workers=1)
    assert threads == {threading.get_ident()}


@pytest.mark.parametrize("hardness", [None, 0.03])
def test_fields_do_not_depend_on_the_thread_count(hardness):
    n = 256
    z = rough_surface(n, seed=5)
    one = bem.solve_contact(z, 1.0 / n, 1.0, 0.0025, hardness=hardness, tol=1e-9, workers=1)
    three = bem.solve_contact(z, 1.0 / n, 1.0, 0.0025, hardness=hardness, tol=1e-9, workers=3)
    generic = bem.solve_contact(z, 1.0 / n, 1.0, 0.0025, hardness=hardness, tol=1e-9, workers=3, xp=np)
    assert one.success and three.success and generic.success
    assert one.nit == three.nit
    assert np.array_equal(one.pressure, three.pressure) and np.array_equal(one.gap, three.gap)
    scale = float(one.pressure.max())
    assert float(np.abs(generic.pressure - one.pressure).max()) <= 1e-6 * scale
    assert generic.area_fraction == one.area_fraction
