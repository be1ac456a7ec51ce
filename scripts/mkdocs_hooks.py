"""MkDocs hooks of the documentation site (``mkdocs.yml``): the pages generated at every build.

Nothing generated here is committed; each page is made from what the package ships, so it cannot drift:

* ``scenarios.md`` (scenario and aircraft files) and ``reference/campaign-file.md`` from the JSON Schemas
  ``planners/schemas/scenario.schema.json``, ``gna/data/schemas/aircraft.schema.json`` and
  ``harness/campaign/schemas/campaign.schema.json`` (rendered by :mod:`schema_doc`; the committed
  ``docs/scenarios.md`` is the same text, kept for readers of the repository);
* ``reference/bundled-scenarios.md``, ``reference/bundled-aircraft.md``, ``reference/bundled-campaigns.md``
  from the package data (``planners/scenarios/*.toml``, ``planners/systems/scenarios/*.toml``,
  ``gna/data/aircraft/*.toml`` with the vendored sources' ``gna/data/sources/*/PROVENANCE.md``,
  ``harness/campaign/campaigns/*.toml``);
* ``api/index.md``: the public API of ``import gflat`` (from ``gflat._PUBLIC``), and ``api/<package>/...``
  one mkdocstrings page per public module of gna, planners, harness and reports (no part of its dotted name starting with ``_``),
  appended to the navigation as "API reference".
"""

from __future__ import annotations

import ast
import json
import pkgutil
import re
import sys
import tomllib
from pathlib import Path

from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "scripts")]  # this checkout's packages (not an installed gflat), schema_doc

import schema_doc  # noqa: E402

#: Packages of the API reference, in the order of the navigation (the layers, bottom up).
API_PACKAGES = ("gna", "planners", "harness", "reports")

SCHEMAS = {
    "scenario": ROOT / "planners" / "schemas" / "scenario.schema.json",
    "aircraft": ROOT / "gna" / "data" / "schemas" / "aircraft.schema.json",
    "campaign": ROOT / "harness" / "campaign" / "schemas" / "campaign.schema.json",
}


def _esc(text: str) -> str:
    """Free text of a data file, safe in Markdown (and in a table cell)."""
    text = str(text).replace("\\", "\\\\")
    for ch in "[]*_|<>`":
        text = text.replace(ch, "\\" + ch)
    return " ".join(text.split())


def _header_comment(path: Path, skip: str = "") -> str:
    """The comment lines at the head of a TOML file (its provenance, as its author wrote it), but ``skip``."""
    out = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.startswith("#"):
            break
        if line.lstrip("#").strip() != skip:
            out.append(line.lstrip("#").strip())
    return " ".join(x for x in out if x)


def _toml_block(path: Path) -> list[str]:
    rel = path.relative_to(ROOT).as_posix()
    text = path.read_text(encoding="utf-8").rstrip("\n")
    return (
        [f'??? example "The file: `{rel}`"', "", "    ```toml"]
        + [f"    {x}" for x in text.splitlines()]
        + [
            "    ```",
            "",
        ]
    )


# ---------------------------------------------------------------------------------------------------
# Bundled scenarios, aircraft and campaigns
# ---------------------------------------------------------------------------------------------------


def _scenario_section(path: Path, aircraft_ids: set[str], level: int = 3) -> list[str]:
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    name = data.get("name", path.stem)
    lines = [f"{'#' * level} `{name}`", ""]
    if data.get("description"):
        lines += [_esc(data["description"]), ""]
    head = _header_comment(path)
    if head:
        lines += [f"**Source.** {_esc(head)}", ""]
    facts = []
    if "aircraft" in data:
        ac = data["aircraft"]
        link = f"[`{ac}`](bundled-aircraft.md#{ac})" if ac in aircraft_ids else f"`{ac}`"
        facts.append(f"aircraft {link}")
    if "system" in data:
        facts.append(f"system `{data['system']}`")
    t = data.get("time", {})
    if t:
        facts.append(f"t = {t.get('t0')} .. {t.get('t1')} s, nodes every {t.get('step')} s")
    gen = data.get("generalized", {})
    facts.append(f"J = {gen.get('J', 0)}" + (f", method {gen['method']}" if "method" in gen else ""))
    lines += ["* " + "; ".join(facts), ""]
    fo = data.get("flat_outputs", {})
    if fo:
        lines += ["| flat output | expression |", "|---|---|"]
        lines += [f"| `{k}` | `{str(v).strip()}` |".replace("|`", "| `") for k, v in fo.items()] + [""]
    known = data.get("verdicts", {}).get("known", [])
    if known:
        lines += ["Recorded violations (`[verdicts] known`, still computed and shown):", ""]
        lines += [f"* `{k['name']}`: {_esc(k['reason'])}" for k in known] + [""]
    return lines + _toml_block(path)


def bundled_scenarios_page(aircraft_ids: set[str]) -> str:
    """The page of the bundled scenarios (``planners/scenarios``, ``planners/systems/scenarios``)."""
    aircraft = sorted((ROOT / "planners" / "scenarios").glob("*.toml"))
    systems = sorted((ROOT / "planners" / "systems" / "scenarios").glob("*.toml"))
    lines = [
        "# Bundled scenarios",
        "",
        "<!-- Generated at build time from planners/scenarios/*.toml and planners/systems/scenarios/*.toml "
        "(scripts/mkdocs_hooks.py). -->",
        "",
        "Every command that takes a scenario takes one of these names (`gflat plan NAME`, `gflat compare NAME`, "
        '`gflat.load_scenario("NAME")`) or the path of your own file ([the file format](../scenarios.md), '
        "[tutorial](../tutorials/own-scenario.md)). Each section below is generated from the file the package "
        "ships, with the file itself at its end.",
        "",
        "| scenario | aircraft or system | span [s] | J |",
        "|---|---|---|---|",
    ]
    for p in aircraft + systems:
        d = tomllib.loads(p.read_text(encoding="utf-8"))
        t = d.get("time", {})
        lines.append(
            f"| [`{d.get('name', p.stem)}`](#{d.get('name', p.stem)}) | `{d.get('aircraft', d.get('system', ''))}` | "
            f"{t.get('t0')} .. {t.get('t1')} | {d.get('generalized', {}).get('J', 0)} |"
        )
    lines += ["", "## Aircraft manoeuvres", ""]
    for p in aircraft:
        lines += _scenario_section(p, aircraft_ids)
    lines += [
        "## Chained-system demonstrations",
        "",
        "Scenarios of the paper's non-aircraft examples (`planners/systems`), planned by the same generalized "
        "flatness; `gflat plan NAME` plans them.",
        "",
    ]
    for p in systems:
        lines += _scenario_section(p, aircraft_ids)
    return "\n".join(lines).rstrip() + "\n"


def _si(ident: str) -> dict:
    """Mass, inertia and geometry of a bundled aircraft in SI, as the model loads them."""
    from gna.aircraft import load_aircraft

    ac = load_aircraft(ident)
    g = ac.geometry
    return {
        "mass": ac.mass.mass,
        "S": g.S,
        "b": g.b,
        "cbar": g.cbar,
        "engines": ac.propulsion.count,
        "terms": len(ac.aero.terms),
    }


def _demote(markdown: str, by: int) -> str:
    return re.sub(r"^(#+) ", lambda m: "#" * (len(m.group(1)) + by) + " ", markdown, flags=re.M)


def bundled_aircraft_page() -> str:
    """The page of the bundled aircraft (``gna/data/aircraft``) and of the vendored source data."""
    files = sorted((ROOT / "gna" / "data" / "aircraft").glob("*.toml"))
    sources = sorted((ROOT / "gna" / "data" / "sources").glob("*/PROVENANCE.md"))
    lines = [
        "# Bundled aircraft",
        "",
        "<!-- Generated at build time from gna/data/aircraft/*.toml and gna/data/sources/*/PROVENANCE.md "
        "(scripts/mkdocs_hooks.py). -->",
        "",
        "The aircraft gflat ships, each with where its numbers come from: the `[provenance]` table of its file, "
        "and for the fitted sets the vendored source data they were fitted from. `gflat aircraft` prints the "
        "same list; [the file format](../scenarios.md#aircraft-files); a new one from any JSBSim aircraft: "
        "[tutorial](../tutorials/fit-jsbsim.md). Masses and lengths below are SI, as the model loads them.",
        "",
        "| id | mass [kg] | S [m²] | b [m] | c̄ [m] | engines | aerodynamic terms | made by |",
        "|---|---|---|---|---|---|---|---|",
    ]
    sections = []
    for p in files:
        d = tomllib.loads(p.read_text(encoding="utf-8"))
        ident = d["id"]
        si = _si(ident)
        made = "gflat fit" if "fit" in d else "published set"
        lines.append(
            f"| [`{ident}`](#{ident}) | {si['mass']:.6g} | {si['S']:.4g} | {si['b']:.4g} | {si['cbar']:.4g} | "
            f"{si['engines']} | {si['terms']} | {made} |"
        )
        sec = [f"## `{ident}`", "", f"**{_esc(d.get('name', ident))}**", ""]
        head = _header_comment(p, skip=d.get("name", ""))
        if head:
            sec += [f"*{_esc(head)}*", ""]
        prov = d.get("provenance", {})
        if prov:
            sec += ["| provenance | |", "|---|---|"] + [f"| {k} | {_esc(v)} |" for k, v in prov.items()] + [""]
        for table in ("mass", "geometry", "engines", "envelope"):
            src = d.get(table, {}).get("source")
            if src:
                sec += [f"* `[{table}]` source: {_esc(src)}"]
        vendored = [s for s in sources if f"gna/data/sources/{s.parent.name}" in json.dumps(prov)]
        if vendored:
            sec += [""] + [
                f"* vendored source data: [`gna/data/sources/{s.parent.name}`](#source-{s.parent.name})"
                for s in vendored
            ]
        sections += sec + [""] + _toml_block(p)
    lines += [""] + sections
    lines += ["## Vendored source data", "", "The source models the fitted sets come from, shipped in the package.", ""]
    for s in sources:
        text = s.read_text(encoding="utf-8")
        title, _, body = text.partition("\n")
        lines += [
            f"### `gna/data/sources/{s.parent.name}` {{#source-{s.parent.name}}}",
            "",
            f"*{_esc(title.lstrip('# '))}* (`{s.relative_to(ROOT).as_posix()}`)",
            "",
            _demote(body.strip(), 3),
            "",
        ]
    return "\n".join(lines).rstrip() + "\n"


def bundled_campaigns_page() -> str:
    """The page of the bundled campaigns (``harness/campaign/campaigns``)."""
    lines = [
        "# Bundled campaigns",
        "",
        "<!-- Generated at build time from harness/campaign/campaigns/*.toml (scripts/mkdocs_hooks.py). -->",
        "",
        "`gflat campaign run NAME --out DIR` runs one of these, or your own file ([the file format]"
        "(campaign-file.md), [tutorial](../tutorials/campaign-dask.md), [campaigns](../campaigns.md)).",
        "",
    ]
    for p in sorted((ROOT / "harness" / "campaign" / "campaigns").glob("*.toml")):
        d = tomllib.loads(p.read_text(encoding="utf-8"))
        lines += [f"## `{d.get('name', p.stem)}`", "", _esc(d.get("description", "")), ""]
        head = _header_comment(p)
        if head:
            lines += [f"**Why these spreads.** {_esc(head)}", ""]
        cases = ", ".join(f"`{c.get('id', c['scenario'])}` ({c.get('loop', 'open')})" for c in d.get("cases", []))
        lines += [
            f"* seed {d.get('seed')}, {d.get('samples', 1)} samples per case and dispersion set; cases {cases}; "
            f"dispersion sets {', '.join(f'`{n}`' for n in d.get('dispersions', {}))}",
            "",
        ]
        lines += _toml_block(p)
    return "\n".join(lines).rstrip() + "\n"


# ---------------------------------------------------------------------------------------------------
# API reference
# ---------------------------------------------------------------------------------------------------


def public_modules(package: str) -> list[str]:
    """Dotted names of ``package`` and of every module under it without a part starting with ``_``, from disk."""
    names = []

    def walk(name: str, path: Path) -> None:
        names.append(name)
        for info in pkgutil.iter_modules([str(path)]):
            if info.name.startswith("_"):
                continue
            if info.ispkg:
                walk(f"{name}.{info.name}", path / info.name)
            else:
                names.append(f"{name}.{info.name}")

    walk(package, ROOT / package)
    return names


def _gflat_groups() -> list[tuple[str, list[str]]]:
    """The public names of ``import gflat`` grouped as its docstring groups them."""
    tree = ast.parse((ROOT / "gflat" / "__init__.py").read_text(encoding="utf-8"))
    doc = ast.get_docstring(tree) or ""
    public = next(
        ast.literal_eval(n.value)
        for n in tree.body
        if isinstance(n, ast.Assign) and any(getattr(t, "id", None) == "_PUBLIC" for t in n.targets)
    )
    groups: list[tuple[str, list[str]]] = []
    for line in doc.splitlines():
        if line and not line[0].isspace() and groups is not None and ":" not in line and line.strip():
            groups.append((line.strip(), []))
        elif line.startswith(" ") and groups:
            for name in re.findall(r":(?:func|class):`([^`]+)`", line):
                if name in public and name not in groups[-1][1]:
                    groups[-1][1].append(name)
    groups = [(g, names) for g, names in groups if names]
    seen = {n for _, names in groups for n in names}
    rest = [n for n in public if n not in seen]
    if rest:
        groups.append(("Other", rest))
    return [(g, [f"{public[n]}.{n}" for n in names]) for g, names in groups]


def _summary(path: str) -> str:
    """First line of the docstring of the object at dotted ``path`` (imported)."""
    import importlib
    import inspect

    module, _, name = path.rpartition(".")
    obj = getattr(importlib.import_module(module), name)
    doc = inspect.getdoc(obj) or ""
    line = doc.strip().split("\n\n")[0].replace("\n", " ")
    return re.sub(r":(?:func|class|meth|mod|data|attr|exc):`~?([^`]+)`", r"`\1`", line).replace("|", "\\|")


def gflat_page() -> str:
    """The page of ``import gflat``: every public name, linked to its reference, with its summary."""
    lines = [
        "# `gflat`: the public API",
        "",
        "<!-- Generated at build time from gflat/__init__.py (scripts/mkdocs_hooks.py). -->",
        "",
        "`import gflat` gives these names, each imported from the module that defines it on first use (so "
        "`import gflat` is cheap). Each links to its full reference in the module that defines it; the "
        "modules below this page document the rest (layers, bottom up: "
        "[gna](gna/index.md) the model, [planners](planners/index.md) the paper's algorithms, "
        "[harness](harness/index.md) engines, validation, campaigns and the command line, "
        "[reports](reports/index.md) rendering).",
        "",
        "```python",
        "import gflat",
        "",
        'plan = gflat.plan_scenario(gflat.load_scenario("gtm-aileron-roll"))',
        "```",
        "",
    ]
    for group, paths in _gflat_groups():
        lines += [f"## {group}", "", "| name | defined in | what |", "|---|---|---|"]
        for p in paths:
            module, _, name = p.rpartition(".")
            lines.append(f"| [`gflat.{name}`][{p}] | [`{module}`][{module}] | {_summary(p)} |")
        lines.append("")
    return "\n".join(lines).rstrip() + "\n"


def is_package(module: str) -> bool:
    """Whether the dotted ``module`` is a package of this checkout (a folder)."""
    return (ROOT / module.replace(".", "/")).is_dir()


def api_uri(module: str) -> str:
    """The page of ``module``: ``api/gna/index.md`` for a package, ``api/gna/aero.md`` for a module."""
    parts = module.split(".")
    return "/".join(["api", *parts, "index.md"]) if is_package(module) else "/".join(["api", *parts]) + ".md"


def api_page(module: str) -> str:
    """The mkdocstrings page of one module."""
    return f"::: {module}\n    options:\n      heading_level: 1\n      show_root_heading: true\n"


def api_nav() -> list:
    """The "API reference" section of the navigation: gflat, then a section per package and subpackage."""

    def section(package: str, mods: list[str]) -> list:
        items: list = [api_uri(package)]
        depth = package.count(".") + 1
        children = sorted({".".join(m.split(".")[: depth + 1]) for m in mods if m.count(".") >= depth})
        for child in children:
            label = child.rpartition(".")[2]
            if is_package(child):
                items.append({label: section(child, [m for m in mods if m == child or m.startswith(child + ".")])})
            else:
                items.append({label: api_uri(child)})
        return items

    nav: list = ["api/index.md"]
    for package in API_PACKAGES:
        nav.append({package: section(package, public_modules(package))})
    return nav


# ---------------------------------------------------------------------------------------------------
# The hooks
# ---------------------------------------------------------------------------------------------------


def on_config(config, **kwargs):
    """Append the API reference to the navigation."""
    config["nav"].append({"API reference": api_nav()})
    return config


def generated_pages() -> dict[str, str]:
    """``{page path in the site: Markdown}`` of every generated page."""
    schemas = {k: json.loads(p.read_text(encoding="utf-8")) for k, p in SCHEMAS.items()}
    aircraft_ids = {p.stem for p in (ROOT / "gna" / "data" / "aircraft").glob("*.toml")}
    pages = {
        "scenarios.md": schema_doc.scenarios_page(schemas["aircraft"], schemas["scenario"]),
        "reference/campaign-file.md": schema_doc.campaign_page(schemas["campaign"]),
        "reference/bundled-scenarios.md": bundled_scenarios_page(aircraft_ids),
        "reference/bundled-aircraft.md": bundled_aircraft_page(),
        "reference/bundled-campaigns.md": bundled_campaigns_page(),
        "api/index.md": gflat_page(),
    }
    for package in API_PACKAGES:
        for m in public_modules(package):
            pages[api_uri(m)] = api_page(m)
    return pages


def on_files(files: Files, config, **kwargs) -> Files:
    """Add the generated pages (``scenarios.md`` replaced by its render from the schema files)."""
    for uri, text in generated_pages().items():
        old = files.get_file_from_path(uri)
        if old is not None:
            files.remove(old)
        files.append(File.generated(config, uri, content=text))
    return files
