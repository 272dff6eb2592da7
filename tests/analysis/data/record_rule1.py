"""Record rule 1's suggestions: tests/analysis/data/rule1_suggestions.json (run once, from the worktree root, on
commit 4b7c30a, before rule 2 existed: ``PYTHONPATH=$PWD python tests/analysis/data/record_rule1.py``).

Two simulated sessions on test_sequential's model curves, 40 suggestions each, every suggestion followed; every
fifth step also the forward simulation's placements (``_future``). test_sequential.py's
``test_rule_1_is_the_first_rule_bit_for_bit`` replays them with ``SequentialDesign(rule=1)``.
"""

import json
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from test_sequential import FILM, W, _curves

from analysis.noise_model import NoiseModel
from analysis.sequential import CostModel, SequentialDesign

out = []
for truth, sd, seed in [("a", 0.15, 1), ("b", 0.3, 2)]:
    d = SequentialDesign(_curves(), W, CostModel(block_s=2.8, place_s=60.0, reseat_s=5.0), budget_s=3600.0,
                         noise=NoiseModel.iid(sd), film_ohm_m2=FILM, n_forward=40)  # fmt: skip
    rng = np.random.default_rng(seed)
    a, cl = d.curves.at(truth, W)
    steps = []
    for step in range(40):
        p = d.suggest()
        rec: dict = {"blocks": d.blocks, "suggestion": p.as_dict()}
        if step % 5 == 4:
            rec["future"] = d._future(d.evidence(), d.noise()[0])
        steps.append(rec)
        i = d.index_of(p.weight_kg)
        for _ in range(p.seatings):
            v = float((FILM / a[i] + cl[i]) * math.exp(sd * rng.standard_normal()))
            d.ingest(p.weight_kg, v, reseated=p.action != "repeat")
    out.append({"truth": truth, "sd": sd, "seed": seed, "steps": steps})
(Path(__file__).parent / "rule1_suggestions.json").write_text(json.dumps(out, indent=0))
