"""The piston/liner rig model: real contact area against added weight (seed section 2.1, Fig. 11; eq. 22).

Modules, each one concept (SI units throughout):

==================  ==============================================================================================
``settings``        :class:`RigSettings`, the scene's ``[rig]`` table, validated (geometry, mesh, weights [kg])
``geometry``        the gap between skirt and liner at every angle [m] (exact offset circle or small clearance)
``law``             :class:`ContactLaw`, what the rig needs of a contact model: p(h) [Pa], A_r/A_0(h) against h [m]
``mesh``            the skirt mesh (uniform, or variable: fine at the contact, graded beyond it)
``loads``           contact force F(h0) [N], its slope [N/m] and the real area [m²] on a mesh, for many h0 at once
``equilibrium``     THE static solver, ``F(h0) = W`` for a batch of weights with adaptive mesh refinement
                    (:func:`batch_equilibrium`); :func:`equilibrium` is one weight of it
``dynamics``        damped release to rest, seed eq. 22 (:func:`settle`)
``sweep``           every weight for every model of a :class:`~sims.config.SimConfig` (:func:`sweep`)
==================  ==============================================================================================

The HDF5 file of a sweep is written and read by :mod:`daq.sweep_file` (``sims`` does no file I/O).
"""

from __future__ import annotations

from sims.rig.dynamics import Settle, settle
from sims.rig.equilibrium import (
    ALPHA_WARN,
    BatchEquilibrium,
    Equilibrium,
    RigLoadError,
    batch_equilibrium,
    equilibrium,
    roughness_parameter,
)
from sims.rig.law import ContactLaw, check_law
from sims.rig.settings import PAPER_WEIGHTS_KG, STANDARD_GRAVITY, RigSettings, check_weights
from sims.rig.sweep import ModelSweep, SweepResult, sweep

__all__ = [
    "ALPHA_WARN",
    "PAPER_WEIGHTS_KG",
    "STANDARD_GRAVITY",
    "BatchEquilibrium",
    "ContactLaw",
    "Equilibrium",
    "ModelSweep",
    "RigLoadError",
    "RigSettings",
    "Settle",
    "SweepResult",
    "batch_equilibrium",
    "check_law",
    "check_weights",
    "equilibrium",
    "roughness_parameter",
    "settle",
    "sweep",
]
