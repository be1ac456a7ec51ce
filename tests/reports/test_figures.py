"""The figures' drawing helpers: plain tick labels (no offset), decimation to the pixel columns, floors of the
axis spans, the reused sheet and the axis labels it records."""

from __future__ import annotations

import numpy as np

from reports.figures import _plain, decimate, recorded_axes, sheet, span_limits


def test_tick_labels_are_plain_numbers_with_the_digits_the_step_needs():
    assert _plain([72.020, 72.022, 72.024]) == ["72.020", "72.022", "72.024"]  # never 1e-3+7.2e1
    assert _plain([0, 0.0025, 0.005]) == ["0", "0.0025", "0.0050"]  # not rounded to 0.003
    assert _plain([-1.0, -0.5, 0.0]) == ["-1.0", "-0.5", "0"]
    assert _plain([1e-5, 2e-5]) == ["1e-5", "2e-5"] and _plain([2e5, 4e5]) == ["2e5", "4e5"]


def test_decimation_keeps_every_extremum_of_a_pixel_column():
    t = np.linspace(0.0, 10.0, 20_001)
    y = np.sin(t) + (t == t[12_345]) * 5.0  # a one-sample spike
    tt, yy = decimate(t, y, 300)
    assert tt.size <= 4 * 300 + 1 and np.all(np.diff(tt) > 0)
    assert yy.max() == y.max() and yy.min() == y.min() and tt[0] == t[0] and tt[-1] == t[-1]
    short = np.arange(10.0)
    assert decimate(short, short, 300)[0] is not None and decimate(short, short, 300)[0].size == 10


def test_a_variation_below_the_comparison_resolution_is_drawn_flat():
    lo, hi = span_limits([np.full(5, 72.0222) + np.arange(5) * 1e-9], "m/s")
    assert hi - lo >= 1e-3 * 1.0 and lo < 72.0222 < hi  # the speed tolerance at least
    lo, hi = span_limits([np.array([0.0, 10.0])], "deg")
    assert lo < 0.0 and hi > 10.0


def test_the_sheet_is_reused_and_records_every_axis_label_with_its_unit(tmp_path):
    s = sheet()
    assert sheet() is s
    for rows in (2, 1):
        axes = s.panels(rows, 3, "test")
        assert len(axes) == rows * 3 and all(ax.get_visible() for ax in axes)
        for ax in axes:
            ax.plot([0, 1], [0, 1])
            ax.set_ylabel("alpha [deg]")
            ax.set_xlabel("t [s]")
        path = s.save(tmp_path, f"f{rows}.png")
        assert recorded_axes(path) == ["alpha [deg]", "t [s]"]
    assert sum(ax.get_visible() for ax in s.axes) == 3  # the sheet's other axes hidden, kept


def test_the_sheets_text_cache_draws_the_text_matplotlib_draws():
    """The sheets' renderer rasterises each string once (reports.figures._canvas_class, on matplotlib's private
    Agg methods): every text is drawn where and as matplotlib's own renderer draws it, to a pixel of rounding
    (a matplotlib whose internals moved fails here, not in a reader's figure)."""
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from reports.figures import _canvas_class

    def draw(canvas):
        fig = Figure(figsize=(6, 3.5), dpi=100)
        canvas(fig)
        ax = fig.add_axes((0.15, 0.2, 0.8, 0.65))
        t = np.linspace(0, 10, 200)
        ax.plot(t, np.degrees(0.3 * np.sin(t)), label="beta [deg]")
        ax.set_xlabel("t [s]")
        ax.set_ylabel("beta [deg]")  # rotated
        ax.set_title("gtm-forward-slip: sideslip, unicode β μ")
        ax.legend(loc="lower right")
        fig.canvas.draw()
        return np.asarray(fig.canvas.buffer_rgba())[:, :, :3].astype(int)

    stock, cached = draw(FigureCanvasAgg), draw(_canvas_class())
    ink_stock, ink_cached = (img.sum(axis=2) < 3 * 128 for img in (stock, cached))
    # the same text in the same places: ink within a pixel of where matplotlib puts it
    near = np.zeros_like(ink_stock)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            near |= np.roll(np.roll(ink_stock, dy, axis=0), dx, axis=1)
    assert ink_cached.sum() > 0.9 * ink_stock.sum()
    assert np.mean(near[ink_cached]) > 0.99
    assert np.mean(np.any(stock != cached, axis=2)) < 0.05
