"""The stability atlas is a test: every extreme case must give what it declares (finite, warning or error)."""

import numpy as np
import pytest

from analysis.studies.atlas import Case, run_atlas
from analysis.studies.atlas_cases import all_cases


@pytest.mark.parametrize("case", all_cases(), ids=lambda c: f"{c.method}:{c.name}")
def test_atlas_case(case):
    (outcome,) = run_atlas([case], limit_s=60.0)
    assert outcome.ok, f"{case.method} / {case.name}: expected {case.expect}, got {outcome.got}: {outcome.detail}"


def test_classifier_flags_nan_negative_and_wrong_exception():
    cases = [
        Case("nan", "m", "", lambda: np.array([1.0, np.nan]), "finite"),
        Case("neg", "m", "", lambda: np.array([-1.0]), "finite"),
        Case("neg allowed", "m", "", lambda: np.array([-1.0]), "finite", non_negative=False),
        Case("type", "m", "", lambda: {}["missing"], "error"),
        Case("value", "m", "", lambda: int("x"), "error"),
    ]
    got = [o.got for o in run_atlas(cases)]
    assert got == ["FAIL", "FAIL", "finite", "FAIL", "error"]


def test_classifier_flags_a_hang():
    import time

    (o,) = run_atlas([Case("hang", "m", "", lambda: time.sleep(5), "finite")], limit_s=0.2)
    assert o.got == "FAIL" and "no answer" in o.detail
