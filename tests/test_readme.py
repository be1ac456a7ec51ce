"""Every Python snippet of the README runs on its own: each name it uses is imported or defined in it."""

from __future__ import annotations

import ast
import builtins
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _snippets():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    return re.findall(r"```python\n(.*?)```", text, re.S)


def _undefined(code: str) -> set[str]:
    tree = ast.parse(code)
    bound = set(dir(builtins))
    for node in ast.walk(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            bound |= {(a.asname or a.name).split(".")[0] for a in node.names}
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            bound.add(node.name)
        elif isinstance(node, ast.arg):
            bound.add(node.arg)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, (ast.Store, ast.Del)):
            bound.add(node.id)
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load)} - bound


def test_each_readme_snippet_stands_alone():
    snippets = _snippets()
    assert len(snippets) >= 2
    for i, code in enumerate(snippets, start=1):
        assert not _undefined(code), f"README snippet {i} uses {sorted(_undefined(code))} without importing them"


def test_readme_is_short():
    """The README is a newcomer's page; rules, history and figures live in docs/."""
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 120, f"README.md has {len(lines)} lines, more than 120: move the detail to docs/"


def test_readme_scenario_file_loads(tmp_path):
    """The README's scenario file is a real one: planners.scenario loads it from a file."""
    from planners.scenario import load_scenario

    text = (ROOT / "README.md").read_text(encoding="utf-8")
    (toml,) = re.findall(r"```toml\n(.*?)```", text, re.S)
    assert len(toml.strip().splitlines()) <= 10
    path = tmp_path / "turn.toml"
    path.write_text(toml, encoding="utf-8")
    sc = load_scenario(path)
    assert sc.name == "twin-otter-level-turn"
    assert sc.aircraft.id == "twin-otter"
    assert (sc.t0, sc.t1) == (0.0, 30.0)
