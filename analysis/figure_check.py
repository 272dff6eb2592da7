"""What a journal reviewer checks on a figure, as a function: :func:`figure_problems` lists every breach.

The figure is drawn once with the Agg renderer and every text that is actually drawn (titles, axis and tick labels,
legend entries, annotations, colour-bar labels) is measured by its window extent; then:

- **fonts**: no text smaller than :data:`analysis.figure_style.MIN_FONT_PT` (points at the saved size);
- **layout**: no text leaves the canvas, no two texts overlap (by more than ``tolerance_px`` each way);
- **units**: every axis that shows numbers has a label with its unit in square brackets (``[mΩ]``, ``[–]``); an
  axis of named categories (fixed tick labels) needs a label but no unit;
- **legends**: every labelled line or collection is in a legend of the figure; with ``models`` (registered
  contact-model keys) the legend entries naming a model are exactly those models, each once;
- **text**: no literal underscore outside mathtext (a raw key or a subscript typed as ``R_s``), no ``(s)`` plural.

Used by the figure tests over the figure registry and every command that draws (``tests/analysis/test_figures.py``);
matplotlib is imported only when a figure is checked.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from analysis.figure_style import MIN_FONT_PT

__all__ = ["DrawnText", "FigureCheckError", "check_figure", "drawn_texts", "figure_problems"]

_UNIT = re.compile(r"\[[^\]]+\]")
_MATH = re.compile(r"(?<!\\)\$.*?(?<!\\)\$")
_MATH_COMMAND = re.compile(r"\\[a-zA-Z]+")
_WORD = re.compile(r"[^\W\d_]{2,}")


class FigureCheckError(AssertionError):
    """A figure breaks the conventions; the message lists every problem, one a line."""


@dataclass(frozen=True)
class DrawnText:
    """One text as drawn: the artist, its string, size [pt] and window extent [px]."""

    artist: Any
    text: str
    size_pt: float
    extent: Any


@contextmanager
def _recording() -> Iterator[list[Any]]:
    """Record every :class:`matplotlib.text.Text` drawn inside the block (tick labels outside the view, hidden
    axes and empty strings are never drawn, so they are never checked)."""
    from matplotlib.text import Text

    seen: list[Any] = []
    original = Text.draw

    def draw(self: Any, renderer: Any) -> None:
        original(self, renderer)
        if self.get_visible() and self.get_text().strip():
            seen.append((self, renderer))

    Text.draw = draw  # type: ignore[method-assign]
    try:
        yield seen
    finally:
        Text.draw = original  # type: ignore[method-assign]


def drawn_texts(fig: Any) -> list[DrawnText]:
    """Draw ``fig`` (Agg) and return every text drawn, with its extent in pixels at the figure's dpi."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    fig.set_canvas(canvas)
    with _recording() as seen:
        canvas.draw()
    out, ids = [], set()
    for artist, renderer in seen:
        if id(artist) in ids:
            continue
        ids.add(id(artist))
        extent = artist.get_window_extent(renderer)
        out.append(DrawnText(artist, artist.get_text(), float(artist.get_fontsize()), extent))
    return out


def _short(text: str) -> str:
    flat = " ".join(text.split())
    return flat if len(flat) <= 40 else flat[:37] + "…"


def _font_problems(texts: list[DrawnText], min_pt: float) -> list[str]:
    small = [t for t in texts if t.size_pt < min_pt - 1e-9]
    return [f"text '{_short(t.text)}' is {t.size_pt:g} pt (< {min_pt:g} pt)" for t in small]


def _canvas_problems(fig: Any, texts: list[DrawnText], tol: float) -> list[str]:
    w, h = fig.bbox.width, fig.bbox.height
    out = []
    for t in texts:
        e = t.extent
        if e.x0 < -tol or e.y0 < -tol or e.x1 > w + tol or e.y1 > h + tol:
            out.append(f"text '{_short(t.text)}' leaves the canvas ({e.x0:.0f}…{e.x1:.0f} × {e.y0:.0f}…{e.y1:.0f} px "
                       f"on {w:.0f} × {h:.0f})")  # fmt: skip
    return out


def _overlap(a: Any, b: Any, tol: float) -> bool:
    dx = min(a.x1, b.x1) - max(a.x0, b.x0)
    dy = min(a.y1, b.y1) - max(a.y0, b.y0)
    return dx > tol and dy > tol


def _overlap_problems(texts: list[DrawnText], tol: float) -> list[str]:
    out = []
    for i, a in enumerate(texts):
        for b in texts[i + 1 :]:
            if _overlap(a.extent, b.extent, tol):
                out.append(f"text '{_short(a.text)}' overlaps '{_short(b.text)}'")
    return out


def _drawn_ticklabels(axis: Any, drawn: set[int]) -> list[Any]:
    return [t for t in axis.get_ticklabels(which="both") if id(t) in drawn]


def _categorical(labels: list[Any]) -> bool:
    """Tick labels that name things (two letters in a row, mathtext commands aside) rather than numbers."""
    return any(_WORD.search(_MATH_COMMAND.sub("", t.get_text())) for t in labels)


def _axis_problems(fig: Any, texts: list[DrawnText]) -> list[str]:
    drawn = {id(t.artist) for t in texts}
    out = []
    for ax in fig.axes:
        if not ax.get_visible() or not ax.axison:
            continue
        for name, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
            ticks = _drawn_ticklabels(axis, drawn)
            if not ticks:
                continue  # a shared axis without its own tick labels
            label = axis.get_label().get_text().strip()
            where = f"axes '{_short(ax.get_title() or ax.get_label() or '?')}' {name}"
            if not label:
                out.append(f"{where}: no axis label")
            elif not _categorical(ticks) and not _UNIT.search(label):
                out.append(f"{where}: label '{_short(label)}' has no unit in [ ]")
    return out


def _legend_texts(fig: Any) -> list[str]:
    legends = [leg for leg in [*fig.legends, *(ax.get_legend() for ax in fig.axes)] if leg is not None]
    return [t.get_text() for leg in legends if leg.get_visible() for t in leg.get_texts()]


def _labelled_artists(fig: Any) -> list[str]:
    out = []
    for ax in fig.axes:
        if not ax.get_visible():
            continue
        for artist in [*ax.get_lines(), *ax.collections, *ax.containers]:
            label = str(artist.get_label() or "")
            if label and not label.startswith("_"):
                out.append(label)
    return out


def _legend_problems(fig: Any, models: Iterable[str] | None) -> list[str]:
    entries = _legend_texts(fig)
    out = [f"'{_short(lab)}' is drawn but in no legend" for lab in dict.fromkeys(_labelled_artists(fig))
           if lab not in entries]  # fmt: skip
    if models is None:
        return out
    from sims.models import model_label, model_names

    shown = {model_label(k) for k in models}
    known = {model_label(k) for k in model_names()} | shown
    named = [lab for e in entries for lab in known if e == lab or e.startswith((f"{lab}:", f"{lab} "))]
    out += [f"model '{m}' is shown but not in the legend" for m in sorted(shown - set(named))]
    out += [f"legend names '{m}', which is not shown" for m in sorted(set(named) - shown)]
    out += [f"legend names '{m}' {named.count(m)} times" for m in sorted(set(named)) if named.count(m) > 1]
    return out


def _text_problems(texts: list[DrawnText]) -> list[str]:
    out = []
    for t in texts:
        plain = _MATH.sub("", t.text).replace(r"\_", "")
        if "_" in plain:
            out.append(f"text '{_short(t.text)}' has a literal underscore (a raw key, or a subscript without mathtext)")
        if "(s)" in plain:
            out.append(f"text '{_short(t.text)}' says '(s)': give the number its own singular or plural")
    return out


def figure_problems(
    fig: Any, *, models: Iterable[str] | None = None, min_font_pt: float = MIN_FONT_PT, tolerance_px: float = 1.0
) -> list[str]:
    """Every breach of the figure conventions in ``fig`` (module docstring), one sentence each; empty when none.

    ``models``: the contact-model keys the figure should show (None: the legend check is only that every labelled
    artist is in a legend). ``tolerance_px``: how far [px at the figure's dpi] a text may touch another or the edge.
    """
    texts = drawn_texts(fig)
    return [
        *_font_problems(texts, min_font_pt),
        *_canvas_problems(fig, texts, tolerance_px),
        *_overlap_problems(texts, tolerance_px),
        *_axis_problems(fig, texts),
        *_legend_problems(fig, models),
        *_text_problems(texts),
    ]


def check_figure(fig: Any, *, models: Iterable[str] | None = None, what: str = "figure") -> None:
    """Raise :class:`FigureCheckError` listing every problem of :func:`figure_problems` (``what`` names the figure)."""
    problems = figure_problems(fig, models=models)
    if problems:
        raise FigureCheckError(f"{what}: " + "; ".join(problems))
