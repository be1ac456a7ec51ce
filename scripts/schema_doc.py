"""Markdown pages from the JSON Schemas of gflat's input files (a table of keys per TOML table).

Used by ``scripts/make_schemas.py`` (the committed ``docs/scenarios.md``) and by the documentation site's
build hook (``scripts/mkdocs_hooks.py``), which renders the schema files shipped in the package at every
build, so the site's file references cannot drift from the schemas the loaders check against.

Each schema property is one row: key (dotted path), type, unit (``x-unit``), default (``x-default``) and
meaning (``description``).  A table (``type: object`` with ``properties``) gets its own section
``[key]``; a table of named tables (``additionalProperties`` with ``properties``) a section
``[key.NAME]``; an array of tables a section ``[[key]]``.  ``x-notes`` of a schema are paragraphs
printed after its sections.
"""

from __future__ import annotations

import json

HEADER = ["| key | type | unit | default | meaning |", "|---|---|---|---|---|"]


def _type(s: dict) -> str:
    t = s.get("x-type", s.get("type"))
    if "enum" in s:
        return " / ".join(json.dumps(v) for v in s["enum"])
    if "oneOf" in s:
        return " or ".join(x.get("type", "?") if x.get("type") != "object" else "table" for x in s["oneOf"])
    if isinstance(t, list):
        return " or ".join(t)
    if t == "object":
        return "table"
    return t or "any"


def _resolve(s: dict, root: dict | None) -> dict:
    """A property's schema with its ``$ref`` (to ``#/$defs/...``) merged in."""
    if root is None or "$ref" not in s:
        return s
    target = root["$defs"][s["$ref"].rsplit("/", 1)[-1]]
    return {**target, **{k: v for k, v in s.items() if k != "$ref"}}


def rows(schema: dict, prefix: str, root: dict | None = None) -> list[str]:
    """Table rows of every property of ``schema`` (and of its sub-tables), keys prefixed by ``prefix``;
    ``$ref`` resolved against ``root``."""
    out = []
    for key, s in schema.get("properties", {}).items():
        s = _resolve(s, root)
        path = f"{prefix}.{key}" if prefix else key
        meaning = s.get("description", "").replace("|", chr(92) + "|")
        out.append(f"| `{path}` | {_type(s)} | {s.get('x-unit', '')} | {s.get('x-default', '')} | {meaning} |")
        subs = [s] + [x for x in s.get("oneOf", []) if isinstance(x, dict)]
        for sub in subs:
            if sub.get("type") == "object" and "properties" in sub:
                out.extend(rows(sub, path, root))
        if s.get("type") == "array" and isinstance(s.get("items"), dict) and "properties" in s["items"]:
            out.extend(rows(s["items"], f"{path}[]", root))
    return out


def _named_tables(s: dict) -> dict | None:
    extra = s.get("additionalProperties")
    return extra if isinstance(extra, dict) and "properties" in extra else None


def _array_of_tables(s: dict) -> dict | None:
    items = s.get("items")
    return items if s.get("type") == "array" and isinstance(items, dict) and "properties" in items else None


def section(title: str, schema: dict, path: str) -> list[str]:
    """Markdown lines of one file kind: its description, top-level keys, then a section per table.

    Parameters
    ----------
    title : str
        Heading (level 2).
    schema : dict
        The file's JSON Schema.
    path : str
        Where the schema lives in the repository (printed).

    Returns
    -------
    list of str
    """
    lines = [f"## {title}", "", schema["description"], "", f"JSON Schema: `{path}`.", ""]
    top = {}
    for key, s in schema["properties"].items():
        named, array = _named_tables(s), _array_of_tables(s)
        default = [f"Without it: `{s['x-default']}`.", ""] if "x-default" in s else []
        if s.get("type") == "object" and named is not None:
            lines += [f"### `[{key}]`: `[{key}.NAME]`", "", s.get("description", ""), ""] + default + HEADER
            lines += rows(named, f"{key}.NAME", schema) + [""]
        elif array is not None:
            lines += [f"### `[[{key}]]`", "", s.get("description", ""), ""] + default + HEADER
            lines += rows(array, key, schema) + [""]
        elif s.get("type") == "object" and "properties" in s:
            lines += [f"### `[{key}]`", "", s.get("description", ""), ""] + HEADER
            lines += rows(s, key, schema) + [""]
        elif s.get("type") == "object":
            lines += [f"### `[{key}]`", "", s.get("description", ""), ""]
            if "propertyNames" in s and "enum" in s["propertyNames"]:
                lines += ["Keys: " + ", ".join(f"`{k}`" for k in s["propertyNames"]["enum"]) + ".", ""]
        else:
            top[key] = s
    lines[6:6] = ["### Top-level keys", ""] + HEADER + rows({"properties": top}, "", schema) + [""]
    if "spline" in schema.get("$defs", {}):
        sp = schema["$defs"]["spline"]
        lines += [
            "### Spline flat outputs",
            "",
            sp["description"] + ": a flat output or prescribed input given as a table instead of an expression, "
            'e.g. `x = { basis = "bezier", coefficients = ["cx1", 4000.0] }`.',
            "",
        ]
        lines += HEADER + rows(sp, "flat_outputs.<output>", schema) + [""]
    for note in schema.get("x-notes", []):
        lines += [note, ""]
    return lines


NAMES = (
    "Identifiers that name output files (`id`, `name`) are 1 to 64 letters, digits, `.`, `_` or `-`, starting "
    "with a letter or a digit, without `..`."
)


def scenarios_page(aircraft: dict, scenario: dict) -> str:
    """The text of ``docs/scenarios.md``: scenario and aircraft files.

    Parameters
    ----------
    aircraft, scenario : dict
        The JSON Schemas of aircraft and scenario files.

    Returns
    -------
    str
    """
    lines = [
        "# Scenario and aircraft files",
        "",
        "<!-- Generated by scripts/make_schemas.py from the JSON Schemas; do not edit by hand. -->",
        "",
        "Both files are TOML. Every table is checked against its JSON Schema when loaded: an unknown key "
        "(with the closest known key suggested), a key of the wrong type, two keys giving the same quantity "
        "(`weight_lb` beside `mass_kg`) or a value out of range is refused with one line naming the file, "
        "table, key and value. " + NAMES,
        "",
        "Files are read as UTF-8 (a leading byte-order mark is accepted). An `aircraft` path inside a "
        "scenario is resolved from the scenario's folder. Defaults in the tables are those the loaders "
        "apply when a key is absent; SI units inside, angles in radians.",
        "",
    ]
    lines += section("Scenario files", scenario, "planners/schemas/scenario.schema.json")
    lines += section("Aircraft files", aircraft, "gna/data/schemas/aircraft.schema.json")
    return "\n".join(lines).rstrip() + "\n"


def campaign_page(campaign: dict) -> str:
    """The text of the site's campaign-file reference.

    Parameters
    ----------
    campaign : dict
        The JSON Schema of campaign files.

    Returns
    -------
    str
    """
    lines = [
        "# Campaign files",
        "",
        "<!-- Generated at build time from harness/campaign/schemas/campaign.schema.json "
        "(scripts/make_schemas.py); do not edit by hand. -->",
        "",
        "A campaign file is TOML: the product of its `[[cases]]` and its `[dispersions.NAME]` sets, times "
        "`samples` ([Campaigns](../campaigns.md) says how it runs and what it reports). The loader "
        "(`harness/campaign/spec.py`) checks every key: an unknown key is refused with the closest known key "
        "suggested, and every expanded case is checked before anything runs. " + NAMES,
        "",
    ]
    lines += section("Campaign files", campaign, "harness/campaign/schemas/campaign.schema.json")
    return "\n".join(lines).rstrip() + "\n"


#: The markers of the generated block of docs/cli.md (the keys of every command's --json).
CLI_BEGIN = "<!-- begin: generated by scripts/make_schemas.py from harness/commands/schemas/*.json -->"
CLI_END = "<!-- end: generated -->"


def cli_outputs(schemas: dict[str, dict]) -> list[str]:
    """Markdown lines of the ``--json`` outputs: a table of keys per command, from the output schemas.

    Parameters
    ----------
    schemas : dict
        Schema name -> the JSON Schema of a command's output (``harness/commands/schemas/<name>.json``).

    Returns
    -------
    list of str
    """
    lines = []
    for name, s in schemas.items():
        required = set(s.get("required", ()))
        lines += [
            f"### `{s['title']}`",
            "",
            s["description"],
            "",
            f"JSON Schema: `harness/commands/schemas/{name}.json`.",
            "",
        ]
        lines += ["| key | type | unit | meaning |", "|---|---|---|---|"]
        for key, p in s["properties"].items():
            meaning = p.get("description", "").replace("|", chr(92) + "|")
            always = " (always)" if key in required else ""
            kind = _type(p).replace("table", "object")
            lines.append(f"| `{key}`{always} | {kind} | {p.get('x-unit', '')} | {meaning} |")
        lines.append("")
    return lines


def cli_page(text: str, schemas: dict[str, dict]) -> str:
    """``docs/cli.md`` with its generated block (between :data:`CLI_BEGIN` and :data:`CLI_END`) made current.

    Parameters
    ----------
    text : str
        The page as it is.
    schemas : dict
        As :func:`cli_outputs`.

    Returns
    -------
    str
    """
    head, _, rest = text.partition(CLI_BEGIN)
    _, _, tail = rest.partition(CLI_END)
    return head + CLI_BEGIN + "\n\n" + "\n".join(cli_outputs(schemas)) + "\n" + CLI_END + tail
