"""Contact area to resistance, normalisation, fits of measured against simulated curves, figures, reports.

Modules: :mod:`analysis.resistance` (seed eq. 23, Holm, Greenwood 1966), :mod:`analysis.circuit` (eq. 23–25 design
calculator, the ``[circuit]`` scene table), :mod:`analysis.measured` (repeats per weight from a session or Tab. 1),
:mod:`analysis.normalisation` (R/R₀ with uncertainty), :mod:`analysis.fit` (R = R_s + s·h/A per model, ranking),
:mod:`analysis.figures`, :mod:`analysis.report`, :mod:`analysis.pipeline` (session + simulation → analysis) and
:mod:`analysis.demo`. Nothing here imports pyvisa; matplotlib only when a figure is drawn.
"""
