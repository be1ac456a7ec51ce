"""Figures of engine runs: states with the ground track and altitude, controls against their limits, differences.

Fed by result objects only (mappings label -> :class:`gna.simulate.SimulationResult`,
a reference DataFrame); no pyplot, hence no global figure state.  Angles are
drawn in degrees and rates in deg/s, everything else in SI units
(:data:`gna.trajectory.UNITS`); every axis label carries its unit, no axis
uses offset or multiplier notation (:func:`_plain`, the sheet's own ticks: :meth:`Sheet.ticks`).

Drawing is cheap by construction: every figure of a process is drawn on one
reused figure object (:class:`Sheet`, Agg canvas, a grid of axes made once:
matplotlib's axes and tick objects are its dominant cost), with fixed margins
(no layout engine), its own tick labels (no tick objects, no tick marks: the
grid shows the ticks, :meth:`Sheet.ticks`), each string rasterised once per
process (:func:`_canvas_class`; the usual ones before the writers fork,
:func:`prepare`), the grid one line per axis, each line reduced to what a
pixel column can show (:func:`decimate`), and saved as an 8-bit RGB PNG
(:func:`png_bytes`): no alpha channel (the PDF, :mod:`reports.pdf`, embeds
the same pixels).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from gna.errors import writing
from gna.trajectory import POSITION, UNITS
from harness.metrics import DEFAULT_VARIABLES, differences, resolve_tolerances
from harness.progress import stage

#: Resolution of every figure [pixel per inch] and width of the sheet [in]: 1080 pixels, the page's width
#: on screen, 150 pixels per inch on an A4 page.
DPI, WIDTH_IN = 90, 12.0

#: Height of one row of panels [in].
ROW_IN = 2.3

#: Fixed margins of the figures [in]: the y tick labels and label (left, between columns), the x tick labels
#: and label (bottom), the title and the legend (top).  Fixed margins cost nothing at drawing time.
MARGINS_IN = {"left": 0.9, "right": 0.15, "bottom": 0.55, "top": 0.75, "wspace": 0.95, "hspace": 0.25}

#: Distance of the axis labels from their axes [in] (left of the y tick labels, below the x tick labels).
LABEL_GAP_IN = {"x": 0.36, "y": 0.72}

#: Most panels a sheet holds.
MAX_PANELS = 12

#: PNG text key under which a figure records the label of each of its axes (``"name [unit]"``, JSON list).
AXES_KEY = "gflat:axes"

#: Smallest span of a y axis per drawn unit: the comparison's resolution of each kind of quantity (the
#: cross-engine tolerances, :data:`harness.metrics.PERCENT_FLOORS`): a variation below it is drawn flat.
SPAN_FLOORS = {
    "m": 1e-2,
    "m/s": 1e-3,
    "deg": math.degrees(1e-4),
    "deg/s": math.degrees(1e-3),
    "N": 1e-3,
    "N m": 1e-4,
}

#: Line styles of the runs: the reference engine solid, the others dashed, dash-dotted.
RUN_STYLES = ("-", "--", "-.", ":")


def plot_scale(name: str) -> tuple[float, str]:
    """Factor and unit a variable is drawn in: radians as degrees, rad/s as deg/s, the rest in SI units.

    Parameters
    ----------
    name : str
        Column name (:data:`gna.trajectory.UNITS`).

    Returns
    -------
    (float, str)
        Multiplier from the SI value, and the unit drawn.
    """
    unit = UNITS.get(name, "")
    if unit == "rad":
        return math.degrees(1.0), "deg"
    if unit == "rad/s":
        return math.degrees(1.0), "deg/s"
    return 1.0, unit


def label(name: str, unit: str) -> str:
    """An axis label: ``"name [unit]"`` (``[-]`` for a dimensionless quantity).

    Parameters
    ----------
    name, unit : str

    Returns
    -------
    str
    """
    return f"{name} [{unit or '-'}]"


def decimate(t, y, width_px: int):
    """The points of a line a panel ``width_px`` pixels wide can show: per pixel column its first, lowest,
    highest and last point, in time order (the line drawn is the same to the pixel).

    Parameters
    ----------
    t, y : array_like
        Shape (n,) each.
    width_px : int
        Pixel columns of the panel.

    Returns
    -------
    (ndarray, ndarray)
        At most ``4 width_px`` points; the input itself when it is no longer, or holds a NaN.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    n, bins = t.size, max(int(width_px), 1)
    if n <= 4 * bins or not np.all(np.isfinite(y)):
        return t, y
    k = -(-n // bins)
    pad = np.concatenate([y, np.full(k * bins - n, y[-1])]).reshape(bins, k)
    lo, hi = pad.argmin(axis=1), pad.argmax(axis=1)
    idx = np.empty((bins, 4), dtype=np.int64)  # per column: first, extrema in time order, last (no sort needed)
    idx[:, 0], idx[:, 1], idx[:, 2], idx[:, 3] = 0, np.minimum(lo, hi), np.maximum(lo, hi), k - 1
    idx += (np.arange(bins) * k)[:, None]
    keep = np.append(np.minimum(idx.ravel(), n - 1), n - 1)  # non-decreasing
    keep = keep[np.concatenate([[True], np.diff(keep) > 0])]
    return t[keep], y[keep]


def span_limits(values, unit: str = "", pad: float = 0.05) -> tuple[float, float]:
    """Limits of a linear axis holding ``values``: their range padded, at least :data:`SPAN_FLOORS` of the
    unit (and 1e-4 of their magnitude) wide, so that a tick label needs few digits and no offset.

    Parameters
    ----------
    values : sequence of array_like
        The finite values drawn (NaN ignored).
    unit : str
        The drawn unit (its floor), see :data:`SPAN_FLOORS`.
    pad : float
        Share of the span added on each side.

    Returns
    -------
    (float, float)
    """
    arrays = [np.asarray(v, dtype=float).ravel() for v in values]
    finite = np.concatenate([a[np.isfinite(a)] for a in arrays]) if arrays else np.zeros(0)
    if finite.size == 0:
        return -1.0, 1.0
    lo, hi = float(finite.min()), float(finite.max())
    floor = max(SPAN_FLOORS.get(unit, 1e-9), 1e-4 * max(abs(lo), abs(hi)))
    if hi - lo < floor:
        mid = 0.5 * (lo + hi)
        lo, hi = mid - 0.5 * floor, mid + 0.5 * floor
    margin = pad * (hi - lo)
    return lo - margin, hi + margin


def log_limits(values, floor: float = 1e-16, decades: float = 10.0) -> tuple[float, float]:
    """Limits of a log axis holding the positive ``values`` (and the tolerances drawn), padded.

    Parameters
    ----------
    values : sequence of array_like
    floor : float
        Smallest value shown.
    decades : float
        Most decades shown below the largest value.

    Returns
    -------
    (float, float)
    """
    arrays = [np.asarray(v, dtype=float).ravel() for v in values]
    finite = np.concatenate([a[np.isfinite(a) & (a > 0)] for a in arrays]) if arrays else np.zeros(0)
    if finite.size == 0:
        return 1e-3, 1.0
    hi = math.log10(float(finite.max()))
    lo = max(math.log10(max(float(finite.min()), floor)), hi - decades)
    if hi - lo < 1.0:
        lo = hi - 1.0
    pad = 0.05 * (hi - lo)
    return 10.0 ** (lo - pad), 10.0 ** (hi + pad)


def _plain(values: Sequence[float]) -> list[str]:
    """Tick labels of a linear axis: fixed-point with the digits the step needs, or a short exponent form."""
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return []
    big = float(np.max(np.abs(v)))
    step = float(np.min(np.diff(v))) if v.size > 1 else (big or 1.0)
    if big >= 1e5 or (0 < big < 1e-3):
        return [f"{x:.3g}".replace("e-0", "e-").replace("e+0", "e") for x in v]
    decimals = max(0, min(8, -math.floor(math.log10(step) + 1e-9))) if step > 0 else 0
    while decimals < 8 and any(abs(float(f"{x:.{decimals}f}") - x) > 1e-6 * step for x in v):
        decimals += 1  # a step of 2.5 units of the last digit: one digit more (0.0025, not 0.003)
    out = [f"{x:.{decimals}f}" for x in v]
    return ["0" if float(s) == 0 else s for s in out]


def _decades(values: Sequence[float]) -> list[str]:
    """Tick labels of a log axis at whole decades: ``1e-6``, ``0.01``, ``1``, ``100``."""
    out = []
    for x in values:
        e = round(math.log10(x)) if x > 0 else 0
        out.append(f"{x:g}" if -2 <= e <= 3 else f"1e{e}")
    return out


def _font_key(prop) -> tuple:
    """What a text's rendering depends on of its font properties (a tuple: no hash of mutable state)."""
    return (
        tuple(prop.get_family()),
        prop.get_style(),
        prop.get_variant(),
        prop.get_weight(),
        prop.get_stretch(),
        prop.get_size_in_points(),
        prop.get_file(),
    )


#: Rendered strings (coverage bitmap, descent, offsets) and their metrics, by string, font, resolution: shared
#: by every renderer of the process (a sheet of another size has its own), inherited by forked workers.
_TEXT_BITMAPS: dict = {}
_TEXT_METRICS: dict = {}
_FONT_HEIGHTS: dict = {}

_CANVAS = None


def _canvas_class():
    """The Agg canvas of the sheets: a renderer kept per image size, each string rendered once per process.

    Matplotlib's Agg renderer lays out and rasterises every glyph of every text each time it is drawn, and
    keeps its metrics per renderer (one per image size); tick labels, axis labels and legends repeat from
    figure to figure, so each string is rasterised once, at a whole pixel, and its bitmap composited where it
    is drawn (the way matplotlib drew text up to 3.9).
    """
    global _CANVAS
    if _CANVAS is not None:
        return _CANVAS
    from matplotlib import rcParams
    from matplotlib.backends.backend_agg import FigureCanvasAgg, RendererAgg, get_hinting_flag

    class TextCacheRenderer(RendererAgg):
        def _rasterise(self, font, key) -> tuple:
            # the string laid out in ``font`` (set_text) as a coverage bitmap, its descent and offsets [pixel]
            font.draw_glyphs_to_bitmap(antialiased=key[3])
            xo, yo = font.get_bitmap_offset()
            hit = (np.array(font.get_image(), dtype=np.uint8), font.get_descent() / 64.0, xo / 64.0, yo / 64.0)
            _TEXT_BITMAPS[key] = hit
            return hit

        def draw_text(self, gc, x, y, s, prop, angle, ismath=False, mtext=None):
            if ismath:
                return super().draw_text(gc, x, y, s, prop, angle, ismath, mtext)
            key = (s, _font_key(prop), self.dpi, bool(gc.get_antialiased()))
            hit = _TEXT_BITMAPS.get(key)
            if hit is None:
                font = self._prepare_font(prop)
                font.set_text(s, 0, flags=get_hinting_flag())
                hit = self._rasterise(font, key)
            image, d, xo, yo = hit
            if image.size == 0:
                return None
            a = math.radians(angle)
            self._renderer.draw_text_image(
                image, round(x + xo + d * math.sin(a)), round(y + yo + d * math.cos(a)) + 1, angle, gc
            )
            return None

        def _get_font_height_metrics(self, prop):
            # the font's ascent, descent and line gap, which matplotlib reads from its tables for every text laid
            # out (matplotlib.text.Text._get_layout: the same formulas)
            key = (_font_key(prop), self.dpi)
            m = _FONT_HEIGHTS.get(key)
            if m is None:
                m = (None, None, None)
                font = self._prepare_font(prop)
                units = font.get_sfnt_table("head")
                for table_name, gap, ascent, descent in (
                    ("OS/2", "sTypoLineGap", "sTypoAscender", "sTypoDescender"),
                    ("hhea", "lineGap", "ascent", "descent"),
                ):
                    table = font.get_sfnt_table(table_name)
                    if table is None or units is None:
                        continue
                    scale = prop.get_size_in_points() * self.dpi / 72 / units["unitsPerEm"]
                    m = (table[ascent] * scale, -table[descent] * scale, table[gap] * scale)
                    break
                _FONT_HEIGHTS[key] = m
            return m

        def get_text_width_height_descent(self, s, prop, ismath):
            if ismath:
                return super().get_text_width_height_descent(s, prop, ismath)
            fk = _font_key(prop)
            key = (s, fk, self.dpi)
            m = _TEXT_METRICS.get(key)
            if m is None:
                # matplotlib's measure (RendererAgg.get_text_width_height_descent), and the string rasterised from
                # the same layout for its drawing, which follows (laying a string out is the dear part)
                font = self._prepare_font(prop)
                font.set_text(s, 0.0, flags=get_hinting_flag())
                w, h = font.get_width_height()
                m = _TEXT_METRICS[key] = (w / 64.0, h / 64.0, font.get_descent() / 64.0)
                drawn = (s, fk, self.dpi, bool(rcParams["text.antialiased"]))
                if drawn not in _TEXT_BITMAPS:
                    self._rasterise(font, drawn)
            return m

    class SheetCanvas(FigureCanvasAgg):
        def __init__(self, figure):
            super().__init__(figure)
            self._renderers: dict = {}

        def get_renderer(self):
            w, h = self.get_width_height(physical=True)
            key = (w, h, self.figure.dpi)
            if self._lastKey != key:
                if key not in self._renderers:
                    self._renderers[key] = TextCacheRenderer(w, h, self.figure.dpi)
                self.renderer = self._renderers[key]
                self._lastKey = key
            return self.renderer

    _CANVAS = SheetCanvas
    return _CANVAS


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    import struct
    import zlib

    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png_bytes(rgba, text: dict[str, str] | None = None, level: int = 1) -> bytes:
    """An 8-bit RGB PNG of an RGBA pixel buffer, its rows unfiltered, deflated at ``level``.

    A figure is mostly flat colour: unfiltered rows deflated fast cost a third of a filtered, level-6 PNG's
    encoding for about 25 % more bytes (Typst compresses the pixels again in the PDF: :mod:`reports.pdf`).

    Parameters
    ----------
    rgba : array_like
        Shape (height, width, 4), uint8 (an Agg canvas's ``buffer_rgba()``); the alpha channel is dropped.
    text : dict, optional
        Text chunks (``tEXt``, or ``iTXt`` when not Latin-1).
    level : int
        zlib compression level.

    Returns
    -------
    bytes
    """
    import struct
    import zlib

    from PIL import Image

    a = np.asarray(rgba, dtype=np.uint8)
    h, w = a.shape[:2]
    rgb = Image.frombuffer("RGBA", (w, h), np.ascontiguousarray(a), "raw", "RGBA", 0, 1).convert("RGB").tobytes()
    rows = np.zeros((h, 1 + 3 * w), dtype=np.uint8)  # filter byte 0 (none) before each row
    rows[:, 1:] = np.frombuffer(rgb, dtype=np.uint8).reshape(h, 3 * w)  # (PIL drops the alpha 10x faster)
    chunks = [_png_chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))]
    for key, value in (text or {}).items():
        try:
            chunks.append(_png_chunk(b"tEXt", key.encode("latin-1") + b"\0" + value.encode("latin-1")))
        except UnicodeEncodeError:
            chunks.append(_png_chunk(b"iTXt", key.encode("latin-1") + b"\0\0\0\0\0" + value.encode("utf-8")))
    chunks.append(_png_chunk(b"IDAT", zlib.compress(rows.tobytes(), level)))
    chunks.append(_png_chunk(b"IEND", b""))
    return b"\x89PNG\r\n\x1a\n" + b"".join(chunks)


def _in_view(locs, ax, which: str) -> np.ndarray:
    """The tick locations ``locs`` within the view of the ``which`` (``"x"``, ``"y"``) axis of ``ax``, as matplotlib
    selects the ticks it draws (within a 1e-10 share of the view, in the axis's scale)."""
    locs = np.asarray(locs, dtype=float)
    axis = ax.xaxis if which == "x" else ax.yaxis
    lo, hi = sorted(axis.get_view_interval())
    tr = axis.get_transform()
    (a, b), t = tr.transform(np.array([lo, hi])), tr.transform(locs) if locs.size else locs
    tol = 1e-10 * (b - a)
    return locs[np.isfinite(t) & (t >= a - tol) & (t <= b + tol)]


class Sheet:
    """One Agg figure with :data:`MAX_PANELS` axes, reused for every figure a process draws.

    :meth:`panels` lays out a grid of ``rows x cols`` of its axes for the
    next figure (the others hidden), each emptied of the previous figure's
    artists but keeping its tick labels; :meth:`save` draws and writes it.
    """

    def __init__(self):
        from matplotlib import ticker
        from matplotlib.figure import Figure

        self.fig = Figure(figsize=(WIDTH_IN, 4 * ROW_IN), dpi=DPI, layout=None)
        _canvas_class()(self.fig)
        self._ticker = ticker
        self.axes = [self.fig.add_axes((0, 0, 0.1, 0.1)) for _ in range(MAX_PANELS)]
        # the ticks are the sheet's (:meth:`ticks`): matplotlib's axes draw none (its tick objects, five artists
        # each, laid out at every draw, were half the cost of a figure); tick marks are not drawn, the grid
        # shows where the ticks are
        self._x_locator = ticker.MaxNLocator(nbins=5, steps=[1, 2, 2.5, 5, 10])
        self._y_locators = {
            "linear": (ticker.MaxNLocator(nbins=5, steps=[1, 2, 2.5, 5, 10]), _plain),
            "log": (ticker.LogLocator(base=10.0, numticks=6), _decades),
        }
        self._labels: dict = {}
        self._x_labelled: dict = {}
        self._y_scale: dict = {}
        for ax in self.axes:
            ax.set_autoscale_on(False)
            ax.grid(False)  # drawn by grid() at saving time: one line per axis, not one per tick
            if ax.patch.get_facecolor() == self.fig.patch.get_facecolor():
                ax.patch.set_visible(False)  # the figure's own colour: drawn for nothing
            self._no_axis_ticks(ax)
            self._labels[ax] = {"x": [], "y": []}
        self.shown: list = []
        self.time_row: dict = {}
        self.width_px = 300

    def _no_axis_ticks(self, ax) -> None:
        ticker = self._ticker
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_locator(ticker.NullLocator())
            axis.set_minor_locator(ticker.NullLocator())
            axis.set_major_formatter(ticker.NullFormatter())
            axis.set_minor_formatter(ticker.NullFormatter())

    def panels(self, rows: int, cols: int, title: str, *, height_in: float = ROW_IN, hspace_in=None) -> list:
        """The axes of the next figure, ``rows x cols`` of them in reading order, empty.

        Parameters
        ----------
        rows, cols : int
            Grid (``rows * cols <= MAX_PANELS``).
        title : str
            The figure's title.
        height_in : float
            Height of a row [in].
        hspace_in : float, optional
            Space between rows [in] (default :data:`MARGINS_IN`; more when a panel above the bottom row
            labels its x axis).

        Returns
        -------
        list of matplotlib.axes.Axes

        Raises
        ------
        ValueError
            More panels than :data:`MAX_PANELS`.
        """
        n = rows * cols
        if n > MAX_PANELS:
            raise ValueError(f"a sheet holds at most {MAX_PANELS} panels, asked for {rows} x {cols}")
        m = dict(MARGINS_IN)
        if hspace_in is not None:
            m["hspace"] = hspace_in
        w = WIDTH_IN
        h = m["top"] + m["bottom"] + rows * height_in + (rows - 1) * m["hspace"]
        self.fig.set_size_inches(w, h)
        ax_w = (w - m["left"] - m["right"] - (cols - 1) * m["wspace"]) / cols
        self.width_px = int(ax_w * DPI)
        for lg in list(self.fig.legends):
            lg.remove()
        for t in list(self.fig.texts):
            t.remove()
        self.fig.suptitle(title, fontsize=11, y=1 - 0.12 / h, va="top")
        for i, ax in enumerate(self.axes):
            if i >= n:
                ax.set_visible(False)
                continue
            r, c = divmod(i, cols)
            left = m["left"] + c * (ax_w + m["wspace"])
            bottom = h - m["top"] - (r + 1) * height_in - r * m["hspace"]
            ax.set_position((left / w, bottom / h, ax_w / w, height_in / h))
            self._clear(ax)
            ax.set_visible(True)
            # labels placed at fixed distances: matplotlib would measure every tick label to place them
            ax.yaxis.set_label_coords(-LABEL_GAP_IN["y"] / ax_w, 0.5)
            ax.xaxis.set_label_coords(0.5, -LABEL_GAP_IN["x"] / height_in)
            self.time_row[ax] = i + cols >= n  # the bottom panel of its column: the time axis labelled
        self.shown = self.axes[:n]
        return list(self.shown)

    def _clear(self, ax) -> None:
        """Remove the previous figure's artists from ``ax``, keep its axis objects and the sheet's tick labels."""
        keep = set(self._labels[ax]["x"] + self._labels[ax]["y"])
        texts = [t for t in ax.texts if t not in keep]
        for artist in list(ax.lines) + list(ax.collections) + texts + list(ax.patches):
            artist.remove()
        if ax.get_legend() is not None:
            ax.get_legend().remove()
        ax.set_xlabel("")
        ax.set_ylabel("")
        ax.set_aspect("auto")
        ax.set_prop_cycle(None)
        self.linear(ax)
        self.x_ticks_labelled(ax, True)
        if not ax.axison:
            ax.axis("on")

    def x_ticks_labelled(self, ax, on: bool) -> None:
        """Label the x ticks of ``ax`` or not.

        Parameters
        ----------
        ax : matplotlib.axes.Axes
            A panel of the sheet.
        on : bool
            Whether its x tick labels are drawn.
        """
        self._x_labelled[ax] = on

    def linear(self, ax) -> None:
        """Give ``ax`` a linear y axis with plain tick labels (at most six).

        Parameters
        ----------
        ax : matplotlib.axes.Axes
            A panel of the sheet.
        """
        if self._y_scale.get(ax) == "linear":
            return
        ax.set_yscale("linear")
        self._no_axis_ticks(ax)  # (a scale sets its own locators)
        self._y_scale[ax] = "linear"

    def log(self, ax) -> None:
        """Give ``ax`` a log y axis with decade ticks only (no minor ticks).

        Parameters
        ----------
        ax : matplotlib.axes.Axes
            A panel of the sheet.
        """
        if self._y_scale.get(ax) == "log":
            return
        ax.set_yscale("log")
        self._no_axis_ticks(ax)
        self._y_scale[ax] = "log"

    def tick_locations(self, ax) -> tuple[np.ndarray, list[str], np.ndarray, list[str]]:
        """The ticks of ``ax`` within its view and their labels, x then y (as matplotlib's locators and the
        sheet's formatters place them: :func:`_plain` on a linear axis, :func:`_decades` on a log one).

        Parameters
        ----------
        ax : matplotlib.axes.Axes
            A panel of the sheet, its limits set.

        Returns
        -------
        (ndarray, list of str, ndarray, list of str)
        """
        out = []
        for which, (locator, fmt) in (
            ("x", (self._x_locator, _plain)),
            ("y", self._y_locators[self._y_scale.get(ax, "linear")]),
        ):
            lo, hi = sorted((ax.get_xlim if which == "x" else ax.get_ylim)())
            locs = np.asarray(locator.tick_values(lo, hi), dtype=float)
            labels = dict(zip(locs.tolist(), fmt(locs)))  # formatted together: the step sets the digits
            shown = _in_view(locs, ax, which)
            out += [shown, [labels[v] for v in shown.tolist()]]
        return tuple(out)

    def _tick_label(self, ax, which: str, i: int):
        """The ``i``-th tick label of the ``which`` axis of ``ax``: a text made once, as matplotlib's tick
        label (its font size, colour, alignment and distance to the axis: tick length and pad)."""
        pool = self._labels[ax][which]
        while len(pool) <= i:
            from matplotlib import rcParams
            from matplotlib.text import Text

            name = f"{which}tick"
            pad = rcParams[f"{name}.major.pad"] + rcParams[f"{name}.major.size"]  # an outward tick's
            tr, va, ha = ax.get_xaxis_text1_transform(pad) if which == "x" else ax.get_yaxis_text1_transform(pad)
            colour = rcParams[f"{name}.labelcolor"]
            if colour == "inherit":
                colour = rcParams[f"{name}.color"]
            text = Text(0.0, 0.0, "", fontsize=rcParams[f"{name}.labelsize"], color=colour, va=va, ha=ha)
            text.set_transform(tr)
            ax.add_artist(text)
            text.set_clip_on(False)  # (add_artist clips to the axes)
            pool.append(text)
        return pool[i]

    def ticks(self, ax) -> tuple[np.ndarray, np.ndarray]:
        """Set the tick labels of ``ax`` for its limits (the x ones unless :meth:`x_ticks_labelled` said no).

        Parameters
        ----------
        ax : matplotlib.axes.Axes
            A panel of the sheet, its limits set.

        Returns
        -------
        (ndarray, ndarray)
            The x and y tick locations (where the grid is drawn).
        """
        xs, xl, ys, yl = self.tick_locations(ax)
        if not self._x_labelled.get(ax, True):
            xl = []
        for which, locs, labels in (("x", xs, xl), ("y", ys, yl)):
            for i, (v, text) in enumerate(zip(locs.tolist(), labels)):
                t = self._tick_label(ax, which, i)
                t.set_position((v, 0.0) if which == "x" else (0.0, v))
                t.set_text(text)
                t.set_visible(True)
            for t in self._labels[ax][which][len(labels) :]:
                t.set_visible(False)
        return xs, ys

    def line(self, ax, t, y, **kw):
        """Draw ``y(t)`` decimated to the panel's pixel columns (:func:`decimate`).

        Parameters
        ----------
        ax : matplotlib.axes.Axes
            A panel of the sheet.
        t, y : array_like
            Shape (n,) each.
        **kw
            Line properties (``matplotlib.axes.Axes.plot``).

        Returns
        -------
        list of matplotlib.lines.Line2D
        """
        tt, yy = decimate(t, y, self.width_px)
        if "color" not in kw:  # the axes' colour cycle
            return ax.plot(tt, yy, **kw)
        from matplotlib.lines import Line2D

        line = Line2D(tt, yy, **kw)
        ax.add_artist(line)  # not Axes.plot: no arguments to parse, no data limits (the sheet does not autoscale)
        return [line]

    def legend(self, handles, labels, ncol: int | None = None) -> None:
        """Draw one legend for the figure, under its title.

        Parameters
        ----------
        handles : list of matplotlib.artist.Artist
        labels : list of str
        ncol : int, optional
            Columns (default: as many as entries, at most six).
        """
        if not handles:
            return
        h = self.fig.get_figheight()
        self.fig.legend(
            handles,
            labels,
            loc="upper center",
            bbox_to_anchor=(0.5, 1 - 0.36 / h),
            ncol=ncol or min(len(labels), 6),
            fontsize=8,
            frameon=False,
        )

    def grid(self, ax, xs=None, ys=None) -> None:
        """Draw the grid of ``ax`` at its ticks as one line per axis (matplotlib's grid is a line per tick, each
        an artist to draw), in matplotlib's grid style (``grid.color``, ``grid.linewidth``, alpha 0.3), under
        the data.

        Parameters
        ----------
        ax : matplotlib.axes.Axes
            A panel of the sheet, its limits set.
        xs, ys : array_like, optional
            The tick locations (default :meth:`tick_locations`).
        """
        from matplotlib import rcParams
        from matplotlib.lines import Line2D

        if xs is None or ys is None:
            xs, _, ys, _ = self.tick_locations(ax)
        style = {
            "color": rcParams["grid.color"],
            "lw": rcParams["grid.linewidth"],
            "ls": rcParams["grid.linestyle"],
            "alpha": 0.3,
            "zorder": 1.5,
            "label": "_grid",
        }
        for locs, transform, vertical in (
            (xs, ax.get_xaxis_transform("grid"), True),
            (ys, ax.get_yaxis_transform("grid"), False),
        ):
            locs = np.asarray(locs, dtype=float)
            if not locs.size:
                continue
            at = np.repeat(locs, 3)
            at[2::3] = np.nan
            across = np.tile([0.0, 1.0, np.nan], locs.size)
            x, y = (at, across) if vertical else (across, at)
            line = Line2D(x, y, transform=transform, **style)
            ax.add_artist(line)

    def axis_labels(self) -> list[str]:
        """The label of every shown axis (``"name [unit]"``), in panel order, without repeats.

        Returns
        -------
        list of str
        """
        out = []
        for ax in self.shown:
            if not ax.axison:
                continue
            for text in (ax.get_ylabel(), ax.get_xlabel()):
                if text and text not in out:
                    out.append(text)
        return out

    def save(self, out, name: str) -> Path:
        """Draw the figure and write it as an RGB PNG ``name`` in the folder ``out`` (made when missing).

        The label of every axis is recorded in the PNG's text chunk :data:`AXES_KEY` (JSON).

        Parameters
        ----------
        out : str or Path
            Output folder.
        name : str
            File name (``.png``).

        Returns
        -------
        Path
            The file written.
        """
        for ax in self.axes:
            if ax in self.shown and ax.axison and ax.get_visible():
                self.grid(ax, *self.ticks(ax))
            else:
                for t in self._labels[ax]["x"] + self._labels[ax]["y"]:
                    t.set_visible(False)
        canvas = self.fig.canvas
        canvas.draw()
        data = png_bytes(canvas.buffer_rgba(), {AXES_KEY: json.dumps(self.axis_labels())})
        path = Path(out) / name
        with writing(path):
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
        return path


_SHEET: Sheet | None = None


def sheet() -> Sheet:
    """This process's :class:`Sheet` (made on first use; a forked worker inherits its parent's).

    Returns
    -------
    Sheet
    """
    global _SHEET
    if _SHEET is None:
        _SHEET = Sheet()
    return _SHEET


#: Tick labels made for every panel ahead of the figures (:func:`prepare`; more are made when a panel needs them).
PREPARED_TICKS = 7


def _common_strings() -> list[tuple[str, str | float]]:
    """The strings every case's figures draw, each with its font size: axis labels, legend entries, the usual
    tick labels (decades, the time axis, round numbers)."""
    from matplotlib import rcParams

    from harness.engines import engine_names

    from .report_figures import SINGULARITY_UNITS
    from .tracking import TRACKING_VARIABLES

    axis = ["t [s]", "h = -z [m]", "|position - plan| [m]", "x (north) [m]", "y (east) [m]", "F [N]"]
    axis += [label(v, plot_scale(v)[1]) for v in STATE_PANELS + TRACKING_VARIABLES]
    axis += [label(f"thrust[{i}]", "N") for i in range(1, 5)] + [
        label(n, plot_scale(n)[1]) for n in ("eta", "dl", "dm", "dn")
    ]
    axis += [label(f"|d {g}|", plot_scale(names[-1])[1]) for g, names in DIFFERENCE_GROUPS.items()]
    axis += ["|position - flat outputs| [m]"] + [label(c, u) for c, u in SINGULARITY_UNITS.items()]
    legend = ["plan", "limit", "flat plan J = 0", "open loop, generalized controls", "closed loop, feedforward J = 0"]
    legend += list(engine_names())
    differences = ["h" if v == "z" else v for names in DIFFERENCE_GROUPS.values() for v in names] + ["tolerance"]
    ticks = _decades([10.0**e for e in range(-16, 5)]) + [str(v) for v in range(0, 301, 25)]
    ticks += [str(v) for v in range(-100, 101, 10)] + [str(v) for v in range(-5, 6)]
    ticks += _plain(np.arange(-1.0, 1.01, 0.5)) + _plain(np.arange(-1.0, 1.01, 0.25))
    ticks += [str(v) for v in range(-1000, 1001, 200)] + [str(v) for v in range(-6000, 6001, 1000)]
    sizes = (rcParams["axes.labelsize"], 8, 7, rcParams["ytick.labelsize"])
    return [(text, size) for texts, size in zip((axis, legend, differences, ticks), sizes) for text in texts]


def prepare() -> None:
    """Make this process's sheet, its tick labels, and draw it once, and rasterise the strings every case draws
    (:func:`_common_strings`), so that forked workers inherit them.

    Cheaper than each worker making its own: call it before forking the workers that draw figures.
    """
    from matplotlib.font_manager import FontProperties

    s = sheet()
    axes = s.panels(4, 3, "")
    t = np.linspace(0.0, 1.0, 3)
    for ax in axes:
        ax.plot(t, t)
        ax.set_xlim(0, 1)
        ax.set_ylim(0, 1)
        for i in range(PREPARED_TICKS):
            s._tick_label(ax, "x", i)  # noqa: SLF001  (the sheet's own)
            s._tick_label(ax, "y", i)  # noqa: SLF001
    s.fig.canvas.draw()
    renderer = s.fig.canvas.get_renderer()
    for text, size in _common_strings():
        renderer.get_text_width_height_descent(text, FontProperties(size=size), False)


def recorded_axes(path: str | Path) -> list[str] | None:
    """The axis labels a figure written by :meth:`Sheet.save` records (None: none recorded).

    Parameters
    ----------
    path : str or Path
        A PNG file.

    Returns
    -------
    list of str or None
    """
    from PIL import Image

    try:
        with Image.open(path) as im:
            text = im.info.get(AXES_KEY)
    except (OSError, ValueError):
        return None
    if not isinstance(text, str):
        return None
    try:
        labels = json.loads(text)
    except ValueError:
        return None
    return [str(x) for x in labels] if isinstance(labels, list) else None


# --------------------------------------------------------------------------- the case figures


def _t(df) -> np.ndarray:
    return np.asarray(df.index, dtype=float)


def time_axis(ax, t0: float, t1: float, s: Sheet) -> None:
    """Set a panel's time axis: ``t0 .. t1`` [s], its ticks labelled on the bottom panel of each column only.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        A panel of ``s``.
    t0, t1 : float
        Span [s].
    s : Sheet
        The sheet.
    """
    ax.set_xlim(t0, t1 if t1 > t0 else t0 + 1.0)
    bottom = s.time_row.get(ax, True)
    s.x_ticks_labelled(ax, bottom)
    ax.set_xlabel(label("t", "s") if bottom else "")


def _span(results: Mapping, reference) -> tuple[float, float]:
    ts = [_t(r.df) for r in results.values() if len(r.df)]
    if reference is not None and len(reference):
        ts.append(_t(reference))
    if not ts:
        return 0.0, 1.0
    return min(float(t[0]) for t in ts), max(float(t[-1]) for t in ts)


def _series(name: str, results: Mapping, reference) -> list[tuple[str, np.ndarray, np.ndarray, dict]]:
    """(label, t, drawn values, style) of ``name`` for the plan (dotted black) and every run."""
    k, _ = plot_scale(name)
    out = []
    if reference is not None and name in reference.columns:
        out.append(("plan", _t(reference), reference[name].to_numpy(float) * k, {"color": "k", "ls": ":", "lw": 2.0}))
    for i, (lab, res) in enumerate(results.items()):
        if name in res.df.columns:
            style = {"color": f"C{i}", "ls": RUN_STYLES[i % len(RUN_STYLES)], "lw": 1.2}
            out.append((lab, _t(res.df), res.df[name].to_numpy(float) * k, style))
    return out


def _draw_time(s: Sheet, ax, series, unit: str, ylabel: str, span) -> dict:
    handles = {}
    for lab, t, y, style in series:
        (handles[lab],) = s.line(ax, t, y, label=lab, **style)
    ax.set_ylim(*span_limits([y for _, _, y, _ in series], unit))
    ax.set_ylabel(ylabel)
    time_axis(ax, *span, s)
    return handles


def _altitude(series):
    return [(lab, t, -y, style) for lab, t, y, style in series]


def _ground_track(s: Sheet, ax, results: Mapping, reference) -> dict:
    """North x against east y, equal scales (north up)."""
    handles, xs, ys = {}, [], []
    curves = []
    if reference is not None and {"x", "y"} <= set(reference.columns):
        curves.append(("plan", reference, {"color": "k", "ls": ":", "lw": 2.0}))
    for i, (lab, res) in enumerate(results.items()):
        curves.append((lab, res.df, {"color": f"C{i}", "ls": RUN_STYLES[i % len(RUN_STYLES)], "lw": 1.2}))
    for lab, df, style in curves:
        east, north = df["y"].to_numpy(float), df["x"].to_numpy(float)
        (handles[lab],) = ax.plot(east, north, label=lab, **style)
        xs.append(east)
        ys.append(north)
    x0, x1 = span_limits(xs, "m")
    y0, y1 = span_limits(ys, "m")
    # equal scales: the panel's shorter data side widened to its aspect
    pos = ax.get_position()
    fw, fh = s.fig.get_size_inches()
    aspect = (pos.height * fh) / (pos.width * fw)
    if (y1 - y0) / (x1 - x0) < aspect:
        mid, half = 0.5 * (y0 + y1), 0.5 * aspect * (x1 - x0)
        y0, y1 = mid - half, mid + half
    else:
        mid, half = 0.5 * (x0 + x1), 0.5 * (y1 - y0) / aspect
        x0, x1 = mid - half, mid + half
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_xlabel(label("y (east)", "m"))
    ax.set_ylabel(label("x (north)", "m"))
    return handles


def _distance_to_plan(s: Sheet, ax, results: Mapping, reference, span) -> dict:
    from harness.metrics import position_error

    handles, drawn = {}, []
    s.log(ax)
    for i, (lab, res) in enumerate(results.items()):
        err = position_error(res, reference)
        d = np.maximum(err.to_numpy(float), 1e-9)
        drawn.append(d)
        style = {"color": f"C{i}", "ls": RUN_STYLES[i % len(RUN_STYLES)], "lw": 1.2}
        (handles[lab],) = s.line(ax, _t(err), d, label=lab, **style)
    ax.set_ylim(*log_limits(drawn, 1e-9))
    ax.set_ylabel(label("|position - plan|", "m"))
    time_axis(ax, *span, s)
    return handles


#: Panels of the states figure after the ground track, the altitude and the distance to the plan.
STATE_PANELS: tuple[str, ...] = ("V", "gamma", "chi", "alpha", "beta", "mu", "p", "q", "r")


def draw_states(results: Mapping, out, *, reference=None, title: str = "", name: str = "states.png") -> Path:
    """States of every run and the plan: ground track (north up), altitude, distance to the plan, the others.

    Parameters
    ----------
    results : mapping label -> SimulationResult
        The runs (the first is the reference engine).
    out : str or Path
        Folder.
    reference : DataFrame, optional
        The plan's states indexed by ``t`` [s] (dotted).
    title : str
        Prefix of the figure's title.
    name : str
        File name.

    Returns
    -------
    Path
    """
    s = sheet()
    axes = s.panels(4, 3, f"{title}: ground track, altitude and states", hspace_in=0.55)
    span = _span(results, reference)
    handles = _ground_track(s, axes[0], results, reference)
    _draw_time(s, axes[1], _altitude(_series("z", results, reference)), "m", label("h = -z", "m"), span)
    if reference is not None and {"x", "y", "z"} <= set(reference.columns):
        _distance_to_plan(s, axes[2], results, reference, span)
    else:
        axes[2].axis("off")
    for ax, var in zip(axes[3:], STATE_PANELS):
        k, unit = plot_scale(var)
        _draw_time(s, ax, _series(var, results, reference), unit, label(var, unit), span)
    s.legend(list(handles.values()), list(handles))
    return s.save(out, name)


def control_panels(aircraft) -> list[tuple[str, object]]:
    """The panels of the controls figure: each engine's thrust, eta (two engines), the surfaces.

    Parameters
    ----------
    aircraft : gna.aircraft.Aircraft or None
        Its limits (:func:`gna.limits.aircraft_limits`, the one definition); None: the five controls unbounded.

    Returns
    -------
    list of (str, gna.limits.Limit or None)
        Panel name (``"thrust[1]"``, ``"eta"``, ``"dl"`` ...) and its limit.
    """
    if aircraft is None:
        return [(n, None) for n in ("F", "eta", "dl", "dm", "dn")]
    from gna.limits import aircraft_limits

    limits = {lim.name: lim for lim in aircraft_limits(aircraft) if lim.kind == "control"}
    names = [f"thrust[{i}]" for i in range(1, aircraft.propulsion.count + 1)]
    names += (["eta"] if aircraft.propulsion.count == 2 else []) + ["dl", "dm", "dn"]
    return [(n, limits.get(n)) for n in names]


def _control_values(name: str, limit, df) -> tuple[np.ndarray, str, float]:
    if limit is not None and name.startswith("thrust"):
        return np.asarray(limit.value_of(df, None), dtype=float), "N", 1.0
    k, unit = plot_scale(name)
    return df[name].to_numpy(float) * k, unit, k


def draw_controls(
    results: Mapping, out, *, reference=None, aircraft=None, title: str = "", name: str = "controls.png"
) -> Path:
    """Applied controls of every run and the plan, each against the aircraft's limits (red dash-dotted).

    Parameters
    ----------
    results : mapping label -> SimulationResult
    out : str or Path
        Folder.
    reference : DataFrame, optional
        The plan's controls indexed by ``t`` [s] (dotted).
    aircraft : gna.aircraft.Aircraft, optional
        Its limits (:func:`control_panels`); without it the five controls, no limit.
    title : str
    name : str

    Returns
    -------
    Path
    """
    s = sheet()
    panels = control_panels(aircraft)
    rows = -(-len(panels) // 3)
    axes = s.panels(rows, 3, f"{title}: applied controls against the aircraft's limits")
    span = _span(results, reference)
    handles = {}
    curves = []
    if reference is not None:
        curves.append(("plan", reference, {"color": "k", "ls": ":", "lw": 2.0}))
    for i, (lab, res) in enumerate(results.items()):
        curves.append((lab, res.df, {"color": f"C{i}", "ls": RUN_STYLES[i % len(RUN_STYLES)], "lw": 1.2}))
    for ax, (pname, limit) in zip(axes, panels):
        thrust = limit is not None and pname.startswith("thrust")
        k, unit = (1.0, "N") if thrust else plot_scale(pname)
        need = limit.columns if thrust else (pname,)
        drawn, bounded = [], None
        for lab, df, style in curves:
            if not all(c in df.columns for c in need):
                continue  # a reference of states only
            y, _, _ = _control_values(pname, limit, df)
            (handles[lab],) = s.line(ax, _t(df), y, label=lab, **style)
            drawn.append(y)
            if limit is not None and all(c in df.columns for c in limit.columns):
                bounded = df
        if bounded is not None:
            t = _t(bounded)
            for bound in limit.bounds(bounded):
                b = np.asarray(bound, dtype=float) * k
                if np.all(np.isfinite(b)):
                    (handles["limit"],) = s.line(ax, t, b, color="r", ls="-.", lw=1.0, label="limit")
                    drawn.append(b)
        ax.set_ylim(*span_limits(drawn, unit))
        ax.set_ylabel(label(pname, unit))
        time_axis(ax, *span, s)
    for ax in axes[len(panels) :]:
        ax.axis("off")
    s.legend(list(handles.values()), list(handles))
    return s.save(out, name)


#: Panels of the differences figure: drawn unit -> the variables drawn in it.
DIFFERENCE_GROUPS: dict[str, tuple[str, ...]] = {
    "position": ("position", "x", "y", "z"),
    "speed": ("V",),
    "angles": ("gamma", "chi", "alpha", "beta", "mu"),
    "rates": ("p", "q", "r"),
}


def _difference_of(a, b):
    """The common times of two runs [s] and a function ``variable -> b - a`` there, as
    :func:`harness.metrics.differences` (its formula: the position's distance, angles wrapped), the runs aligned once
    for every variable (the one-variable function aligns them at each call)."""
    from harness.metrics.tables import difference

    A, B = a.df, b.df
    ta, tb = np.asarray(A.index, dtype=float), np.asarray(B.index, dtype=float)
    if ta.size == tb.size and np.array_equal(ta, tb):
        ia = ib = slice(None)
        t = ta
    else:
        t, ia, ib = np.intersect1d(ta, tb, assume_unique=True, return_indices=True)

    def diff(variable: str) -> np.ndarray:
        cols = ("x", "y", "z") if variable == POSITION else (variable,)
        if not all(c in A.columns and c in B.columns for c in cols):
            return differences(a, b, variable).to_numpy(float)  # its error, said once
        pa = {c: A[c].to_numpy(float)[ia] for c in cols}
        pb = {c: B[c].to_numpy(float)[ib] for c in cols}
        return np.asarray(difference(variable, pa, pb), dtype=float)

    return t, diff


def draw_differences(results: Mapping, out, *, tolerances=None, title: str = "", name: str = "differences.png"):
    """Absolute differences of every run to the first (log scale), one panel per kind of quantity, the
    tolerances dotted in red.

    Parameters
    ----------
    results : mapping label -> SimulationResult
        Two runs or more; the first is the reference.
    out : str or Path
    tolerances : None, float or mapping
        :func:`harness.metrics.resolve_tolerances`.
    title : str
    name : str

    Returns
    -------
    Path or None
        None with a single run.
    """
    labels = list(results)
    if len(labels) < 2:
        return None
    tol = resolve_tolerances(tolerances, DEFAULT_VARIABLES)
    s = sheet()
    axes = s.panels(2, 2, f"{title}: differences to {labels[0]}", height_in=2.6)
    ref = results[labels[0]]
    span = _span(results, None)
    aligned = {lab: _difference_of(ref, results[lab]) for lab in labels[1:]}
    for ax, (group, names) in zip(axes, DIFFERENCE_GROUPS.items()):
        s.log(ax)
        drawn, unit = [], ""
        for j, lab in enumerate(labels[1:]):
            t, d = aligned[lab]
            for c, var in enumerate(names):
                k, unit = plot_scale(var)
                y = np.maximum(np.abs(d(var)) * k, 1e-16)
                shown = "h" if var == "z" else var
                who = shown if len(labels) == 2 else f"{shown}, {lab}"
                s.line(ax, t, y, color=f"C{c}", ls=RUN_STYLES[j % len(RUN_STYLES)], lw=1.0, label=who)
                drawn.append(y)
        for value in sorted({tol[v] * plot_scale(v)[0] for v in names if v in tol}):
            ax.axhline(value, color="r", ls=":", lw=1.2, label="tolerance")
            drawn.append([value])
        ax.set_ylim(*log_limits(drawn))
        ax.set_ylabel(label(f"|d {group}|", unit))
        time_axis(ax, *span, s)
        ax.legend(fontsize=7, ncol=3, loc="lower right", framealpha=0.8)
    return s.save(out, name)


def write_figures(
    results: Mapping,
    out_dir,
    *,
    reference: pd.DataFrame | None = None,
    title: str = "",
    tolerances=None,
    aircraft=None,
    progress=None,
) -> list[Path]:
    """States and controls of every engine (and the reference), and the differences to the first engine.

    Parameters
    ----------
    results : mapping label -> SimulationResult
        Runs on a common output grid; the first is the reference engine.
    out_dir : str or Path
        Folder the PNG files are written to (created if needed).
    reference : DataFrame, optional
        Planned states and controls indexed by ``t`` [s], drawn dotted (e.g. the plan's).
    title : str
        Prefix of the figure titles.
    tolerances : None, float or mapping
        Drawn as lines on the difference plots (see
        :func:`harness.metrics.resolve_tolerances`).
    aircraft : gna.aircraft.Aircraft, optional
        Its limits, drawn on the controls (:func:`draw_controls`).
    progress : harness.progress.Progress, optional
        Each figure drawn is a stage (``drawing states.png of <title>``).

    Returns
    -------
    list of Path
        ``states.png``, ``controls.png`` and (with two runs or more) ``differences.png``.
    """
    of = f" of {title}" if title else ""
    with stage(progress, f"drawing states.png{of}"):
        paths = [draw_states(results, out_dir, reference=reference, title=title)]
    with stage(progress, f"drawing controls.png{of}"):
        paths.append(draw_controls(results, out_dir, reference=reference, aircraft=aircraft, title=title))
    if len(results) < 2:
        return paths
    with stage(progress, f"drawing differences.png{of}"):
        diff = draw_differences(results, out_dir, tolerances=tolerances, title=title)
    return paths + ([diff] if diff is not None else [])
