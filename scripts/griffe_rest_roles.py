"""Griffe extension of the documentation site: the reST of gflat's numpydoc docstrings, read as Markdown.

The docstrings are numpydoc (checked by ``tests/test_docstrings.py``) with Sphinx roles such as
:func:`gna.trim.trim` and literal blocks introduced by ``::``.  mkdocstrings renders docstrings as
Markdown, so this extension (``mkdocs.yml``, handler option ``extensions``) rewrites, before rendering:

* ``:func:`target``` (and ``:class:``, ``:meth:``, ``:mod:``, ``:data:``, ``:attr:``, ``:exc:``,
  ``:obj:``; ``~`` shows the last part only) into an *optional* autorefs cross-reference: a link when
  ``target`` (absolute, or relative to the docstring's module or class) is an object the site documents,
  plain code otherwise, never a warning;
* a paragraph ending in ``::`` into one ending in ``:`` (the indented block after it is a Markdown code
  block already);
* ``.. math::`` directives into a code block of the formula.

Module constants documented by a ``#:`` comment (Sphinx's style) get it as their docstring from the
``griffe-sphinx`` extension, listed before this one.
"""

from __future__ import annotations

import re

import griffe

ROLE = re.compile(r":(?:py:)?(func|class|meth|mod|data|attr|exc|obj):`(~?)([^`]+)`")
MATH = re.compile(r"^(\s*)\.\. math::\s*(.*)$")

#: Top-level packages of the site's API reference.
PACKAGES = ("gflat", "gna", "planners", "harness", "reports")


def _public_names() -> dict[str, str]:
    """gflat's public names -> their defining module (``gflat._PUBLIC``), read without importing gflat."""
    import ast
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "gflat" / "__init__.py"
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "_PUBLIC" for t in node.targets):
            return ast.literal_eval(node.value)
    return {}


PUBLIC = _public_names()


def _candidates(target: str, obj: griffe.Object) -> tuple[str, str]:
    target = target.strip().lstrip(".").removesuffix("()")
    if target.split(".")[0] in PACKAGES:
        return target, target
    if "." not in target and target in PUBLIC:
        return f"{PUBLIC[target]}.{target}", target
    module = obj.module.path if obj.kind is not griffe.Kind.MODULE else obj.path
    owner = obj.parent.path if obj.kind is not griffe.Kind.CLASS and obj.parent is not None else obj.path
    if obj.kind is griffe.Kind.CLASS:
        return f"{obj.path}.{target}", f"{module}.{target}"
    return f"{owner}.{target}" if owner != module else f"{module}.{target}", f"{module}.{target}"


def rewrite(text: str, obj: griffe.Object) -> str:
    """The docstring ``text`` of ``obj`` with its reST roles, ``::`` and math directives made Markdown.

    Parameters
    ----------
    text : str
        The docstring.
    obj : griffe.Object
        The object it documents (for relative targets).

    Returns
    -------
    str
    """

    def role(m: re.Match) -> str:
        tilde, target = m.group(2), m.group(3)
        shown = target.strip().removesuffix("()").split(".")[-1] if tilde else target.strip()
        ident, slug = _candidates(target, obj)
        return f'<autoref identifier="{ident}" slug="{slug}" optional><code>{shown}</code></autoref>'

    lines = []
    for line in text.splitlines():
        math = MATH.match(line)
        if math:
            lines += [f"{math.group(1)}```text", f"{math.group(1)}{math.group(2)}", f"{math.group(1)}```"]
            continue
        if line.rstrip().endswith("::") and not line.strip().startswith(".."):
            line = line.rstrip()[:-1] if line.strip() != "::" else ""
        lines.append(ROLE.sub(role, line))
    return "\n".join(lines)


class RestRoles(griffe.Extension):
    """Rewrite every docstring when griffe creates the object (see the module docstring).

    Attributes are rewritten last (``on_attribute_instance``, listed after ``griffe_sphinx`` in
    ``mkdocs.yml``), so that their ``#:`` comments, which ``griffe_sphinx`` makes docstrings, are too.
    """

    def on_instance(self, *, obj: griffe.Object, **kwargs) -> None:
        """Rewrite the docstring of ``obj`` (not an attribute).

        Parameters
        ----------
        obj : griffe.Object
            The object griffe just created.
        **kwargs
            Other arguments of the event (unused).
        """
        if obj.docstring is not None and obj.kind is not griffe.Kind.ATTRIBUTE:
            obj.docstring.value = rewrite(obj.docstring.value, obj)

    def on_attribute_instance(self, *, attr: griffe.Attribute, **kwargs) -> None:
        """Rewrite the docstring of the attribute ``attr``.

        Parameters
        ----------
        attr : griffe.Attribute
            The attribute griffe just created.
        **kwargs
            Other arguments of the event (unused).
        """
        if attr.docstring is not None:
            attr.docstring.value = rewrite(attr.docstring.value, attr)
