"""TOML writing of aircraft documents and their comparison."""

from __future__ import annotations

import math
import tomllib

import pytest

from gna.errors import InputError
from gna.fit.writer import Inline, aircraft_document, differences, table, value


def test_values_round_trip_through_tomllib():
    data = {
        "s": 'a "quoted" \\ string',
        "f": 0.1 + 0.2,
        "i": 3,
        "b": True,
        "inf": math.inf,
        "nan": math.nan,
        "l": [1.0, -2.5e-300],
        "t": Inline({"x": 1.0, "y key": "z"}),
    }
    text = "\n".join(table("", data)) + "\n"
    back = tomllib.loads(text)
    assert back["s"] == data["s"] and back["f"] == data["f"] and back["l"] == data["l"]
    assert back["inf"] == math.inf and math.isnan(back["nan"]) and back["t"] == {"x": 1.0, "y key": "z"}
    with pytest.raises(InputError, match="cannot write"):
        value(object())


def _doc():
    return {
        "id": "x",
        "name": "X",
        "provenance": {"source": "test", "date": "2026-01-01"},
        "mass": {"mass_kg": 100.0, "Ixx_kgm2": 10.0, "Iyy_kgm2": 20.0, "Izz_kgm2": 25.0},
        "geometry": {"S_m2": 2.0, "b_m": 3.0, "cbar_m": 0.7},
        "aero": {"structure": "custom", "terms": [{"theta": 1, "coef": "CL", "monomial": "alpha", "value": 5.0}]},
    }


def test_document_parses_and_loads():
    text = aircraft_document(_doc(), "header line")
    assert text.startswith("# header line\n")
    parsed = tomllib.loads(text)
    assert parsed["aero"]["terms"][0]["value"] == 5.0


def test_document_that_does_not_load_is_refused():
    doc = _doc()
    doc["mass"]["mass_kg"] = -1.0
    with pytest.raises(InputError, match="mass must be positive"):
        aircraft_document(doc, "h")


def test_differences():
    a = {"x": 1.0, "y": [1, 2], "z": {"s": "a", "d": "2020"}}
    b = {"x": 1.0 + 1e-13, "y": [1, 2], "z": {"s": "a", "d": "2021"}}
    assert differences(a, b, ignore=("z.d",)) == []
    assert differences(a, b) == ["z.d: '2020' vs '2021'"]
    assert differences({"x": 1.0}, {"x": 1.001}) == ["x: 1.0 vs 1.001"]
    assert differences({"x": [1]}, {"x": [1, 2]}) == ["x: 1 items vs 2"]
    assert differences({"x": 1}, {}) == ["x: only in first"]
