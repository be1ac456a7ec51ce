"""The public package ``gflat``: every name of its ``__all__`` is the object its defining module holds, with a
numpydoc docstring, and ``import gflat`` loads none of them (nor numpy) until one is used."""

from __future__ import annotations

import importlib
import inspect
import subprocess
import sys

import pytest

import gflat

from .test_docstrings import check_docstring, public_api

NAMES = [n for n in gflat.__all__ if n != "__version__"]


def test_import_gflat_loads_nothing_until_a_name_is_used():
    code = (
        "import sys, gflat\n"
        "mine = lambda: sorted(m for m in sys.modules if m.split('.')[0] in ('numpy', 'gna', 'planners', 'harness'))\n"
        "print(mine())\n"
        "gflat.InputError\n"
        "print(mine())\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    before, after = out.stdout.splitlines()
    assert before == "[]"
    assert after == "['gna', 'gna.errors']"


@pytest.mark.parametrize("name", NAMES)
def test_each_name_is_its_modules_object_with_a_numpydoc_docstring(name):
    obj = getattr(gflat, name)
    module = importlib.import_module(gflat._PUBLIC[name])
    assert getattr(module, name) is obj
    assert name in dir(gflat)
    if inspect.isfunction(obj):
        assert check_docstring(obj, f"gflat.{name}") == []
    else:
        assert inspect.isclass(obj), name
        assert (inspect.getdoc(obj) or "").strip(), f"gflat.{name}: no docstring"
        methods = [(n, fn, m) for n, fn, m in public_api(module) if n.startswith(f"{module.__name__}.{name}.")]
        problems = [p for n, fn, m in methods for p in check_docstring(fn, n, m)]
        assert not problems, "\n".join(problems)


def test_an_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'plan'"):
        gflat.plan  # noqa: B018


def test_version_is_the_installed_distributions():
    from importlib import metadata

    assert gflat.__version__ == metadata.version("gflat")
