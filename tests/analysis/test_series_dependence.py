"""The mean rule's subset search (analysis/series_dependence.py) tests many subsets at once: the same answer as one
subset at a time, in the same order."""

import itertools

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from analysis.series_dependence import _mean_source


def _one_at_a_time(v, j, tol, limit=12):
    """The smallest, first (itertools order) set of other columns whose mean is column j, one misprint allowed."""
    m, r = v.shape
    others = [k for k in range(r) if k != j][:limit]
    for size in range(2, len(others) + 1):
        for subset in itertools.combinations(others, size):
            bad = sum(abs(v[i, j] - sum(v[i, k] for k in subset) / size) > tol[i] for i in range(m))
            if bad <= (1 if m >= 4 else 0):
                return subset
    return ()


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    m=st.sampled_from([2, 3, 4, 9]),
    r=st.integers(3, 9),
    planted=st.lists(st.integers(2, 4), max_size=2),
    misprint=st.booleans(),
)
def test_batched_search_finds_what_one_subset_at_a_time_finds(seed, m, r, planted, misprint):
    rng = np.random.default_rng(seed)
    v = np.round(rng.uniform(1.0, 5.0, (m, r)), 3)
    for size in planted:  # a column made the printed mean of others, perhaps with one misprint
        j, *src = rng.choice(r, size=min(size + 1, r), replace=False)
        v[:, j] = np.round(v[:, src].mean(axis=1), 3)
        if misprint:
            v[rng.integers(0, m), j] += 0.5
    tol = np.full(m, 1.0001e-3)
    for j in range(r):
        assert _mean_source(v, j, tol) == _one_at_a_time(v, j, tol)
