"""Study ``integrator``: the damped release-to-rest of seed eq. 22, explicit against implicit integrators.

The piston under a Tab. 1 weight is released just touching the liner and integrated to rest with
m ẍ = m g − F_c(x) − B ẋ on the Greenwood–Tripp curve of the default scene (``sims.rig.dynamics.settle``; the
implicit methods get the analytic Jacobian from the curve's slope). Reference: the static equilibrium of the same
model on the same mesh (a bracketed root solve, independent of any time integration); error = relative error of
the rest separation. Two dampings: light (the scene's B, not stiff) and heavy (stiffness ratio ≫ 100, stiff).
Seconds: wall time of the integration; ``extra`` carries nfev, njev, nlu and the stiffness ratio. ``--quick``
uses B = 3e6 N·s/m for the stiff case (ratio ≈ 300) so explicit RK45 finishes in about a second; the full study
uses B = 1e7 (ratio ≈ 3000), where RK45 needs ~10^5 evaluations.
"""

from __future__ import annotations

import warnings

from analysis.studies.rows import Row

REFERENCE = "the static equilibrium (bracketed root solve) of the same model and mesh"
_METHODS = ("RK45", "Radau", "BDF", "LSODA")
_WEIGHT_KG = 25.966


def run(quick: bool) -> list[Row]:
    from contactrig.core.scene import load_scene
    from sims.config import SimConfig
    from sims.database import build_database
    from sims.rig import equilibrium, settle
    from sims.rig.dynamics import MAX_EVALUATIONS

    config = SimConfig.from_scene(load_scene())
    settings = config.rig
    curve = build_database(config, models=["greenwood_tripp"])["greenwood_tripp"]
    static = equilibrium(curve, settings, _WEIGHT_KG)
    dampings = (("light", settings.damping_n_s_per_m), ("heavy", 3e6 if quick else 1e7))
    rows: list[Row] = []
    for label, damping in dampings:
        for method in _METHODS:
            # full study: no evaluation budget, so explicit RK45's true cost on the stiff case is measured
            budget = MAX_EVALUATIONS if quick else None
            with warnings.catch_warnings(record=True) as caught:
                # an explicit method on the stiff case warns by design: keep the text in the row, not on stderr
                warnings.simplefilter("always")
                run_ = settle(
                    curve,
                    settings,
                    _WEIGHT_KG,
                    method=method,
                    damping_n_s_per_m=damping,
                    static=static,
                    rtol=1e-6,
                    max_evaluations=budget,
                )
            rows.append(
                Row(
                    study="integrator",
                    method=method,
                    setting=f"{label} damping B = {damping:.3g} N·s/m ({'stiff' if run_.stiff else 'not stiff'})",
                    error=abs(run_.separation_error_m) / abs(run_.static_separation_m),
                    seconds=run_.elapsed_s,
                    extra={
                        "error_kind": "relative error of the rest separation",
                        "nfev": run_.nfev,
                        "njev": run_.njev,
                        "nlu": run_.nlu,
                        "stiffness_ratio": run_.stiffness_ratio,
                        "damping_ratio": run_.damping_ratio,
                        "settled": run_.settled,
                        "status": run_.status,
                        "warnings": [str(w.message) for w in caught],
                    },
                )
            )
    return rows
