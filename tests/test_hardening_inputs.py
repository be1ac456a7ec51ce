"""Bad input files and command lines: one clear error each, never a silent wrong result or a write outside.

Each test takes a bundled file with one line changed (or a small command line) and checks the one-line
error naming the file, the table, the key and the value.  Test names carry the kind of the hardening
list they cover: ``test_k1_*`` identifiers used as paths, ``test_k3_*`` unknown or conflicting keys,
``test_k4_*`` wrong types in aircraft files, ``test_k5_*`` file paths, ``test_k13_*`` small CLI defects,
``test_k14_*`` documentation honesty.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import logging
import math
import os
import re
import tempfile
from pathlib import Path

import pytest

from gna.aero import AERO_VARIABLES, MAX_EXPONENT, TermTable, parse_monomial
from gna.aircraft import Aircraft, aircraft_from_dict, list_aircraft, load_aircraft
from gna.errors import InputError, UnknownAircraftError
from gna.schema import SAFE_NAME, check_name, load_schema
from harness.cli import EXIT_CODES, build_parser, main
from planners.scenario import list_scenarios, load_scenario, scenario_from_dict

ROOT = Path(__file__).resolve().parents[1]
AIRCRAFT_DIR = ROOT / "gna" / "data" / "aircraft"
SCENARIO_DIR = ROOT / "planners" / "scenarios"


def _edited(tmp_path: Path, source: Path, old: str, new: str, name: str | None = None) -> Path:
    """``source`` with its first ``old`` replaced by ``new``, written under ``tmp_path``."""
    text = source.read_text(encoding="utf-8")
    assert old in text, f"{old!r} not in {source.name}"
    out = tmp_path / (name or source.name)
    out.write_text(text.replace(old, new, 1), encoding="utf-8")
    return out


def _aircraft(tmp_path, old, new, ident="f16c"):
    return load_aircraft(_edited(tmp_path, AIRCRAFT_DIR / f"{ident}.toml", old, new))


def _scenario(tmp_path, old, new, name="gtm-forward-slip"):
    return load_scenario(_edited(tmp_path, SCENARIO_DIR / f"{name}.toml", old, new))


def _files(root: Path) -> set[Path]:
    return {p for p in root.rglob("*") if p.is_file()}


# ---------------------------------------------------------------------------------------------------
# Kind 1: identifiers used as paths
# ---------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "bad", ["../../esc", "/x", "a/b", "..", "a..b", "", ".hidden", "-x", "x" * 65, "a b", "C:\\x", "x\\y"]
)
def test_k1_aircraft_id_restricted_at_load(tmp_path, bad):
    with pytest.raises(InputError, match=r"f16c\.toml: id = .*(letters, digits|safe identifier)"):
        _aircraft(tmp_path, 'id = "f16c"', f"id = {json.dumps(bad)}")


@pytest.mark.parametrize("bad", ["../../p", "/p", "a/b", "..", "a b"])
def test_k1_scenario_name_restricted_at_load(tmp_path, bad):
    with pytest.raises(InputError, match=r"gtm-forward-slip\.toml: name = .*(letters, digits|safe identifier)"):
        _scenario(tmp_path, 'name = "gtm-forward-slip"', f"name = {json.dumps(bad)}")


def test_k1_scenario_name_from_an_unsafe_file_name(tmp_path):
    text = (SCENARIO_DIR / "gtm-forward-slip.toml").read_text().replace('name = "gtm-forward-slip"\n', "")
    (tmp_path / "my slip.toml").write_text(text)
    with pytest.raises(InputError, match="name \\(from the file name\\) = 'my slip'"):
        load_scenario(tmp_path / "my slip.toml")
    (tmp_path / "my-slip.toml").write_text(text)
    assert load_scenario(tmp_path / "my-slip.toml").name == "my-slip"


def test_k1_safe_names_accepted():
    for ok in ["f16c", "twin-otter", "F4N", "c172x", "a.b_c-1", "x" * 64]:
        assert check_name(ok, "id", "here") == ok
    assert all(SAFE_NAME.match(n) for n in list_aircraft() + list_scenarios())


def test_k1_aircraft_object_refuses_unsafe_id():
    base = load_aircraft("f16c")
    with pytest.raises(InputError, match="id = '../esc'"):
        dataclasses.replace(base, id="../esc")


def test_k1_export_jsbsim_writes_nothing_outside_out(tmp_path, capsys):
    """The issue's ``gflat export-jsbsim FILE --out a/b/c/xo`` with ``id = "../../esc"`` (and ``/x``)."""
    for bad in ("../../esc", "/x"):
        src = _edited(tmp_path, AIRCRAFT_DIR / "f16c.toml", 'id = "f16c"', f'id = "{bad}"', name="evil.toml")
        before = _files(tmp_path)
        out = tmp_path / "a" / "b" / "c" / "xo"
        assert main(["export-jsbsim", str(src), "--out", str(out)]) == 2
        assert "id = " in capsys.readouterr().err
        assert _files(tmp_path) == before
        assert not Path("/x.xml").exists()


def test_k1_jsbsim_paths_stay_under_their_root(tmp_path):
    from harness.engines.jsbsim import files as jf

    assert jf.xml_path(tmp_path, "f16c") == tmp_path / "f16c" / "f16c.xml"
    for bad in ("../../esc", "/x", "a/../../b"):
        with pytest.raises(InputError, match="not a safe identifier"):
            jf.xml_path(tmp_path, bad)


def test_k1_jsbsim_engine_temporary_aircraft_inside_its_folder_and_removed(tmp_path, monkeypatch):
    from harness.engines.jsbsim.export import aircraft_xml
    from harness.engines.jsbsim.fdm import load_fdm

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    a = load_aircraft("f16c")
    with pytest.raises(InputError, match="not a safe identifier"):
        load_fdm(aircraft_xml(a), "../esc")
    fdm, problems, capture = load_fdm(aircraft_xml(a), a.id)
    assert fdm is not None
    assert list(tmp_path.iterdir()) == []  # the temporary root is removed, nothing left beside it


# ---------------------------------------------------------------------------------------------------
# Kind 3: unknown or conflicting keys, repeated terms, non-integer counts, shadowed constants
# ---------------------------------------------------------------------------------------------------


def test_k3_misspelt_scenario_key_suggests(tmp_path):
    with pytest.raises(
        InputError,
        match=r"\[flat_outputs\]: unknown key 'zeta_valu' \(did you mean 'zeta_value'\?\) = "
        r"'0.3'; known keys: x, y, z, zeta",
    ):
        _scenario(tmp_path, 'zeta_value = "0"', 'zeta_valu = "0.3"')


def test_k3_misspelt_aircraft_key_suggests(tmp_path):
    with pytest.raises(
        InputError,
        match=r"f16c\.toml \[mass\]: unknown key 'Ixz_slugft' \(did you mean "
        r"'Ixz_slugft2'\?\) = 982",
    ):
        _aircraft(tmp_path, "Ixz_slugft2", "Ixz_slugft")


@pytest.mark.parametrize(
    "table, key",
    [("", "aircraftt"), ("[time]", "stepp"), ("[generalized]", "j"), ("[report]", "time"), ("[environment]", "densty")],
)
def test_k3_unknown_key_in_every_scenario_table(table, key):
    data = json.loads(json.dumps(load_scenario("gtm-aileron-roll").raw))
    target = data if not table else data.setdefault(table.strip("[]"), {})
    target[key] = 1.0
    with pytest.raises(
        InputError, match=re.escape(f"{table}: unknown key {key!r}" if table else f"unknown key {key!r}")
    ):
        scenario_from_dict(data, where="t.toml")


def test_k3_unknown_tracking_and_top_level_keys():
    data = json.loads(json.dumps(load_scenario("gtm-aileron-roll").raw))
    data["tracking"]["saturated"] = True
    with pytest.raises(InputError, match=r"\[tracking\]: unknown key 'saturated' \(did you mean 'saturate'\?\) = True"):
        scenario_from_dict(data, where="t.toml")


def test_k3_compare_table_keys_checked_values_passed_through():
    """``[compare]``: its keys are the loader's (every command refuses a misspelt one); its values are the
    harness's to check (harness.validation.parse_compare)."""
    data = json.loads(json.dumps(load_scenario("gtm-aileron-roll").raw))
    data["compare"] = {"dt_out": "anything"}
    assert scenario_from_dict(data, where="t.toml").compare == {"dt_out": "anything"}
    data["compare"] = {"anything": 1}
    with pytest.raises(InputError, match=r"t.toml \[compare\]: unknown key 'anything'"):
        scenario_from_dict(data, where="t.toml")


def test_k3_weight_beside_mass_refused(tmp_path):
    with pytest.raises(InputError, match=r"\[mass\]: mass_kg = 9000.0 and weight_lb = .* same quantity twice"):
        _aircraft(tmp_path, "[mass]", "[mass]\nmass_kg = 9000.0")


@pytest.mark.parametrize(
    "old, new",
    [
        ("cbar_ft = ", "cbar_m = 3.0\ncbar_ft = "),
        ("x_cg_cbar = ", "x_cg_m = 0.5\nx_cg_cbar = "),
        ("x_ref_cbar = ", "x_ref_in = 1.0\nx_ref_cbar = "),
        ("epsilon_rad = ", "epsilon_deg = 1.0\nepsilon_rad = "),
    ],
)
def test_k3_one_unit_per_quantity(tmp_path, old, new):
    with pytest.raises(InputError, match="same quantity twice"):
        _aircraft(tmp_path, old, new)


def test_k3_repeated_term_refused(tmp_path):
    """A second CL-alpha term used to be summed into the first."""
    with pytest.raises(InputError, match=r"\[aero.terms\]: term 17 repeats term 99 \(CL, monomial alpha\)"):
        _aircraft(
            tmp_path, "terms = [\n", 'terms = [\n  { theta = 99, coef = "CL", monomial = "alpha", value = 1.0 },\n'
        )
    with pytest.raises(InputError, match="theta = 17 is used by an earlier term"):
        _aircraft(tmp_path, "theta = 30,", "theta = 17,")


@pytest.mark.parametrize("count", ["1.7", "0", "3", "true"])
def test_k3_non_integer_engine_count_refused(tmp_path, count):
    with pytest.raises(InputError, match=rf"\[engines\]: count must be .*got {count.replace('true', 'True')}"):
        _aircraft(tmp_path, "count = 1", f"count = {count}")


@pytest.mark.parametrize("name", ["pi", "e", "g0", "kt", "sin", "sqrt", "t"])
def test_k3_constants_may_not_shadow(tmp_path, name):
    with pytest.raises(InputError, match=rf"\[constants\]: {name} = 3.0 would shadow the"):
        _scenario(tmp_path, "[time]", f"[constants]\n{name} = 3.0\n\n[time]", name="twin-otter-single-engine")


def test_k3_constant_names_are_identifiers(tmp_path):
    with pytest.raises(InputError, match=r"\[constants\]: key '2x' is not allowed; a constant's name is a letter"):
        _scenario(tmp_path, "[time]", '[constants]\n"2x" = 3.0\n\n[time]', name="twin-otter-single-engine")


@pytest.mark.parametrize(
    "old, new, message",
    [
        ("[generalized]", "[h]\nq = 0.1\n\n[generalized]", "calibration"),  # h and calibration
        ('density = "isa"', 'density = "isa"\nrho = 1.0', "rho = 1.0 is used only with density = 'constant'"),
        ('eta = "0"', 'eta = "0"\nf1 = "1"', "f1 = '1' is used only with zeta = 'mix'"),
        ('eta = "0"', 'eta = "0"\ndn = "0"', "eta = '0' and dn = '0' give the same quantity twice"),
        ("J = 6", "J = 1.5", "J must be a whole number or one of 'auto', got 1.5"),
        (
            "[calibration]",
            "[calibration]\nspeed = 3.0",
            "[calibration]: key 'speed' is not allowed; known keys: V, gamma",
        ),
    ],
)
def test_k3_scenario_conflicts_and_types(tmp_path, old, new, message):
    with pytest.raises(InputError, match=re.escape(message)):
        _scenario(tmp_path, old, new)


def test_k3_schema_files_and_docs_are_current():
    spec = importlib.util.spec_from_file_location("make_schemas", ROOT / "scripts" / "make_schemas.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    for path, text in mod.outputs().items():
        assert path.read_text(encoding="utf-8") == text, f"{path.name} is stale: run python scripts/make_schemas.py"


def test_k3_docs_list_every_key():
    doc = (ROOT / "docs" / "scenarios.md").read_text(encoding="utf-8")

    def keys(schema, prefix=""):
        for k, s in schema.get("properties", {}).items():
            yield f"{prefix}{k}"
            for sub in [s] + s.get("oneOf", []):
                if sub.get("type") == "object":
                    yield from keys(sub, f"{prefix}{k}.")
            if isinstance(s.get("items"), dict):
                yield from keys(s["items"], f"{prefix}{k}[].")

    for schema in (
        load_schema("gna", "data", "schemas", "aircraft.schema.json"),
        load_schema("planners", "schemas", "scenario.schema.json"),
    ):
        for k in keys(schema):
            assert f"`{k}`" in doc or f"`[{k}]`" in doc, k


def test_k3_every_bundled_file_loads():
    for n in list_aircraft():
        assert load_aircraft(n).id == n
    for n in list_scenarios():
        assert load_scenario(n).name == n


# ---------------------------------------------------------------------------------------------------
# Kind 4: wrong types in aircraft files
# ---------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "old, new, message",
    [
        ("weight_lb = ", 'weight_lb = "heavy"\n#', r"f16c\.toml \[mass\]: weight_lb must be a number, got 'heavy'"),
        ("count = 1", 'count = "two"', r"f16c\.toml \[engines\]: count must be one of 1, 2, got 'two'"),
        (
            'monomial = "alpha", value = 4.458',
            'monomial = "alpha^100000", value = 4.458',
            rf"\[aero.terms\] #17: monomial 'alpha\^100000': exponent 100000 of alpha exceeds {MAX_EXPONENT}",
        ),
        (
            'monomial = "alpha", value = 4.458',
            "monomial = 5, value = 4.458",
            r"\[aero.terms #17\]: monomial must be a string, got 5",
        ),
        ("value = 4.458", 'value = "big"', r"\[aero.terms #17\]: value must be a number, got 'big'"),
        (
            'coef = "CL", monomial = "alpha",',
            'coef = "CX", monomial = "alpha",',
            r"\[aero.terms #17\]: coef must be one of",
        ),
        ("theta = 17,", 'theta = "17",', r"\[aero.terms #17\]: theta must be a whole number, got '17'"),
        ("b_ft = ", "b_ft = [1.0]\n#", r"\[geometry\]: b_ft must be a number, got \[1.0\]"),
        ("[provenance]", "[provenance]\nextra = 3", r"\[provenance\]: extra must be a string, got 3"),
        ('id = "f16c"', "id = 16", r"f16c\.toml: id must be a string, got 16"),
    ],
)
def test_k4_wrong_types_name_file_table_key_value(tmp_path, old, new, message):
    with pytest.raises(InputError, match=message):
        _aircraft(tmp_path, old, new)


def test_k4_section_not_a_table():
    good = {
        "id": "x",
        "mass": 3,
        "geometry": {"S_m2": 1.0, "b_m": 2.0, "cbar_m": 0.5},
        "aero": {"terms": [{"coef": "CL", "monomial": "alpha", "value": 5.0}]},
    }
    with pytest.raises(InputError, match=r"^a.toml: mass must be a table, got 3$"):
        aircraft_from_dict(good, where="a.toml")


def test_k4_terms_not_a_list(tmp_path):
    text = (AIRCRAFT_DIR / "f16c.toml").read_text()
    start = text.index("terms = [")
    end = text.index("\n]", start) + 2
    (tmp_path / "f16c.toml").write_text(text[:start] + "terms = 5" + text[end:])
    with pytest.raises(InputError, match=r"f16c\.toml \[aero\]: terms must be a list, got 5"):
        load_aircraft(tmp_path / "f16c.toml")


def test_k4_python_api_checks_too():
    with pytest.raises(InputError, match="exponent 100000 of alpha exceeds"):
        parse_monomial("alpha^100000")
    with pytest.raises(InputError, match="exceeds"):
        parse_monomial("*".join(["beta"] * (MAX_EXPONENT + 1)))
    with pytest.raises(InputError, match="malformed"):
        parse_monomial("alpha^1000000000000")
    with pytest.raises(InputError, match="monomial must be a string"):
        parse_monomial(3)
    assert parse_monomial(f"alpha^{MAX_EXPONENT}")[0] == MAX_EXPONENT and len(AERO_VARIABLES) == 8
    with pytest.raises(InputError, match="terms must be a list of tables, got 5"):
        TermTable.from_records(5)
    with pytest.raises(InputError, match=r"^a.toml \[aero.terms #1\]: missing one of 'coef', 'coefficient'$"):
        aircraft_from_dict(
            {
                "id": "x",
                "mass": {"mass_kg": 100.0, "Ixx_kgm2": 10.0, "Iyy_kgm2": 20.0, "Izz_kgm2": 25.0},
                "geometry": {"S_m2": 1.0, "b_m": 2.0, "cbar_m": 0.5},
                "aero": {"terms": [{"monomial": "alpha", "value": 5.0}]},
            },
            where="a.toml",
        )
    with pytest.raises(InputError, match="#1: value = 'x' must be a number"):
        TermTable.from_records([{"coef": "CL", "monomial": "alpha", "value": "x"}])


# ---------------------------------------------------------------------------------------------------
# Kind 5: file paths
# ---------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("loader, what", [(load_scenario, "scenario"), (load_aircraft, "aircraft")])
def test_k5_missing_folder_and_suffix_have_distinct_messages(tmp_path, loader, what):
    with pytest.raises(InputError, match=f"{what} file .*no such file"):
        loader(tmp_path / "nope.toml")
    with pytest.raises(InputError, match=f"{what} file .*no such file"):
        loader("some/where/else")
    with pytest.raises(InputError, match=f"{what} file .*is a folder, not a .toml file"):
        loader(tmp_path)
    (tmp_path / "plain.txt").write_text("x = 1")
    (tmp_path / "mine.toml").write_text("x = 1")
    with pytest.raises(InputError, match=f"{what} file .*no such file .*; did you mean .*mine.toml\\?"):
        loader(tmp_path / "mine")
    with pytest.raises(InputError, match=f"{what} file .*must end in .toml"):
        loader(tmp_path / "plain.txt")


def test_k5_unknown_bare_names_keep_their_catalogue_message():
    with pytest.raises(InputError, match="unknown scenario 'loop-the-loop'; bundled scenarios"):
        load_scenario("loop-the-loop")
    with pytest.raises(UnknownAircraftError, match="known aircraft"):
        load_aircraft("concorde")


def test_k5_non_utf8_and_unreadable(tmp_path, monkeypatch):
    p = tmp_path / "latin.toml"
    p.write_bytes((SCENARIO_DIR / "gtm-forward-slip.toml").read_bytes().replace(b"# The", b"# \xe9 The", 1))
    with pytest.raises(InputError, match=r"latin\.toml: not UTF-8 text \(byte 0xe9"):
        load_scenario(p)
    q = tmp_path / "locked.toml"
    q.write_text("x = 1")

    def denied(self):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(Path, "read_bytes", denied)
    with pytest.raises(InputError, match=r"locked\.toml: cannot read the file \(Permission denied\)"):
        load_aircraft(q)


def test_k5_byte_order_mark_accepted(tmp_path):
    for src, loader in (
        (SCENARIO_DIR / "gtm-forward-slip.toml", load_scenario),
        (AIRCRAFT_DIR / "gtm.toml", load_aircraft),
    ):
        p = tmp_path / src.name
        p.write_bytes(b"\xef\xbb\xbf" + src.read_bytes())
        assert loader(p).path == str(p)


def test_k5_aircraft_path_resolved_from_the_scenario_folder(tmp_path, monkeypatch):
    folder = tmp_path / "mission"
    (folder / "craft").mkdir(parents=True)
    (folder / "craft" / "my-gtm.toml").write_text(
        (AIRCRAFT_DIR / "gtm.toml").read_text().replace('id = "gtm"', 'id = "my-gtm"')
    )
    sc = _edited(folder, SCENARIO_DIR / "gtm-forward-slip.toml", 'aircraft = "gtm"', 'aircraft = "craft/my-gtm.toml"')
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    s = load_scenario(sc)
    assert s.aircraft.id == "my-gtm"
    assert Path(s.aircraft.path) == folder / "craft" / "my-gtm.toml"
    ref = load_scenario("gtm-forward-slip")
    assert s.aircraft.mass == ref.aircraft.mass and s.h == ref.h  # same numbers as the bundled GTM


# ---------------------------------------------------------------------------------------------------
# Kind 13: small CLI defects, load-time checks of envelope and aero terms, huge spans
# ---------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("word, value", [("-1e-3", -1e-3), ("-1E+2", -100.0), ("-.5", -0.5), ("-2", -2.0)])
def test_k13_negative_numbers_with_exponent_are_values(word, value):
    args = build_parser().parse_args(["trim", "f16c", "--speed", "150", "--gamma", word])
    assert args.gamma == value


def test_k13_negative_gamma_runs(capsys):
    assert main(["trim", "f16c", "--speed", "150", "--gamma", "-1e-3"]) == 0
    assert "-0.001 rad" in capsys.readouterr().out


def test_k13_repeated_engines_refused_before_planning(monkeypatch, capsys):
    import harness.commands.compare as compare

    def never(*a, **k):
        raise AssertionError("planned before checking --engines")

    monkeypatch.setattr(compare, "run_case", never)
    assert main(["compare", "gtm-aileron-roll", "--engines", "inhouse,inhouse"]) == 2
    assert "distinct" in capsys.readouterr().err


def test_k13_envelope_and_terms_checked_at_load(tmp_path):
    with pytest.raises(
        InputError,
        match=r"f16c\.toml \(f16c\) \[envelope\]: alpha_min = 50 deg must be "
        r"below alpha_max = 45 deg",
    ):
        _aircraft(tmp_path, "alpha_min_deg = -10.0", "alpha_min_deg = 50.0")
    text = (AIRCRAFT_DIR / "f16c.toml").read_text()
    start = text.index("terms = [")
    (tmp_path / "f16c.toml").write_text(text[:start] + "terms = []" + text[text.index("\n]", start) + 2 :])
    with pytest.raises(InputError, match=r"\[aero\]: terms must be at least 1 items, got \[\]"):
        load_aircraft(tmp_path / "f16c.toml")
    with pytest.raises(InputError, match="no terms"):
        dataclasses.replace(load_aircraft("f16c"), aero=TermTable(()))


@pytest.mark.parametrize("t0, t1", [(-1e308, 1e308), (0.0, 1e308), (-1e10, 0.0)])
def test_k13_huge_span_refused(t0, t1):
    from tests.planners.conftest import make_scenario

    with pytest.raises(InputError, match=r"\[time\]: t[01] = .* is beyond"):
        make_scenario(time={"t0": t0, "t1": t1, "step": 1.0})


def test_k13_version_and_exit_codes(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and re.match(r"gflat \S+", capsys.readouterr().out)
    text = build_parser().format_help()
    for code in EXIT_CODES:
        assert re.search(rf"^\s+{code}\s", text, re.M), code
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "**0** success" in readme and "**1**" in readme and "**2** usage or input error" in readme
    assert main(["plan", "no-such-scenario"]) == 2
    with pytest.raises(SystemExit) as exc:
        main(["trim", "f16c"])  # missing --speed: argparse's usage error
    assert exc.value.code == 2


def test_k13_verbose_and_quiet_set_logging_for_the_run_only(capsys):
    root = logging.getLogger()
    before = root.level, list(root.handlers)
    main(["-v", "aircraft", "f16c"])
    assert "aircraft: done in" in capsys.readouterr().err  # -v: INFO shown
    main(["aircraft", "f16c", "-q"])
    assert capsys.readouterr().err == ""  # -q: errors only
    main(["aircraft", "f16c"])
    assert "done in" not in capsys.readouterr().err  # default: gflat's own progress, not the run's summary
    # run in-process, gflat leaves logging as it found it (no handler bound to a stream that may close)
    assert (root.level, list(root.handlers)) == before


# ---------------------------------------------------------------------------------------------------
# Kind 14: documentation honesty
# ---------------------------------------------------------------------------------------------------


def test_k14_planning_doc_calls_the_paper_thrust_unexplained():
    doc = (ROOT / "docs" / "planning.md").read_text(encoding="utf-8")
    para = doc[doc.index("The paper's J = 0 thrust (−2.36 N)") :]
    para = para[: para.index("\n\n")]
    assert "unexplained" in para and "carries a factor α" in para
    assert "comes\nfrom its H = 0 simple model" not in doc
    # the claim: at zero g (alpha ~ 0) the H terms of our GTM drag vanish with alpha
    gtm = load_aircraft("gtm")
    for t in gtm.aero.terms_of("CD"):
        if not t.is_flat:
            assert t.exponents[AERO_VARIABLES.index("alpha")] >= 1, t.monomial
    assert math.isclose(sum(t.value for t in gtm.aero.terms_of("CD") if t.monomial == "1"), 0.0252, rel_tol=0.05)


def test_schema_module_is_ground_floor():
    """gna.schema imports nothing from planners or harness (checked by running a clean interpreter)."""
    import subprocess
    import sys

    code = (
        "import sys, gna.schema, gna.aircraft; print(any(m.split('.')[0] in ('planners', 'harness') "
        "for m in sys.modules))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert out.stdout.strip() == "False", out.stderr


def test_valid_files_load_to_the_same_numbers():
    """A hand-built file equal to the test fixture gives the fixture's numbers (no conversion changed)."""
    good = {
        "id": "x",
        "mass": {"weight_lb": 1000.0, "Ixx_slugft2": 10.0, "Iyy_slugft2": 20.0, "Izz_slugft2": 25.0},
        "geometry": {"S_ft2": 100.0, "b_ft": 20.0, "cbar_ft": 5.0, "x_cg_cbar": 0.3},
        "engines": {"count": 2, "y_p_ft": 3.0, "epsilon_deg": 2.0},
        "aero": {"terms": [{"coef": "CL", "monomial": "alpha", "value": 5.0}]},
    }
    a = aircraft_from_dict(good)
    assert isinstance(a, Aircraft)
    assert a.mass.mass == 1000.0 * 0.45359237 and a.geometry.S == 100.0 * 0.3048**2
    assert a.geometry.x_cg == a.geometry.x_ref == 0.3 * (5.0 * 0.3048)
    assert a.propulsion.count == 2 and a.propulsion.epsilon == math.radians(2.0)


@pytest.mark.parametrize(
    "module_name",
    ["gna.schema", "gna.aircraft", "gna.aero", "planners.scenario", "harness.cli", "harness.engines.jsbsim.files"],
)
def test_loader_docstrings(module_name):
    """The numpydoc rules of tests/test_docstrings.py, on the loaders and the CLI entry point."""
    import importlib

    td = pytest.importorskip("tests.test_docstrings")
    problems = []
    for name, fn, method in td.public_api(importlib.import_module(module_name)):
        problems += td.check_docstring(fn, name, skip_first=method)
    assert not problems, "\n".join(problems)


# --- fourth round (docs/hardening.md) ------------------------------------------------------------------------


@pytest.mark.parametrize(
    "text, words",
    [
        ("-500 + 0*" + "(" * 1990 + "t" + ")" * 1990, "too many nested parentheses"),
        ("-500 + 0*9**9**9", "cannot be evaluated (a number too large for a float)"),
        ("-500 + " + "q" * 3000, "unknown name"),
    ],
)
def test_an_expression_message_quotes_a_long_expression_shortened(text, words):
    from planners.expressions import SHOWN_CHARS, compile_expression

    with pytest.raises(InputError) as exc:
        compile_expression(text, {}, "s.toml [flat_outputs] z")
    msg = str(exc.value)
    assert words in msg and "\n" not in msg
    assert len(msg) < SHOWN_CHARS + 300, msg
