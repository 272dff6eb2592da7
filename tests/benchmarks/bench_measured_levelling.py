"""A(W) of the packaged measured-surface scene: mean-plane-only levelling against form removal + ISO filtering.

Run: ``.venv/bin/python tests/benchmarks/bench_measured_levelling.py`` (needs the extra 'surfaces'; ~20 s).
Prints, per model and weight, the real contact area with the scene as shipped (cylinder form removed, λs = 25 µm,
λc = 250 µm; the baseline) and with ``form = "plane"`` and no filters (what contactrig did before), and their ratio;
then the same for the edge treatment (``edges = "window"`` against the shipped ``"mirror"``), in the rig and in the
BEM reference itself (real-area fraction at 1–30 MPa, hardness-capped).
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "contactrig" / "scenes" / "measured.toml"


def _variant(text: str, name: str, replace: dict[str, str]) -> Path:
    for old, new in replace.items():
        text = text.replace(old, new)
    path = SCENE.parent / f".bench-{name}.toml"  # beside the shipped scene: its relative map paths resolve
    path.write_text(text, encoding="utf-8")
    return path


def _areas(scene: Path) -> tuple[dict[str, dict[str, list[float]]], float]:
    t = time.perf_counter()
    cmd = [sys.executable, "-m", "contactrig", "simulate", str(scene), "--json"]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    return json.loads(out)["models"], time.perf_counter() - t


def _compare(title: str, base: dict, other: dict, labels: tuple[str, str]) -> None:
    print(f"\n{title}")
    print(f"{'model':18s} {'W (kg)':>7s} {labels[0] + ' A (mm²)':>22s} {labels[1] + ' A (mm²)':>22s} {'ratio':>7s}")
    for model, b in base.items():
        o = other[model]
        for w, a0, a1 in zip(b["weight_kg"], b["contact_area_m2"], o["contact_area_m2"], strict=True):
            print(f"{model:18s} {w:7.2f} {a0 * 1e6:22.4f} {a1 * 1e6:22.4f} {a1 / a0:7.3f}")


def _bem_edges(window: Path) -> None:
    from contactrig.core.scene import load_scene
    from sims.bem import solve_contact
    from sims.bem_database import composite_from_config
    from sims.config import SimConfig

    pressures = (1e6, 3e6, 10e6, 30e6)
    print(f"\nBEM real-area fraction at {[f'{p / 1e6:g}' for p in pressures]} MPa")
    out = {}
    for name, scene in (("mirror", SCENE), ("window", window)):
        cfg = SimConfig.from_scene(load_scene(scene))
        z, px = composite_from_config(cfg)
        t = time.perf_counter()
        m = cfg.materials
        out[name] = [solve_contact(z, px, m.E_star, p, hardness=m.H).area_fraction for p in pressures]
        print(f"{name:7s} {z.shape[0]}² {time.perf_counter() - t:5.1f} s  " + "  ".join(f"{a:.4f}" for a in out[name]))
    print("window/mirror  " + "  ".join(f"{w / r:.3f}" for w, r in zip(out["window"], out["mirror"], strict=True)))


def main() -> None:
    text = SCENE.read_text(encoding="utf-8")
    plane = _variant(text, "plane", {'form = "cylinder"': 'form = "plane"', "lambda_s_m = 25e-6\n": "",
                                     "lambda_c_m = 250e-6\n": ""})  # fmt: skip
    window = _variant(text, "window", {'edges = "mirror"': 'edges = "window"'})
    try:
        (base, t0), (lev, t1), (win, t2) = _areas(SCENE), _areas(plane), _areas(window)
        _bem_edges(window)
    finally:
        plane.unlink()
        window.unlink()
    print(f"simulate: shipped {t0:.1f} s, mean plane only {t1:.1f} s, window {t2:.1f} s")
    _compare("levelling: form removal + filtering (baseline) vs mean plane only", base, lev, ("form+filter", "plane"))
    _compare("edges: mirror (baseline) vs window", base, win, ("mirror", "window"))


if __name__ == "__main__":
    main()
