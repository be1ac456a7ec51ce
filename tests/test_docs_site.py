"""The documentation site (``mkdocs.yml``): it builds with warnings as errors, its generated pages cover every
key and bundled file, and every command of its tutorials runs as written.

Tutorial pages (:data:`EXECUTED`) are run block by block, in order, in an empty folder of their own:

* a fenced block with a ``title="NAME"`` (``toml``, ``python``, ...) is a file: written to ``NAME``;
* a ``bash`` block runs in ``bash -euo pipefail`` (``gflat``, ``python`` and ``pytest`` are this
  checkout's, through ``PYTHONPATH``);
* a ``python`` block without a title runs with this interpreter;
* ``text`` and ``console`` blocks are output and commands shown, not run; a tutorial has no ``console``
  command (``$ ...``): what it tells you to type, the test types.

A block that exits non-zero fails the test with its command and the end of its output.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"

#: Pages whose blocks are executed: the getting-started page and every tutorial.
EXECUTED = [DOCS / "getting-started.md"] + sorted(p for p in (DOCS / "tutorials").glob("*.md") if p.stem != "index")

FENCE = re.compile(
    r"^(?P<indent> *)```(?P<lang>[\w+-]*)(?P<attrs>[^\n]*)\n(?P<body>.*?)^(?P=indent)```[ \t]*$", re.S | re.M
)

#: Safety bound of one block [s] (a hung block fails instead of holding CI); the blocks end on their own.
BLOCK_BOUND_S = 900


def blocks(page: Path) -> list[tuple[str, str | None, str]]:
    """``(language, file name or None, text)`` of every fenced block of ``page``, in order."""
    out = []
    for m in FENCE.finditer(page.read_text(encoding="utf-8")):
        indent = len(m["indent"])
        body = "".join(line[indent:] for line in m["body"].splitlines(keepends=True))
        title = re.search(r'title="([^"]+)"', m["attrs"])
        out.append((m["lang"], title.group(1) if title else None, body))
    return out


def _environment(bin_dir: Path) -> dict[str, str]:
    """This checkout's gflat, python and pytest first on PATH; no coverage or pytest options of the outer run."""
    bin_dir.mkdir()
    for name, cmd in (("gflat", "-m gflat"), ("python", ""), ("pytest", "-m pytest")):
        shim = bin_dir / name
        shim.write_text(f'#!/bin/sh\nexec "{sys.executable}" {cmd} "$@"\n', encoding="utf-8")
        shim.chmod(0o755)
    env = {
        k: v
        for k, v in os.environ.items()
        if not k.startswith(("COV_CORE_", "PYTEST_", "COVERAGE_")) and k not in ("PYTHONPATH", "MPLBACKEND")
    }
    env.update(PATH=f"{bin_dir}{os.pathsep}{env.get('PATH', '')}", PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    return env


@pytest.mark.parametrize("page", EXECUTED, ids=[p.stem for p in EXECUTED])
def test_every_tutorial_block_runs(page, tmp_path):
    work = tmp_path / "work"
    work.mkdir()
    env = _environment(tmp_path / "bin")
    ran = 0
    for i, (lang, title, text) in enumerate(blocks(page), start=1):
        where = f"{page.relative_to(ROOT)} block {i} ({lang}{' ' + title if title else ''})"
        if title:
            (work / title).parent.mkdir(parents=True, exist_ok=True)
            (work / title).write_text(text, encoding="utf-8")
            continue
        if lang == "bash":
            cmd = ["bash", "-euo", "pipefail", "-c", text]
        elif lang == "python":
            cmd = [sys.executable, "-c", text]
        else:
            assert lang in ("text", "console", "toml"), f"{where}: a {lang!r} block is neither run nor a file"
            if page.parent.name == "tutorials":
                assert not re.search(r"^\$ ", text, re.M), f"{where}: a command shown but not run; make it bash"
            continue
        res = subprocess.run(cmd, cwd=work, env=env, capture_output=True, text=True, timeout=BLOCK_BOUND_S)
        assert res.returncode == 0, (
            f"{where} exited {res.returncode}:\n{text}\n--- stdout (end)\n{res.stdout[-4000:]}\n"
            f"--- stderr (end)\n{res.stderr[-4000:]}"
        )
        ran += 1
    assert ran, f"{page.relative_to(ROOT)}: no block runs"


def _hooks():
    spec = importlib.util.spec_from_file_location("mkdocs_hooks", ROOT / "scripts" / "mkdocs_hooks.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_site_builds_with_warnings_as_errors(tmp_path):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("COV_CORE_", "PYTEST_", "COVERAGE_"))}
    env.update(NO_MKDOCS_2_WARNING="1", PYTHONPATH=str(ROOT))
    site = tmp_path / "site"
    res = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(ROOT / "mkdocs.yml"), "-d", str(site)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=BLOCK_BOUND_S,
    )
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-8000:]
    assert "WARNING" not in res.stderr, res.stderr[-8000:]
    for page in ("index.html", "getting-started.html", "tutorials/fit-jsbsim.html", "reference/campaign-file.html"):
        assert (site / page).is_file(), page
    trim = (site / "api" / "gna" / "trim.html").read_text(encoding="utf-8")
    assert "trim_level" in trim and "Parameters" in trim  # a docstring rendered, numpydoc sections read
    api = (site / "api" / "index.html").read_text(encoding="utf-8")
    assert 'href="gna/aircraft.html#gna.aircraft.load_aircraft"' in api  # the public names link to their pages


def test_generated_pages_cover_every_key_and_bundled_file():
    hooks = _hooks()
    pages = hooks.generated_pages()
    campaign = json.loads(hooks.SCHEMAS["campaign"].read_text(encoding="utf-8"))
    text = pages["reference/campaign-file.md"]
    for key, s in campaign["properties"].items():
        assert any(f"`{form}`" in text for form in (key, f"[{key}]", f"[[{key}]]", f"[{key}.NAME]")), key
        sub = s.get("items") or s.get("additionalProperties") or s
        for k in sub.get("properties", {}) if isinstance(sub, dict) else ():
            assert re.search(rf"`{key}(\.NAME)?\.{k}`", text), f"{key}.{k}"
    assert pages["scenarios.md"] == (DOCS / "scenarios.md").read_text(encoding="utf-8")  # the committed copy
    scen = pages["reference/bundled-scenarios.md"]
    for p in [
        *(ROOT / "planners" / "scenarios").glob("*.toml"),
        *(ROOT / "planners" / "systems" / "scenarios").glob("*.toml"),
    ]:
        assert f"### `{tomllib.loads(p.read_text(encoding='utf-8'))['name']}`" in scen, p.name
    aircraft = pages["reference/bundled-aircraft.md"]
    for p in (ROOT / "gna" / "data" / "aircraft").glob("*.toml"):
        assert f"## `{p.stem}`" in aircraft and "| provenance |" in aircraft, p.name
    for p in (ROOT / "gna" / "data" / "sources").glob("*/PROVENANCE.md"):
        assert f"{{#source-{p.parent.name}}}" in aircraft, p
    for p in (ROOT / "harness" / "campaign" / "campaigns").glob("*.toml"):
        assert f"## `{p.stem}`" in pages["reference/bundled-campaigns.md"], p.name
    for package in hooks.API_PACKAGES:
        for module in hooks.public_modules(package):
            assert pages[hooks.api_uri(module)].startswith(f"::: {module}\n"), module


def test_campaign_schema_accepts_the_bundled_and_tutorial_campaigns():
    import jsonschema

    schema = json.loads(_hooks().SCHEMAS["campaign"].read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator.check_schema(schema)
    validator = jsonschema.Draft202012Validator(schema)
    files = [
        tomllib.loads(p.read_text(encoding="utf-8"))
        for p in (ROOT / "harness" / "campaign" / "campaigns").glob("*.toml")
    ]
    files += [
        tomllib.loads(text)
        for page in EXECUTED
        for lang, title, text in blocks(page)
        if lang == "toml" and title and "[[cases]]" in text
    ]
    assert len(files) >= 2
    for data in files:
        assert not list(validator.iter_errors(data)), data.get("name")
    assert list(validator.iter_errors({"seed": 1, "cases": [{"scenario": "x", "looop": "open"}]}))


def test_docs_dependencies_are_in_the_test_extra():
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["optional-dependencies"]
    assert set(extras["docs"]) <= set(extras["test"])  # CI installs .[test] and builds the site
