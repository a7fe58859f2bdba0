"""A small figure model: what a plot shows, independent of how it is drawn.

A Figure holds Panels (axes boxes at fixed places on the page); a Panel holds Lines,
vertical Marks across it and Upright labels beside them, its axis labels, title and
legend entries. Figure.finish() works out each panel's limits (the data's with a 5 %
margin, or set ones; equal aspect by widening one axis), ticks (nice_ticks) and tick
labels, once. The emitters draw a finished Figure: navkit.figure_png (Pillow, PNG) and
navkit.figure_mpl (matplotlib, the other formats); neither decides layout.

Lengths on the page are in points (1/72 in) unless named otherwise; data limits and
coordinates are in the data's own units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Figure", "Panel", "Line", "Marks", "Upright", "nice_ticks", "tick_labels",
           "tick_count", "TICK_PT", "MARGIN"]

# Font size (pt) of tick labels and axis labels; the title is 1.2 times it, legend
# entries 0.833 times it (matplotlib's "medium", "large", "small").
TICK_PT = 10.0

# Share of the data's span added on each side of autoscaled limits.
MARGIN = 0.05

# A tick step is one of these times a power of ten.
_STEPS = (1.0, 2.0, 2.5, 5.0, 10.0)

# Most ticks on an axis: matplotlib's default locator's count for a long axis.
_MAX_TICKS = 9


@dataclass
class Line:
    """A polyline (NaN in x or y breaks it) or, with style "points", a dot at each point.
    `width` (pt) is the line's width or the dot's diameter; `style` "solid", "dashed" or
    "points"; `label` its legend entry (None: none)."""

    x: np.ndarray
    y: np.ndarray
    color: str
    width: float = 1.5
    style: str = "solid"
    label: str | None = None


@dataclass
class Marks:
    """Vertical lines across a panel at data x values `x`, `width` (pt) wide, `style`
    "solid" or "dotted", drawn with opacity `alpha` under the panel's lines; `gid` names
    the kind ("command", "event")."""

    x: np.ndarray
    color: str
    width: float
    style: str = "solid"
    alpha: float = 1.0
    gid: str = ""


@dataclass
class Upright:
    """Text turned 90 degrees counter-clockwise (read bottom to top), its right edge at data
    x `x`, its top at the panel's top (`at` "top") or its bottom at the panel's bottom
    ("bottom"); `size` in pt. It may reach beyond the panel."""

    x: float
    text: str
    color: str
    size: float
    at: str = "top"


@dataclass
class Panel:
    """An axes box at `rect` (left, bottom, width, height as fractions of the figure).
    `xlim`/`ylim`: limits to use (None: the lines' data with MARGIN); `invert_x`: x grows
    to the left; `equal`: one data unit is as long across as up (the shorter-spanned axis
    widened about its centre). After Figure.finish(): `xlim`, `ylim` (left, right /
    bottom, top: an inverted x has xlim[0] > xlim[1]), `xticks`, `yticks` and their
    labels."""

    rect: tuple
    lines: list = field(default_factory=list)
    marks: list = field(default_factory=list)
    labels: list = field(default_factory=list)
    xlabel: str = ""
    ylabel: str = ""
    title: str = ""
    xlim: tuple | None = None
    ylim: tuple | None = None
    invert_x: bool = False
    equal: bool = False
    legend: bool = True
    xticks: np.ndarray | None = None
    yticks: np.ndarray | None = None
    xtick_labels: list = field(default_factory=list)
    ytick_labels: list = field(default_factory=list)

    def size_pt(self, fig: "Figure") -> tuple:
        """(width, height) of the box in points on `fig`."""
        return (self.rect[2] * fig.width * 72.0, self.rect[3] * fig.height * 72.0)

    def data_limits(self) -> tuple:
        """((xmin, xmax), (ymin, ymax)) of the finite points of the lines; (0, 1) for an
        axis with none."""
        out = []
        for axis in ("x", "y"):
            lo, hi = math.inf, -math.inf
            for ln in self.lines:
                v = np.asarray(getattr(ln, axis), dtype=float)
                v = v[np.isfinite(v)]
                if v.size:
                    lo, hi = min(lo, float(v.min())), max(hi, float(v.max()))
            out.append((lo, hi) if lo <= hi else (0.0, 1.0))
        return tuple(out)

    def finish(self, fig: "Figure") -> None:
        """Set the limits, ticks and tick labels (see the class)."""
        (dx0, dx1), (dy0, dy1) = self.data_limits()
        x0, x1 = self.xlim if self.xlim is not None else _margined(dx0, dx1)
        y0, y1 = self.ylim if self.ylim is not None else _margined(dy0, dy1)
        w_pt, h_pt = self.size_pt(fig)
        if self.equal:
            x0, x1, y0, y1 = equal_aspect(x0, x1, y0, y1, w_pt, h_pt)
        self.xticks = nice_ticks(x0, x1, tick_count(w_pt, across=True))
        self.yticks = nice_ticks(y0, y1, tick_count(h_pt, across=False))
        self.xtick_labels = tick_labels(self.xticks)
        self.ytick_labels = tick_labels(self.yticks)
        self.xlim = (x1, x0) if self.invert_x else (x0, x1)
        self.ylim = (y0, y1)


@dataclass
class Figure:
    """A page `width` x `height` in inches, drawn at `dpi` dots per inch (PNG), with
    `panels`."""

    width: float
    height: float
    dpi: float
    panels: list = field(default_factory=list)

    def finish(self) -> "Figure":
        """Finish every panel (Panel.finish); returns the figure."""
        for p in self.panels:
            p.finish(self)
        return self

    @property
    def pixels(self) -> tuple:
        """(width, height) of the page in pixels at `dpi`."""
        return (round(self.width * self.dpi), round(self.height * self.dpi))


def _margined(lo: float, hi: float) -> tuple:
    """(lo, hi) widened by MARGIN of the span on each side; a zero span (a constant line)
    first opened by 5 % of the value (0.05 about 0)."""
    if hi <= lo:
        d = 0.05 * abs(lo) or 0.05
        lo, hi = lo - d, hi + d
    pad = MARGIN * (hi - lo)
    return (lo - pad, hi + pad)


def equal_aspect(x0: float, x1: float, y0: float, y1: float, w_pt: float, h_pt: float) -> tuple:
    """Limits (x0, x1, y0, y1) widened so one data unit is as long across as up in a box
    `w_pt` x `h_pt` (pt): the axis with fewer units per point grows about its centre; the
    other is kept."""
    per_x, per_y = (x1 - x0) / w_pt, (y1 - y0) / h_pt
    if per_x > per_y:
        c, half = 0.5 * (y0 + y1), 0.5 * per_x * h_pt
        return x0, x1, c - half, c + half
    c, half = 0.5 * (x0 + x1), 0.5 * per_y * w_pt
    return c - half, c + half, y0, y1


def tick_count(length_pt: float, across: bool) -> int:
    """The most ticks an axis `length_pt` long holds: one per three (across) or two (up)
    tick-label font sizes, 1 to 9."""
    per = TICK_PT * (3.0 if across else 2.0)
    return max(1, min(_MAX_TICKS, int(length_pt // per)))


def nice_ticks(lo: float, hi: float, most: int = _MAX_TICKS) -> np.ndarray:
    """Ticks within [lo, hi] (either order): the multiples of the smallest step of 1, 2,
    2.5, 5 x 10^n at least (hi - lo) / `most` long, so there are at most about `most` + 1;
    if that leaves fewer than two, the next smaller steps are tried. Empty for an empty
    or non-finite span."""
    lo, hi = min(lo, hi), max(lo, hi)
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return np.array([])
    raw = (hi - lo) / max(1, most)
    scale = 10.0 ** math.floor(math.log10(raw))
    steps = [s * scale for s in _STEPS]
    first = next(i for i, s in enumerate(steps) if s >= raw * (1 - 1e-9))
    ticks = np.array([])
    for step in steps[first::-1] + [s * scale / 10 for s in _STEPS[-2::-1]]:
        k0 = math.ceil(lo / step - 1e-9)
        k1 = math.floor(hi / step + 1e-9)
        ticks = np.arange(k0, k1 + 1) * step
        if ticks.size >= 2:
            break
    ticks[np.abs(ticks) < 1e-12 * (hi - lo)] = 0.0     # an exact 0, not -0 or 1e-17
    return ticks


def tick_labels(ticks) -> list:
    """Labels of evenly spaced `ticks`: as many decimals as the step needs (0.5 -> 1, 2.5 ->
    1, 0.25 -> 2), a minus sign (U+2212) for negatives; beyond 1e6 or below 1e-4 the
    shortest %g form that tells the ticks apart."""
    ticks = np.asarray(ticks, dtype=float)
    if ticks.size == 0:
        return []
    big = float(np.abs(ticks).max())
    step = float(np.diff(ticks).min()) if ticks.size > 1 else max(big, 1.0)
    if 1e-4 <= big < 1e6:
        decimals = 0
        while decimals < 10 and abs(round(step, decimals) - step) > 1e-9 * step:
            decimals += 1
        text = [f"{t:.{decimals}f}" for t in np.where(np.abs(ticks) < 0.5 * step, 0.0, ticks)]
    else:
        for digits in range(1, 18):
            text = [f"{t:.{digits}g}" for t in ticks]
            if all(abs(float(x) - t) <= 1e-6 * step for x, t in zip(text, ticks)):
                break
    return [x.replace("-", "\u2212") for x in text]
