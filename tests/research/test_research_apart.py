"""research/ stays apart from the product: not imported, not packaged, every file described in its README."""

from __future__ import annotations

import ast
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PRODUCT = ("gna", "planners", "harness", "reports")


def _imported_top_names(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def test_the_product_imports_neither_research_nor_benchmarks():
    offenders = [
        str(p.relative_to(ROOT))
        for pkg in PRODUCT
        for p in (ROOT / pkg).rglob("*.py")
        if _imported_top_names(p) & {"research", "benchmarks", "scripts"}
    ]
    assert offenders == []


def test_research_is_not_packaged():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    include = project["tool"]["setuptools"]["packages"]["find"]["include"]
    assert not [p for p in include if p.split("*")[0] in ("research", "benchmarks", "scripts")]
    assert not (ROOT / "research" / "__init__.py").exists()


def test_every_research_file_is_in_the_readme():
    readme = (ROOT / "research" / "README.md").read_text(encoding="utf-8")
    files = sorted(p.name for p in (ROOT / "research").iterdir() if p.is_file() and p.name != "README.md")
    assert files, "research/ holds no file"
    missing = [name for name in files if f"`{name}`" not in readme]
    assert missing == []


def test_scripts_keeps_only_the_product_tools():
    # the data import, the schema pages, and the documentation site's build extensions (mkdocs.yml)
    assert sorted(p.name for p in (ROOT / "scripts").glob("*.py")) == [
        "griffe_rest_roles.py",
        "import_gna_published.py",
        "make_schemas.py",
        "mkdocs_hooks.py",
        "schema_doc.py",
    ]
