"""Writing fitted aircraft files (TOML) and comparing them.

The output follows the layout of the hand-made aircraft files
(``gna/data/aircraft/f16c.toml``): a commented header, ``id``, ``name``,
``[provenance]`` (source, transformation, date, sampling design, reference
condition, statistics), ``[mass]``, ``[geometry]``, ``[engines]``,
``[envelope]``, a machine-readable ``[fit]`` record (design, per-coefficient
statistics, trim check; ignored by the loader) and ``[aero]`` with one inline
table per term (``std_error`` added).  Strings are written as TOML basic
strings, floats with ``repr`` (shortest round-trip form).
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Mapping
from typing import Any

from ..aircraft import aircraft_from_dict
from ..errors import InputError

_BARE = set("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-")


def _key(k: str) -> str:
    return k if k and set(k) <= _BARE else json.dumps(k)


def value(v: Any) -> str:
    """The TOML text of one value.

    Parameters
    ----------
    v : object
        A str, bool, int, float (inf and nan included), numpy scalar, list or tuple, or mapping (written
        as an inline table), nested freely.

    Returns
    -------
    str
        TOML text: strings as basic strings, floats by ``repr`` (shortest round-trip form).

    Raises
    ------
    InputError
        A value of another type.
    """
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, Mapping):
        return "{ " + ", ".join(f"{_key(str(k))} = {value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(value(x) for x in v) + "]"
    if hasattr(v, "item"):  # numpy scalar
        return value(v.item())
    raise InputError(f"cannot write {type(v).__name__} {v!r} to TOML")


def _is_table(v: Any) -> bool:
    return isinstance(v, Mapping) and not getattr(v, "inline", False)


class Inline(dict):
    """A mapping written as an inline table."""

    inline = True


def table(path: str, body: Mapping[str, Any]) -> list[str]:
    """Lines of ``[path]`` with its scalar keys, then its sub-tables.

    A list under the key ``terms`` is written one inline table a line (the ``[aero]`` terms).

    Parameters
    ----------
    path : str
        Dotted table name (keys quoted where needed); empty for the top level (no header line).
    body : mapping
        Keys -> values; a mapping that is not :class:`Inline` becomes a sub-table ``[path.key]``.

    Returns
    -------
    list of str
        The lines, sub-tables separated by an empty line.

    Raises
    ------
    InputError
        A value that cannot be written (:func:`value`).
    """
    lines = [f"[{path}]"] if path else []
    for k, v in body.items():
        if not _is_table(v):
            if k == "terms" and isinstance(v, list):
                lines.append("terms = [")
                lines.extend(f"  {value(Inline(t))}," for t in v)
                lines.append("]")
            else:
                lines.append(f"{_key(k)} = {value(v)}")
    for k, v in body.items():
        if _is_table(v):
            lines.append("")
            lines.extend(table(f"{path}.{_key(k)}" if path else _key(k), v))
    return lines


def aircraft_document(doc: Mapping[str, Any], header: str) -> str:
    """TOML text of an aircraft document; checked to parse and to load as an aircraft.

    Parameters
    ----------
    doc : mapping
        The document: top-level keys (``id``, ``name``) and tables (:func:`gna.fit.document.fitted_document`).
    header : str
        Comment lines written first (each prefixed ``#``).

    Returns
    -------
    str
        The file's text.

    Raises
    ------
    RuntimeError
        The text does not parse as TOML (a bug of this writer, not of the input).
    InputError
        The document does not load as an aircraft (:func:`gna.aircraft.aircraft_from_dict`), or holds a value
        that cannot be written.
    """
    lines = [f"# {line}" if line else "#" for line in header.splitlines()]
    top = {k: v for k, v in doc.items() if not _is_table(v)}
    lines.extend(table("", top))
    for k, v in doc.items():
        if _is_table(v):
            lines.append("")
            lines.extend(table(_key(k), v))
    text = "\n".join(lines) + "\n"
    try:
        parsed = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:  # a bug in this writer, not user input
        raise RuntimeError(f"writer produced invalid TOML: {exc}") from exc
    aircraft_from_dict(parsed, where="generated aircraft file")
    return text


def differences(
    a: Any, b: Any, *, rtol: float = 1e-8, atol: float = 1e-10, ignore: tuple[str, ...] = (), path: str = ""
) -> list[str]:
    """Where two parsed documents differ: floats beyond ``atol + rtol*max(|a|,|b|)``, anything else exactly.

    Parameters
    ----------
    a, b : object
        Parsed TOML values (mappings and lists compared recursively).
    rtol, atol : float
        Relative and absolute tolerance on numbers when either side is a float.
    ignore : tuple of str
        Dotted paths not compared (e.g. ``"provenance.date"``).
    path : str
        Dotted path of ``a`` and ``b`` in their documents (prefix of the messages).

    Returns
    -------
    list of str
        One line a difference (``"path: a vs b"``, ``"path: only in first"``, ...); empty when equal.
    """
    if path in ignore:
        return []
    if isinstance(a, Mapping) and isinstance(b, Mapping):
        out = []
        for k in sorted(set(a) | set(b)):
            p = f"{path}.{k}" if path else str(k)
            if p in ignore:
                continue
            if k not in a or k not in b:
                out.append(f"{p}: only in {'second' if k not in a else 'first'}")
            else:
                out.extend(differences(a[k], b[k], rtol=rtol, atol=atol, ignore=ignore, path=p))
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{path}: {len(a)} items vs {len(b)}"]
        out = []
        for i, (x, y) in enumerate(zip(a, b)):
            out.extend(differences(x, y, rtol=rtol, atol=atol, ignore=ignore, path=f"{path}[{i}]"))
        return out
    if isinstance(a, float) or isinstance(b, float):
        if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
            x, y = float(a), float(b)
            if (math.isnan(x) and math.isnan(y)) or x == y:
                return []
            if abs(x - y) <= atol + rtol * max(abs(x), abs(y)):
                return []
        return [f"{path}: {a!r} vs {b!r}"]
    return [] if a == b else [f"{path}: {a!r} vs {b!r}"]
