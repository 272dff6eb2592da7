"""The conventions every figure shares: fonts, the unit style of axis labels, repeat colours and markers.

Light on purpose (numpy and the standard library only; matplotlib is not imported), so the live view
(:mod:`analysis.watch`) and the comparison figures (:mod:`analysis.figures`) take the same style without importing
each other. The checks that a drawn figure keeps these conventions are in :mod:`analysis.figure_check`.

- Fonts: nothing smaller than :data:`MIN_FONT_PT` (points at the saved size; a figure is saved at its own size).
- Units: in square brackets after the quantity, ``weight W [kg]``, ``resistance R [mΩ]``; a ratio or other
  dimensionless quantity says ``[–]`` (:data:`DIMENSIONLESS`). Subscripts are mathtext (``R$_s$``,
  ``A$_\\mathrm{BEM}$``), never a literal underscore.
- Repeats M1…Mn: the Okabe–Ito qualitative palette (colour-blind safe) with a marker each
  (:func:`repeat_style`); the mean over the repeats is black.
"""

from __future__ import annotations

import textwrap
from typing import Any

__all__ = [
    "DIMENSIONLESS",
    "MEASURED_COLOUR",
    "MIN_FONT_PT",
    "RC",
    "REPEAT_COLOURS",
    "REPEAT_MARKERS",
    "repeat_style",
    "wrap_title",
]

#: The smallest font of any text in a figure, points at the saved size.
MIN_FONT_PT = 7.0

#: The unit of a dimensionless quantity (ratios, normalised residuals, probabilities).
DIMENSIONLESS = "[–]"

MEASURED_COLOUR = "#222222"

#: Okabe & Ito (2008) "Color Universal Design" palette without black (the mean is black) and without yellow (too
#: pale on white); distinguishable for the common colour-vision deficiencies.
REPEAT_COLOURS = ("#0072B2", "#E69F00", "#009E73", "#D55E00", "#56B4E9", "#CC79A7", "#7F7F7F")
#: One marker per repeat as well, so repeats stay apart in greyscale print; 7 colours × 8 markers give 56 pairs.
REPEAT_MARKERS = ("o", "s", "^", "v", "D", "P", "X", "*")

RC: dict[Any, Any] = {
    "font.size": 9.0,
    "axes.titlesize": 10.0,
    "axes.labelsize": 9.0,
    "xtick.labelsize": 8.0,
    "ytick.labelsize": 8.0,
    "legend.fontsize": 8.0,
    "figure.titlesize": 10.0,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "grid.linewidth": 0.6,
    "lines.linewidth": 1.6,
    "lines.markersize": 4.5,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "savefig.dpi": 150,
    "figure.dpi": 100,
    "svg.fonttype": "none",
}


def repeat_style(k: int) -> dict[str, Any]:
    """Colour and marker of repeat ``k`` (0-based: M1 is 0), the same in every figure: colours cycle through
    :data:`REPEAT_COLOURS`, markers through :data:`REPEAT_MARKERS`, so no two of the first 56 repeats look alike."""
    if k < 0:
        raise ValueError(f"repeat index = {k}: expected >= 0")
    return {"color": REPEAT_COLOURS[k % len(REPEAT_COLOURS)], "marker": REPEAT_MARKERS[k % len(REPEAT_MARKERS)]}


def wrap_title(text: str, width_in: float, fontsize_pt: float = 10.0) -> str:
    """``text`` broken into lines that fit ``width_in`` inches at ``fontsize_pt`` (an average glyph is taken as
    0.55 em wide), so a long title stays on the canvas."""
    chars = max(int(width_in * 72.0 / (0.55 * fontsize_pt)), 20)
    return "\n".join(textwrap.wrap(text, chars, break_on_hyphens=False)) if len(text) > chars else text


#: Symbols written with an underscore in terminal text and their mathtext form for figures.
_SUBSCRIPTS = {"σ_f": "σ$_f$", "R_s": "R$_s$", "R_T": "R$_T$", "R_Barber": "R$_\\mathrm{Barber}$",
               "R_macro": "R$_\\mathrm{macro}$"}  # fmt: skip


def mathtext(text: str) -> str:
    """``text`` with the symbols of :data:`_SUBSCRIPTS` (``σ_f``, ``R_s`` …) as mathtext subscripts, for a figure."""
    for plain, math in _SUBSCRIPTS.items():
        text = text.replace(plain, math)
    return text

