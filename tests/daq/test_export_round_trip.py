"""Issue 20 items 10 and 11: ``export --to csv`` writes each stored value as the shortest text that ``contactrig
import`` reads back to the same double, adds mean, SD, SEM and n per weight, and carries sample, operator, notes and
scene name in its ``#`` lines, which ``import`` reads back (``sessions`` shows the same metadata for both files)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from contactrig.cli.main import main
from daq.export import csv_field, shortest_text
from daq.plan import SessionPlan
from daq.table_import import DIGITS_PER_OHM, RESISTANCE_BOUNDS_OHM, parse_table
from daq.table_provenance import read_provenance

from .conftest import small_scene
from .sessions import load_quietly, write_session

LO, HI = RESISTANCE_BOUNDS_OHM


@settings(max_examples=300, deadline=None)
@given(value=st.floats(LO, HI, allow_nan=False, allow_infinity=False), unit=st.sampled_from(sorted(DIGITS_PER_OHM)))
def test_every_double_reads_back_exactly_from_the_shortest_text(value, unit):
    text = csv_field(shortest_text(value, DIGITS_PER_OHM[unit]))
    table = parse_table(f"weight_kg,M1_{unit}\n1,{text}\n")  # the import's own reader
    assert table.resistance_ohm[0, 0] == value
    # shortest: as many significant digits as Python's repr of the double (the shortest round-trip decimal)
    digits = lambda s: len(s.lower().split("e")[0].replace("-", "").replace(".", "").strip("0"))  # noqa: E731
    assert digits(text) == digits(repr(value))


def test_the_issue_value_and_a_noisy_product():
    assert csv_field(shortest_text(7.8427035773e-3, 3)) == "7.8427035773"  # not 7.842703577299999 or …01
    assert repr(7.8427035773e-3 * 1e3) != "7.8427035773"  # what the old export wrote came from this product
    assert csv_field(shortest_text(2.1e-3, 3)) == "2.1" and csv_field(shortest_text(0.01, 3)) == "10"


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    folder = tmp_path_factory.mktemp("round")
    original = folder / "original.h5"
    write_session(SessionPlan.from_scene(small_scene(sample='sample = "-Ra 0.2 µm, \\"liner A\\""')), original)
    out = folder / "out.csv"
    assert main(["export", str(original), "-o", str(out)]) == 0
    return original, out


def test_summary_statistics_per_weight(exported):
    original, out = exported
    lines = [ln for ln in out.read_text(encoding="utf-8").splitlines() if not ln.startswith("#")]
    header = [h.strip('"') for h in lines[0].split(",")]
    s = load_quietly(original).summary
    for line in lines[1:]:
        row = dict(zip(header, line.split(","), strict=True))
        x = s.loc[s["weight_kg"] == float(row["weight_kg"]), "mean_ohm"].to_numpy() * 1e3  # mΩ
        assert int(row["n"]) == x.size == 2
        assert float(row["mean_mohm"]) == pytest.approx(np.mean(x), rel=1e-14)
        assert float(row["sd_mohm"]) == pytest.approx(np.std(x, ddof=1), rel=1e-12)
        assert float(row["sem_mohm"]) == pytest.approx(np.std(x, ddof=1) / math.sqrt(2), rel=1e-12)


def _entry(folder, name, capsys):
    capsys.readouterr()
    assert main(["sessions", str(folder), "--json"]) == 0
    entries = {e["path"].rsplit("/", 1)[-1]: e for e in json.loads(capsys.readouterr().out)}
    return {k: entries[name][k] for k in ("sample", "operator", "notes", "scene")}


def test_import_reads_back_sample_operator_notes_and_scene(exported, tmp_path, capsys):
    original, out = exported
    prov = read_provenance(out.read_text(encoding="utf-8"))
    assert prov["sample"] == '-Ra 0.2 µm, "liner A"' and prov["scene"] == "daq-test"  # the ' before - is removed
    back = tmp_path / "back.h5"
    assert main(["import", str(out), "-o", str(back)]) == 0
    (tmp_path / "original.h5").write_bytes(original.read_bytes())
    a, b = _entry(tmp_path, "original.h5", capsys), _entry(tmp_path, "back.h5", capsys)
    assert a == b and a["sample"] == '-Ra 0.2 µm, "liner A"' and a["operator"] == "tester" and a["scene"] == "daq-test"
    assert load_quietly(back).start["operator_source"] == "table"


def test_notes_travel_and_operator_option_wins(exported, tmp_path, capsys):
    _, out = exported
    text = out.read_text(encoding="utf-8")
    assert '# notes:,""' in text  # the session has none: an empty record
    text = text.replace('# notes:,""', '# notes:,"dry run; new liner"', 1)
    edited = tmp_path / "notes.csv"
    edited.write_text(text, encoding="utf-8")
    first, second = tmp_path / "a" / "first.h5", tmp_path / "b" / "second.h5"
    first.parent.mkdir()
    second.parent.mkdir()
    assert main(["import", str(edited), "-o", str(first)]) == 0
    assert _entry(first.parent, "first.h5", capsys)["notes"] == "dry run; new liner"
    again = tmp_path / "again.csv"
    assert main(["export", str(first), "-o", str(again)]) == 0
    assert main(["import", str(again), "-o", str(second), "--operator", "someone else"]) == 0
    e = _entry(second.parent, "second.h5", capsys)
    assert e["notes"] == "dry run; new liner" and e["operator"] == "someone else" and e["scene"] == "daq-test"
