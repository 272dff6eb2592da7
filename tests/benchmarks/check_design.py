"""Re-run a plan written by ``contactrig design`` through ``acquire --sim`` and ``fit``, as a user would, and compare
the fraction of sessions that rank the true model first by ΔAIC ≥ 10 with the design's prediction (issue #15).

For each direction of one model pair (truth A against B, then B against A) it runs ``repeats`` sessions of the
plan scene with ``[session] sim_model`` = the truth and ``sim_seed`` = 1, 2, …, each acquired on the simulated bench
and fitted with ``--models A,B``; a session counts when the truth is first with ΔAIC ≥ 10. Prints the observed
fraction with its binomial standard error next to the prediction.

Run:  python tests/benchmarks/check_design.py PLAN.toml greenwood_tripp jackson_green [--repeats 8] [--workdir DIR]
"""

from __future__ import annotations

import argparse
import json
import math
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CONTACTRIG = [sys.executable, "-m", "contactrig"]


def _scene(plan_text: str, truth: str, seed: int) -> str:
    text = re.sub(r'(?m)^sim_model = "[^"]*"', f'sim_model = "{truth}"', plan_text)
    return re.sub(r"(?m)^sim_seed = \d+", f"sim_seed = {seed}", text)


def _one(plan_text: str, truth: str, other: str, seed: int, work: Path) -> float:
    scene = work / f"{truth}-{seed}.toml"
    session = work / f"{truth}-{seed}.h5"
    scene.write_text(_scene(plan_text, truth, seed), encoding="utf-8")
    acquire = [*CONTACTRIG, "acquire", str(scene), "--sim", "--yes", "--sim-speed", "1000", "-o", str(session)]
    subprocess.run([*acquire, "--force"], check=True, capture_output=True)
    fit = [*CONTACTRIG, "fit", str(session), "--models", f"{truth},{other}", "--json", "--bootstrap", "0"]
    out = subprocess.run(fit, check=True, capture_output=True, text=True).stdout
    aic = {k: v["goodness"]["aic"] for k, v in json.loads(out)["models"].items()}
    return aic[other] - aic[truth]  # > 0: the truth is ahead


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("plan")
    ap.add_argument("model_a")
    ap.add_argument("model_b")
    ap.add_argument("--repeats", type=int, default=8)
    ap.add_argument("--workdir", default=None)
    args = ap.parse_args()
    plan_text = Path(args.plan).read_text(encoding="utf-8")
    work = Path(args.workdir or tempfile.mkdtemp(prefix="check-design-"))
    work.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    for truth, other in ((args.model_a, args.model_b), (args.model_b, args.model_a)):
        gaps = [_one(plan_text, truth, other, seed, work) for seed in range(1, args.repeats + 1)]
        hits = sum(g >= 10.0 for g in gaps)
        p = hits / len(gaps)
        se = math.sqrt(max(p * (1 - p), 1.0 / len(gaps)) / len(gaps))
        print(f"truth {truth} vs {other}: {hits}/{len(gaps)} sessions decisive (ΔAIC >= 10), {p:.0%} ± {se:.0%}; "
              f"ΔAIC min {min(gaps):.1f}, median {sorted(gaps)[len(gaps) // 2]:.1f}")  # fmt: skip
    print(f"{2 * args.repeats} sessions in {time.perf_counter() - t0:.0f} s; files in {work}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
