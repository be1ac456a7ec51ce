"""Numpydoc docstrings of the public API, checked (after python-control's ``docstrings_test.py``).

For every public function of the modules in :data:`MODULES`, and every public method of their
public classes (properties, dunder methods and the methods a dataclass or NamedTuple generates are
skipped), the docstring must have

* a summary line;
* a ``Parameters`` (or ``Other Parameters``) entry for every parameter of the signature except
  ``self``/``cls`` (``a, b : type`` groups allowed; ``*args``/``**kwargs`` documented as such), and no
  entry for a parameter the signature does not have;
* a ``Returns`` (or ``Yields``) section when the function returns a value: a return annotation other
  than None, or a ``return <value>`` in its own body;
* a ``Raises`` section when its own body raises on purpose (a ``raise`` that is not a bare re-raise).
"""

from __future__ import annotations

import ast
import importlib
import inspect
import textwrap
import warnings

import pytest

docscrape = pytest.importorskip("numpydoc.docscrape")

#: Modules whose public functions and classes are checked.
MODULES = [
    "gna.eom",
    "gna.solve",
    "gna.controller",
    "gna.trim",
    "planners.flat",
    "planners.plan",
    "planners.generalized",
    "planners.generalized_newton",
    "planners.flatness_test",
    "planners.chained",
    "planners.systems.first_order_lag",
    "planners.systems.car_trailers",
    "planners.systems.demos",
    "planners.systems.aircraft",
    "planners.systems.scenario",
    "planners.newton",
    "planners.singularity",
    "planners.tracking",
    "gna.simulate",
    "gna.tape",
    "gna.trajectory",
    "harness.engines.base",
    "harness.engines.registry",
    "harness.engines.inhouse",
    "harness.engines.fly",
    "harness.engines.jsbsim.engine",
    "harness.engines.jsbsim.fdm",
    "harness.engines.jsbsim.states",
    "harness.engines.jsbsim.source",
    "harness.engines.jsbsim.script",
    "harness.testing",
    "harness.pytest_plugin",
    "harness.metrics.tables",
    "harness.metrics.scales",
    "harness.metrics.runs",
    "harness.validation.case",
    "harness.validation.run",
    "harness.rundir",
    "harness.parallel",
    "harness.artefacts",
    "harness.validation.tolerances",
    "harness.validation.result",
    "harness.engines.jsbsim.grid",
    "reports.model",
    "reports.html",
    "reports.pdf",
    "reports.report_figures",
    "harness.campaign.spec",
    "harness.campaign.sampling",
    "harness.campaign.execute",
    "harness.campaign.store",
    "harness.campaign.runner",
    "harness.campaign.batch",
    "harness.campaign.integrators",
    "harness.campaign.montecarlo",
    "harness.campaign.report",
]


def _own_nodes(fn_node):
    """AST nodes of a function's own body (not of the functions, lambdas or classes nested in it)."""
    todo = list(ast.iter_child_nodes(fn_node))
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda, ast.ClassDef)):
            continue
        yield node
        todo.extend(ast.iter_child_nodes(node))


def _function_node(func):
    try:
        source = textwrap.dedent(inspect.getsource(func))
    except (OSError, TypeError):
        return None
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name == func.__name__:
            return node
    return None


def _returns_value(func, node) -> bool:
    ann = inspect.signature(func).return_annotation
    if ann is not inspect.Signature.empty:
        return ann not in (None, "None", type(None))
    if node is None:
        return False
    return any(
        isinstance(n, ast.Return)
        and n.value is not None
        and not (isinstance(n.value, ast.Constant) and n.value.value is None)
        for n in _own_nodes(node)
    )


def _raises(node) -> bool:
    return node is not None and any(isinstance(n, ast.Raise) and n.exc is not None for n in _own_nodes(node))


def check_docstring(func, name: str | None = None, skip_first: bool = False) -> list[str]:
    """Problems of the numpydoc docstring of ``func``, as messages.

    Parameters
    ----------
    func : callable
        A plain function (for a method: the function found in the class ``__dict__``).
    name : str, optional
        Name to print (default: the function's qualified name).
    skip_first : bool
        Skip the first parameter of the signature (``self`` or ``cls`` of a method).

    Returns
    -------
    list of str
        Empty when the docstring is complete.
    """
    name = name or f"{func.__module__}.{func.__qualname__}"
    doc = inspect.getdoc(func)
    if not doc:
        return [f"{name}: no docstring"]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            parsed = docscrape.NumpyDocString(doc)
    except Exception as exc:  # a malformed section is a finding, not a crash
        return [f"{name}: docstring does not parse as numpydoc ({exc})"]
    problems = []
    if not "".join(parsed["Summary"]).strip():
        problems.append(f"{name}: no summary line")
    params = list(inspect.signature(func).parameters.values())
    if skip_first and params:
        params = params[1:]
    expected = {}
    for p in params:
        if p.kind is inspect.Parameter.VAR_POSITIONAL:
            expected[f"*{p.name}"] = p
        elif p.kind is inspect.Parameter.VAR_KEYWORD:
            expected[f"**{p.name}"] = p
        else:
            expected[p.name] = p
    documented = set()
    for entry in list(parsed["Parameters"]) + list(parsed["Other Parameters"]):
        for part in entry.name.replace("\\", "").split(","):
            if part.strip():
                documented.add(part.strip())
    for pname in expected:
        if pname not in documented:
            problems.append(f"{name}: parameter '{pname}' is not documented in Parameters")
    for pname in sorted(documented - set(expected)):
        problems.append(f"{name}: Parameters documents '{pname}', which is not in the signature")
    node = _function_node(func)
    if _returns_value(func, node) and not (parsed["Returns"] or parsed["Yields"]):
        problems.append(f"{name}: returns a value but has no Returns section")
    if _raises(node) and not parsed["Raises"]:
        problems.append(f"{name}: raises but has no Raises section")
    return problems


def public_api(module):
    """``(name, function, is_method)`` for the public functions and public methods of public classes
    defined in ``module`` (each function object once)."""
    seen = set()
    for name, obj in vars(module).items():
        if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
            continue
        if inspect.isfunction(obj) and id(obj) not in seen:
            seen.add(id(obj))
            yield f"{module.__name__}.{name}", obj, False
        elif inspect.isclass(obj):
            generated = set(getattr(obj, "__dataclass_fields__", {})) and {"__init__", "__repr__", "__eq__"}
            for mname, member in vars(obj).items():
                if mname.startswith("_") or mname in generated or isinstance(member, property):
                    continue
                if isinstance(member, staticmethod):
                    fn, method = member.__func__, False
                elif isinstance(member, classmethod):
                    fn, method = member.__func__, True
                elif inspect.isfunction(member):
                    fn, method = member, True
                else:
                    continue
                if fn.__module__ != module.__name__ or id(fn) in seen:  # generated (NamedTuple, Protocol)
                    continue
                seen.add(id(fn))
                yield f"{module.__name__}.{name}.{mname}", fn, method


@pytest.mark.parametrize("module_name", MODULES)
def test_docstrings(module_name):
    module = importlib.import_module(module_name)
    problems = [p for name, fn, method in public_api(module) for p in check_docstring(fn, name, method)]
    assert not problems, f"{len(problems)} docstring problem(s):\n" + "\n".join(problems)


# --- the checker itself -----------------------------------------------------------------------


def _complete(a, b, *args, scale=1.0, **kwargs):
    """Sum of two numbers.

    Parameters
    ----------
    a, b : float
        Terms [m].
    *args : float
        More terms [m].
    scale : float
        Factor.
    **kwargs
        Ignored.

    Returns
    -------
    float
        The scaled sum [m].

    Raises
    ------
    ValueError
        When ``scale`` is negative.
    """
    if scale < 0:
        raise ValueError("negative scale")
    return scale * (a + b + sum(args))


def _strip(func, line):
    """A copy of ``func`` whose docstring lacks the lines containing ``line`` (and their description)."""
    lines = inspect.getdoc(func).splitlines()
    out, skip = [], False
    for ln in lines:
        if ln.strip().startswith(line):
            skip = True
            continue
        if skip and ln.startswith("    "):
            continue
        skip = False
        out.append(ln)

    def copy(*a, **k):
        return func(*a, **k)

    copy.__signature__ = inspect.signature(func)
    copy.__doc__ = "\n".join(out)
    copy.__name__ = copy.__qualname__ = func.__name__
    return copy


def test_checker_accepts_a_complete_docstring():
    assert check_docstring(_complete) == []


def test_checker_fails_when_a_parameter_doc_is_removed():
    problems = check_docstring(_strip(_complete, "scale : float"), "synthetic")
    assert problems == ["synthetic: parameter 'scale' is not documented in Parameters"]


def test_checker_fails_on_a_documented_parameter_absent_from_the_signature():
    def f(a):
        """Summary.

        Parameters
        ----------
        a, b : float
            Terms.
        """

    assert check_docstring(f, "f") == ["f: Parameters documents 'b', which is not in the signature"]


def test_checker_wants_returns_and_raises_from_the_own_body():
    def f(x):
        """Summary.

        Parameters
        ----------
        x : float
            A number.
        """

        def inner():
            raise RuntimeError  # nested: not f's own raise

        if x < 0:
            raise ValueError("x < 0")
        return 2 * x

    def g(x) -> None:
        """Summary.

        Parameters
        ----------
        x : float
            A number.
        """
        try:
            x()
        except TypeError:
            raise  # a bare re-raise needs no Raises section
        return None

    assert check_docstring(f, "f") == [
        "f: returns a value but has no Returns section",
        "f: raises but has no Raises section",
    ]
    assert check_docstring(g, "g") == []


def test_checker_fails_on_a_real_function_with_a_parameter_doc_removed():
    """Removing one parameter's entry from a real public function's docstring makes it fail."""
    from gna.eom import force_equations

    assert check_docstring(force_equations, "gna.eom.force_equations") == []
    broken = _strip(force_equations, "X, Y, Z :")
    problems = check_docstring(broken, "gna.eom.force_equations")
    assert problems == [
        f"gna.eom.force_equations: parameter '{p}' is not documented in Parameters" for p in ("X", "Y", "Z")
    ]
