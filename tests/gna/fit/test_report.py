"""Quality tables: text is stable under round-off, and reads the committed fit records."""

from __future__ import annotations

from gna.fit.report import num, statistics_table, trim_table


def test_num_never_prints_negative_zero():
    assert num(-1e-17, 4) == "0.0000" and num(-1e-17, 3, True) == "+0.000"
    assert num(-0.25, 2) == "-0.25" and num(0.25, 1, True) == "+0.2"


def test_tables_cover_every_fitted_aircraft_and_coefficient():
    stats = statistics_table()
    for ident in ("twin-otter", "gtm", "f4", "f16-jsbsim"):
        assert stats.count(f"| {ident} |") == 6
        assert f"| {ident} |" in trim_table()
