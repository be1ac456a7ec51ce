"""Hardening, third round, kind 7: a damaged golden trajectory is one clear failure naming the file and
saying to run ``pytest --gflat-regen``, never a pandas or decoding error."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from gna.eom import CONTROL_NAMES, STATE_NAMES
from harness.pytest_plugin import GoldenError, read_golden

USER_TEST = """
def test_twin_otter(gflat_flight):
    gflat_flight("twin-otter-single-engine", engines=["inhouse"], duration=1.0)
"""


def _good(path):
    t = np.linspace(0.0, 1.0, 51)
    df = pd.DataFrame(
        {c: np.cos(t + i) for i, c in enumerate(STATE_NAMES + CONTROL_NAMES)}, index=pd.Index(t, name="t")
    )
    df.to_csv(path, float_format="%.17g")
    return df


DAMAGE = {
    "empty": lambda p: p.write_bytes(b""),
    "binary": lambda p: p.write_bytes(bytes(range(256)) * 8),
    "not UTF-8": lambda p: p.write_bytes(b"t,x\n0,1\n" + b"\xff\xfe\x00garbage\n"),
    "header only": lambda p: p.write_text(p.read_text().splitlines()[0] + "\n"),
    "truncated mid-line": lambda p: p.write_text(p.read_text()[: len(p.read_text()) // 2]),
    "a word for a number": lambda p: p.write_text(p.read_text().replace("\n0.02", "\nabc", 1)),
    "times out of order": lambda p: p.write_text(
        "\n".join([p.read_text().splitlines()[0]] + p.read_text().splitlines()[1:][::-1]) + "\n"
    ),
}


@pytest.mark.parametrize("kind", list(DAMAGE))
def test_k7_a_damaged_golden_csv_is_one_line_naming_the_file_and_regen(tmp_path, kind):
    path = tmp_path / "test_x.csv"
    _good(path)
    DAMAGE[kind](path)
    with pytest.raises(GoldenError) as exc:
        read_golden(path, STATE_NAMES)
    text = str(exc.value)
    assert "\n" not in text and str(path) in text and "pytest --gflat-regen" in text


def test_k7_a_corrupt_parquet_sibling_and_a_missing_column(tmp_path):
    pq = tmp_path / "test_x.parquet"
    pq.write_bytes(b"PAR1" + b"\x00" * 100 + b"PAR1")
    with pytest.raises(GoldenError, match=r"test_x.parquet is unusable: it cannot be read .*--gflat-regen"):
        read_golden(tmp_path / "test_x.csv", STATE_NAMES)
    pq.unlink()
    _good(tmp_path / "test_x.csv").drop(columns=["mu"]).to_csv(tmp_path / "test_x.csv")
    with pytest.raises(GoldenError, match=r"no column 'mu'"):
        read_golden(tmp_path / "test_x.csv", STATE_NAMES)


def test_k7_a_good_golden_reads_back_exactly(tmp_path):
    df = _good(tmp_path / "g.csv")
    back = read_golden(tmp_path / "g.csv", STATE_NAMES)
    assert np.array_equal(back.to_numpy(), df.to_numpy()) and np.array_equal(back.index, df.index)


def test_k7_the_fixture_fails_clearly_on_truncated_and_empty_goldens(pytester, monkeypatch):
    monkeypatch.setenv("PYTEST_DISABLE_PLUGIN_AUTOLOAD", "1")
    pytester.makepyfile(test_user=USER_TEST)
    golden = pytester.path / "gflat_golden" / "test_user" / "test_twin_otter.csv"
    pytester.runpytest("-p", "harness.pytest_plugin", "-q", "--gflat-regen").assert_outcomes(passed=1)
    lines = golden.read_text().splitlines()
    golden.write_text("\n".join(lines[: len(lines) // 2]) + "\n")  # whole rows lost: the span is short
    short = pytester.runpytest("-p", "harness.pytest_plugin", "-q")
    short.assert_outcomes(failed=1)
    short.stdout.fnmatch_lines(
        ["*golden trajectory*test_twin_otter.csv is unusable: it covers t = 0 .. *--gflat-regen*"]
    )
    golden.write_bytes(b"")
    empty = pytester.runpytest("-p", "harness.pytest_plugin", "-q")
    empty.assert_outcomes(failed=1)
    empty.stdout.fnmatch_lines(["*test_twin_otter.csv is unusable: the file is empty*--gflat-regen*"])
    out = empty.stdout.str()
    assert "Traceback" not in out and "pandas" not in out


# --- fourth round (docs/hardening.md) ------------------------------------------------------------------------


def test_a_column_of_no_trajectory_is_refused_not_ignored(tmp_path):
    path = tmp_path / "test_x.csv"
    _good(path).assign(extra=1.0).to_csv(path, float_format="%.17g")
    with pytest.raises(GoldenError, match=r"column 'extra' is no trajectory column .*--gflat-regen") as exc:
        read_golden(path, STATE_NAMES)
    assert "\n" not in str(exc.value)


def test_the_fixture_fails_on_a_damaged_golden_with_one_message(pytester, monkeypatch):
    monkeypatch.setenv("PYTEST_DISABLE_PLUGIN_AUTOLOAD", "1")
    pytester.makepyfile(test_user=USER_TEST)
    golden = pytester.path / "gflat_golden" / "test_user" / "test_twin_otter.csv"
    pytester.runpytest_subprocess("-p", "harness.pytest_plugin", "-q", "--gflat-regen").assert_outcomes(passed=1)
    text = golden.read_text()
    golden.write_text(text.replace(",x,", ",X,", 1))
    res = pytester.runpytest_subprocess("-p", "harness.pytest_plugin", "-q")
    res.assert_outcomes(failed=1)
    out = res.stdout.str()
    assert "is unusable: column 'X' is no trajectory column" in out
    assert "During handling of the above exception" not in out and "Traceback" not in out
