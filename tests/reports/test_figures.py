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
