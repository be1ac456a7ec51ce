"""The committed fitted aircraft files are current, and they meet the issue's trim targets."""

from __future__ import annotations

import tomllib
from importlib import resources
from pathlib import Path

import pytest

from gna.aircraft import list_aircraft, load_aircraft
from gna.errors import GflatError
from gna.fit.regenerate import SPECS, regenerate
from gna.fit.report import TARGET_ALPHA_DEG, TARGET_DM_DEG, update_docs

DOCS = Path(__file__).resolve().parents[3] / "docs" / "fit_quality.md"


def test_committed_fitted_files_are_current(tmp_path):
    """Regenerate every fitted file into a temporary folder (about 4 s: GTM tables, two JSBSim
    aircraft, 10 000 points each, trims) and compare with the committed files."""
    report = regenerate(tmp_path, today="2000-01-01")
    assert report == {ident: [] for ident in SPECS}, report
    for ident in SPECS:
        new = tomllib.loads((tmp_path / f"{ident}.toml").read_text())
        old = tomllib.loads((Path(str(resources.files("gna") / "data" / "aircraft")) / f"{ident}.toml").read_text())
        assert new["provenance"]["date"] == old["provenance"]["date"]


def test_fitted_aircraft_are_listed_with_provenance():
    ids = list_aircraft()
    for ident in ("twin-otter", "gtm", "f4", "f16c", "a7", "f16-jsbsim"):
        assert ident in ids
    for ident in SPECS:
        a = load_aircraft(ident)
        for key in ("source", "transformation", "date", "sampling", "reference_condition", "statistics"):
            assert a.provenance.get(key), (ident, key)
        assert a.aero.structure == "gna45" and len(a.aero) == 45


@pytest.mark.parametrize("ident", list(SPECS))
def test_trim_targets_are_met(ident):
    with open(load_aircraft(ident).path, "rb") as fh:
        diff = tomllib.load(fh)["fit"]["trim"]["difference"]
    assert abs(diff["alpha_deg"]) <= TARGET_ALPHA_DEG
    assert abs(diff["dm_deg"]) <= TARGET_DM_DEG


def test_generated_documentation_block_is_current():
    if not DOCS.is_file():
        pytest.skip("documentation not in this installation")
    assert update_docs(DOCS, check=True), "run: gflat fit regenerate --docs docs/fit_quality.md"


def test_unknown_id_is_refused(tmp_path):
    with pytest.raises(GflatError, match="unknown fitted aircraft nope"):
        regenerate(tmp_path, ["nope"])


def test_a_stale_file_is_detected(tmp_path):
    committed = tmp_path / "committed"
    committed.mkdir()
    lines = Path(load_aircraft("twin-otter").path).read_text().splitlines()
    i = next(k for k, line in enumerate(lines) if 'coef = "CD", monomial = "alpha",' in line)
    lines[i] = lines[i].replace("value = ", "value = 1", 1)  # 0.137 -> 10.137
    (committed / "twin-otter.toml").write_text("\n".join(lines) + "\n")
    report = regenerate(tmp_path / "out", ["twin-otter"], check=True, committed_dir=committed)
    assert report["twin-otter"] and report["twin-otter"][0].startswith("aero.terms[1].value")
    assert not (tmp_path / "out").exists()
