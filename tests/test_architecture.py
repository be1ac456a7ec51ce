"""Architecture rules of the project, enforced.

* The model package (``gna``) is the ground floor: importing it loads nothing from ``planners`` or
  ``harness`` (data flows down only: commands -> reports -> validation -> engines/metrics ->
  planners -> gna).
* No module imports a private name (``_x``) from another of our packages, nor reaches one as an
  attribute of another package's module; inside a package private names are fine.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("gna", "planners", "harness", "reports")


def _sources(packages=PACKAGES):
    for pkg in packages:
        base = ROOT / pkg
        if base.is_dir():
            yield from sorted(p for p in base.rglob("*.py") if "out" not in p.relative_to(base).parts[:1])


def _is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def private_imports(source: str, own_package: str) -> list[tuple[int, str]]:
    """Uses of another package's private names in ``source`` (a module of ``own_package``).

    Parameters
    ----------
    source : str
        Python source code.
    own_package : str
        Top-level package the module belongs to (its private names are allowed).

    Returns
    -------
    list of (int, str)
        Line number and a description of each violation.
    """
    tree = ast.parse(source)
    found = []
    aliases: dict[str, str] = {}  # local name -> dotted module path of another of our packages

    def foreign(dotted: str) -> bool:
        top = dotted.split(".")[0]
        return top in PACKAGES and top != own_package

    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module and foreign(node.module):
            parts = node.module.split(".")
            if any(_is_private(p) for p in parts[1:]):
                found.append((node.lineno, f"from {node.module} import ... (private module)"))
            for a in node.names:
                if _is_private(a.name):
                    found.append((node.lineno, f"from {node.module} import {a.name}"))
                else:
                    aliases[a.asname or a.name] = f"{node.module}.{a.name}"
        elif isinstance(node, ast.Import):
            for a in node.names:
                if foreign(a.name):
                    if any(_is_private(p) for p in a.name.split(".")[1:]):
                        found.append((node.lineno, f"import {a.name} (private module)"))
                    if a.asname:
                        aliases[a.asname] = a.name
                    else:
                        top = a.name.split(".")[0]
                        aliases[top] = top

    def dotted_of(expr) -> str | None:
        if isinstance(expr, ast.Name):
            return aliases.get(expr.id)
        if isinstance(expr, ast.Attribute):
            base = dotted_of(expr.value)
            return None if base is None else f"{base}.{expr.attr}"
        return None

    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and _is_private(node.attr):
            base = dotted_of(node.value)
            if base is not None:
                found.append((node.lineno, f"{base}.{node.attr}"))
    return sorted(set(found))


def test_model_package_imports_nothing_above_it():
    code = (
        "import sys, gna, gna.solve, gna.eom, gna.trim, gna.simulate; "
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('planners', 'harness', 'reports')))"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_fit_pipeline_imports_nothing_above_the_model():
    mods = [
        p.relative_to(ROOT).with_suffix("").as_posix().replace("/", ".")
        for p in sorted((ROOT / "gna" / "fit").rglob("*.py"))
    ]
    mods = [m.removesuffix(".__init__") for m in mods]
    code = (
        f"import importlib, sys\nfor m in {mods!r}: importlib.import_module(m)\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('planners', 'harness', 'reports')))"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_no_private_name_crosses_a_package_boundary():
    bad = []
    for path in _sources():
        pkg = path.relative_to(ROOT).parts[0]
        for line, what in private_imports(path.read_text(encoding="utf-8"), pkg):
            bad.append(f"{path.relative_to(ROOT)}:{line}: {what}")
    assert not bad, "private names used across packages:\n" + "\n".join(bad)


@pytest.mark.parametrize(
    "source,expected",
    [
        ("from gna.eom import _coefficients\n", ["from gna.eom import _coefficients"]),
        ("import gna.eom\nx = gna.eom._coefficients\n", ["gna.eom._coefficients"]),
        ("import gna.eom as E\nx = E._coefficients\n", ["gna.eom._coefficients"]),
        ("from gna import eom\nx = eom._coefficients(1)\n", ["gna.eom._coefficients"]),
        ("from gna.eom import aero_coefficients, __doc__\nx = gna_thing._private\n", []),
        ("from planners.series import _mul_kernel\n", []),  # inside its own package: fine
        ("from .series import _mul_kernel\n", []),
    ],
)
def test_private_import_checker(source, expected):
    assert [w for _, w in private_imports(source, "planners")] == expected
