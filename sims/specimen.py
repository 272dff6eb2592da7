"""The specimen a scene describes, loaded: real contact area against weight, whichever geometry it is.

A scene describes either the seed paper's piston resting in its liner (``[rig]``, :func:`sims.rig.sweep`) or a rough
sphere pressed onto a rough flat (``[press]``, :func:`sims.press.press_sweep`). Both return a
:class:`sims.rig.sweep.SweepResult`, so files, the simulated bench, fits and figures take either; callers use
:func:`sweep_specimen` and never ask which geometry they have.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from sims.config import SimConfig
    from sims.rig.sweep import SweepResult

__all__ = ["sweep_specimen"]


def sweep_specimen(
    config: SimConfig,
    models: Sequence[str] | None = None,
    weights_kg: Sequence[float] | None = None,
    *,
    database: Any = None,
    elastic: bool = False,
) -> SweepResult:
    """A(W) [m²] per model at ``weights_kg`` [kg] (None: the scene's own load sweep) for the scene's specimen.

    ``database``: a prebuilt contact database (else the curves of ``models`` are built). ``elastic``: couple the
    rig's asperity layer to the bodies' bulk elasticity (:mod:`sims.rig.elastic`); the press always includes it.
    """
    if config.press is None:
        from sims.rig import sweep

        return sweep(config, models=models, weights_kg=weights_kg, database=database, elastic=elastic)
    from sims.press import press_sweep

    laws = None
    if database is not None:
        names = list(models) if models is not None else list(database)
        laws = {n: database[n] for n in names}
    return press_sweep(config, config.press, models, weights_kg, laws=laws)
