"""Error against run time for every numerical method, and the stability atlas (``contactrig bench``).

Each study is a function ``study(quick: bool) -> list[Row]`` that states its reference (how "error" is measured)
and times each method against it in one run. :func:`run` gathers the rows; :mod:`analysis.studies.report`
prints the table and writes figures and a Markdown report; :mod:`analysis.studies.atlas` runs the stiff and extreme
cases. Studies import what they measure lazily, so ``contactrig bench --study gaussian_integrals`` builds nothing else.
"""

from analysis.studies.rows import Row, run, study_names

__all__ = ["Row", "run", "study_names"]
