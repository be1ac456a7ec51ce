"""Architecture rules of the project, enforced.

* The model package (``gna``) is the ground floor: importing it loads nothing from ``planners`` or
  ``harness`` (data flows down only: commands -> reports -> validation -> engines/metrics ->
  planners -> gna).
* Imports point one way: every module belongs to a unit of :data:`LAYERS` and imports only its own
  layer or lower ones (static imports, read with :mod:`ast`, including those inside functions and the
  module paths a module-level lazy table names); the graph of the units has no cycle.
* No module imports a private name (``_x``) from another of our packages, nor reaches one as an
  attribute of another package's module; inside a package private names are fine.

``python tests/test_architecture.py --graph`` prints the graph of the units (layer, unit, the units it
imports; a violation marked ``!!``).
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("gna", "planners", "harness", "reports", "gflat")


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


# --- the import graph -------------------------------------------------------------------------

#: Unit (a package, a sub-package or a module) -> layer.  A module belongs to the longest unit its dotted
#: name starts with; it may import its own layer or a lower one.
LAYERS: dict[str, int] = {
    "gna": 0,
    "harness": 0,  # the package's own __init__ only: it imports nothing (the public face is gflat)
    "planners": 1,
    "harness.engines": 2,
    "harness.metrics": 2,
    "harness.validation": 3,
    "harness.artefacts": 3,
    "harness.recorded": 3,  # a run's recorded files, confined and checked: read by reports and campaigns
    "harness.testing": 3,
    "harness.parallel": 3,  # worker processes and their bounds: imports only gna, used by campaigns and commands
    "harness.progress": 3,  # a command's progress lines (rich): imports nothing of ours; reports, pools, commands
    "reports": 4,
    "harness.campaign": 4,
    "harness.commands": 5,
    "harness.cli": 5,
    "harness.rundir": 5,
    "harness.pytest_plugin": 5,
    "gflat": 5,
}

#: Units that hold their own module only, not the modules below their dotted name.
_EXACT = {"harness"}


def module_names(root: Path = ROOT, packages=PACKAGES) -> dict[str, Path]:
    """Dotted name -> file of every module of our packages (``reports/out`` excluded)."""
    names = {}
    for path in _sources(packages):
        parts = path.relative_to(root).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        names[".".join(parts)] = path
    return names


def unit_of(module: str, layers=LAYERS) -> str | None:
    """The unit of :data:`LAYERS` a dotted module name belongs to (None: none does)."""
    best = None
    for unit in layers:
        if module == unit or (unit not in _EXACT and module.startswith(unit + ".")):
            if best is None or len(unit) > len(best):
                best = unit
    return best


def static_imports(source: str, module: str, is_package: bool, known) -> list[tuple[int, str]]:
    """The modules of ours that ``source`` (the module ``module``) imports, with their line numbers.

    Parameters
    ----------
    source : str
        Python source code.
    module : str
        Its dotted name (relative imports are resolved against it).
    is_package : bool
        Whether the module is a package's ``__init__``.
    known : collection of str
        Dotted names of our modules: ``from a.b import c`` imports ``a.b.c`` when that is a module,
        else ``a.b``.

    Returns
    -------
    list of (int, str)
        Every ``import``/``from ... import`` anywhere in the module (inside functions too), and every
        module path a module-level assignment names as a string (a lazy table: ``"harness.commands.plan"``
        or ``".engines"``), resolved to our dotted module names.
    """
    tree = ast.parse(source)
    package = module if is_package else module.rpartition(".")[0]
    ours = tuple(p + "." for p in PACKAGES)

    def absolute(name: str, level: int) -> str:
        if level == 0:
            return name
        base = package.split(".")
        base = base[: len(base) - (level - 1)] if level > 1 else base
        return ".".join([*base, name] if name else base)

    def mine(name: str) -> bool:
        return name in PACKAGES or name.startswith(ours)

    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names if mine(a.name)]
        elif isinstance(node, ast.ImportFrom):
            base = absolute(node.module or "", node.level)
            if not mine(base):
                continue
            for a in node.names:
                sub = f"{base}.{a.name}"
                found.append((node.lineno, sub if sub in known else base))
    for node in tree.body:  # lazy tables: module paths named by module-level assignments
        if isinstance(node, (ast.Assign, ast.AnnAssign)) and node.value is not None:
            for c in ast.walk(node.value):
                if isinstance(c, ast.Constant) and isinstance(c.value, str):
                    text = c.value
                    level = len(text) - len(text.lstrip("."))
                    name = absolute(text[level:], level) if level else text
                    if name in known and (level or mine(name)):
                        found.append((c.lineno, name))
    return sorted(set(found))


def import_edges(root: Path = ROOT) -> list[tuple[str, int, str]]:
    """``(module, line, imported module)`` for every import between two of our modules.

    Returns
    -------
    list of (str, int, str)
    """
    names = module_names(root)
    edges = []
    for name, path in sorted(names.items()):
        for line, target in static_imports(path.read_text(encoding="utf-8"), name, path.name == "__init__.py", names):
            if target != name:
                edges.append((name, line, target))
    return edges


def unit_graph(edges, layers=LAYERS) -> dict[str, dict[str, list[str]]]:
    """Unit -> imported unit -> the ``module:line -> module`` imports behind that arrow.

    Parameters
    ----------
    edges : iterable of (str, int, str)
        From :func:`import_edges`.
    layers : dict
        Unit -> layer.

    Returns
    -------
    dict
    """
    graph: dict[str, dict[str, list[str]]] = {u: {} for u in layers}
    for src, line, dst in edges:
        a, b = unit_of(src, layers), unit_of(dst, layers)
        if a is not None and b is not None and a != b:
            graph[a].setdefault(b, []).append(f"{src}:{line} -> {dst}")
    return graph


def layer_violations(graph, layers=LAYERS) -> list[str]:
    """The arrows of ``graph`` that point up (to a higher layer), each with the imports behind it."""
    bad = []
    for a, targets in graph.items():
        for b, why in sorted(targets.items()):
            if layers[b] > layers[a]:
                bad.append(f"{a} (layer {layers[a]}) -> {b} (layer {layers[b]}): " + "; ".join(why))
    return bad


def cycles(graph) -> list[list[str]]:
    """The strongly connected components of more than one unit of ``graph`` (Tarjan), each sorted.

    Parameters
    ----------
    graph : dict
        Unit -> iterable of the units it imports.

    Returns
    -------
    list of list of str
        Empty when the graph is acyclic.
    """
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(found)


def format_graph(graph, layers=LAYERS) -> str:
    """The unit graph as text, highest layer first: ``layer unit -> imported units`` (``!!``: points up).

    Parameters
    ----------
    graph : dict
        From :func:`unit_graph`.
    layers : dict
        Unit -> layer.

    Returns
    -------
    str
    """
    lines = []
    width = max(len(u) for u in graph)
    for unit in sorted(graph, key=lambda u: (-layers[u], u)):
        if not graph[unit] and not any(unit in t for t in graph.values()):
            continue  # a unit with no module yet (harness.rundir before it is written)
        targets = sorted(graph[unit], key=lambda b: (-layers[b], b))
        arrows = ", ".join(("!!" if layers[b] > layers[unit] else "") + b for b in targets) or "-"
        lines.append(f"{layers[unit]}  {unit:<{width}}  -> {arrows}")
    return "\n".join(lines)


def test_every_module_has_a_layer():
    missing = sorted(m for m in module_names() if unit_of(m) is None)
    assert not missing, "modules with no layer in LAYERS (add their unit): " + ", ".join(missing)


def test_imports_point_down():
    bad = layer_violations(unit_graph(import_edges()))
    assert not bad, f"{len(bad)} arrow(s) point up a layer:\n  " + "\n  ".join(bad)


def test_units_form_no_cycle():
    graph = unit_graph(import_edges())
    found = cycles(graph)
    assert not found, "import cycles between units:\n" + "\n".join(
        " <-> ".join(c) + ": " + "; ".join(w for a in c for b in c for w in graph[a].get(b, [])) for c in found
    )


def test_import_reader_sees_relative_function_level_and_lazy_imports():
    known = {"harness", "harness.engines", "harness.engines.registry", "harness.validation", "gna", "gna.errors"}
    source = (
        "from gna.errors import InputError\n"
        "from . import registry\n"
        "from ..validation import run_case\n"
        "import numpy\n"
        "def f():\n"
        "    import harness.validation\n"
        "_LAZY = {'x': '.registry', 'y': 'gna.errors', 'z': 'not a module'}\n"
        "def g():\n"
        "    return 'harness.validation'\n"  # a string inside a function is not a lazy table
    )
    got = static_imports(source, "harness.engines", True, known)
    assert got == [
        (1, "gna.errors"),
        (2, "harness.engines.registry"),
        (3, "harness.validation"),
        (6, "harness.validation"),
        (7, "gna.errors"),
        (7, "harness.engines.registry"),
    ]
    assert static_imports("from .registry import get_engine\n", "harness.engines.fly", False, known) == [
        (1, "harness.engines.registry")
    ]


def test_layer_and_cycle_checks_catch_an_upward_arrow_and_a_cycle():
    layers = {"low": 0, "mid": 1, "top": 2}
    edges = [("top.a", 1, "mid.b"), ("mid.b", 2, "low"), ("low.c", 3, "top.a")]
    graph = unit_graph(edges, layers)
    assert layer_violations(graph, layers) == ["low (layer 0) -> top (layer 2): low.c:3 -> top.a"]
    assert cycles(graph) == [["low", "mid", "top"]]
    assert cycles(unit_graph(edges[:2], layers)) == []
    assert "!!top" in format_graph(graph, layers)


if __name__ == "__main__":
    if sys.argv[1:] != ["--graph"]:
        sys.exit("usage: python tests/test_architecture.py --graph")
    print(format_graph(unit_graph(import_edges())))
