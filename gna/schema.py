"""Input files checked before use: safe identifiers, file look-up, TOML reading, JSON Schema validation.

Aircraft and scenario files are TOML; each table is checked against a JSON
Schema shipped with the package (``gna/data/schemas/aircraft.schema.json``,
``planners/schemas/scenario.schema.json``) with :mod:`jsonschema`, and the
first problem is reported as one line naming the file, the table, the key and
the value, with a "did you mean" suggestion for a misspelt key (difflib).
Unknown keys, conflicting keys (``weight_lb`` beside ``mass_kg``) and wrong
types are refused rather than ignored.

Identifiers that become file names (an aircraft ``id``, a scenario ``name``)
must match :data:`SAFE_NAME`: letters, digits, ``.``, ``_`` and ``-``, starting
with a letter or a digit, at most 64 characters, never ``..``: no path
separator, no absolute path, no parent folder.
"""

from __future__ import annotations

import difflib
import json
import re
import tomllib
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any

from .errors import InputError

#: Pattern of identifiers used as file names (aircraft ``id``, scenario ``name``).
SAFE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,63}$")

#: Largest input file read [bytes]: every bundled file is below 100 kB; a bigger one is a mistake or an attack.
MAX_FILE_BYTES = 16 * 1024 * 1024

#: Deepest nesting of tables and lists in a TOML file (the schemas nest at most 5 levels).
MAX_DEPTH = 32

#: Most items of one list or keys of one table in a TOML file (tighter bounds are in the schemas).
MAX_ITEMS = 10000

#: Words of the JSON Schema types, for messages.
_TYPE_WORDS = {
    "object": "a table",
    "array": "a list",
    "number": "a number",
    "integer": "a whole number",
    "string": "a string",
    "boolean": "true or false",
}


def check_name(value: Any, key: str, where: str) -> str:
    """Check an identifier that becomes a file or folder name.

    Parameters
    ----------
    value : object
        The identifier read from a file (``id`` of an aircraft, ``name`` of a scenario).
    key : str
        Its key, for the message.
    where : str
        File (and table), for the message.

    Returns
    -------
    str
        ``value``, unchanged.

    Raises
    ------
    InputError
        If ``value`` is not a string matching :data:`SAFE_NAME` or contains ``..``.
    """
    if not isinstance(value, str) or not SAFE_NAME.match(value) or ".." in value:
        raise InputError(
            f"{where}: {key} = {value!r} is not a safe identifier: use 1 to 64 letters, digits, "
            f"'.', '_' or '-', starting with a letter or a digit, without '..' "
            f"(it names output files)"
        )
    return value


def find_file(
    name_or_path: str | Path, catalogue: Mapping[str, Path], what: str, base: str | Path | None = None
) -> Path | None:
    """The bundled file called ``name_or_path``, or the ``.toml`` file at that path.

    Parameters
    ----------
    name_or_path : str or pathlib.Path
        A bundled name (``f16c``) or a path.
    catalogue : mapping of str to pathlib.Path
        The bundled files by name.
    what : str
        ``"aircraft"`` or ``"scenario"``, for the messages.
    base : str or pathlib.Path, optional
        Folder relative paths are resolved from (the folder of the scenario that names an
        aircraft); default the current directory.

    Returns
    -------
    pathlib.Path or None
        The file; None for a bare name that is neither bundled nor a file (the caller names the
        bundled files).

    Raises
    ------
    InputError
        A path that does not exist, a folder, or a file whose name does not end in ``.toml``.
    """
    key = str(name_or_path)
    if key in catalogue:
        return catalogue[key]
    path = Path(key)
    if base is not None and not path.is_absolute():
        path = Path(base) / path
    looks_like_path = any(sep in key for sep in ("/", "\\")) or key.endswith(".toml")
    if path.is_dir():
        raise InputError(f"{what} file {key!r}: {path} is a folder, not a .toml file")
    if path.is_file():
        if path.suffix != ".toml":
            raise InputError(f"{what} file {key!r}: the file name must end in .toml")
        return path
    if looks_like_path or path.exists():
        hint = (
            f"; did you mean {key}.toml?"
            if path.suffix != ".toml" and path.with_name(path.name + ".toml").is_file()
            else ""
        )
        raise InputError(f"{what} file {key!r}: no such file ({path}){hint}")
    return None


def read_toml(path: str | Path) -> dict:
    """Read a TOML file (UTF-8, a leading byte-order mark accepted), its size and shape bounded.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.

    Returns
    -------
    dict
        The parsed document.

    Raises
    ------
    InputError
        The file cannot be read, is larger than :data:`MAX_FILE_BYTES`, is not UTF-8, is not valid TOML,
        nests tables and lists deeper than :data:`MAX_DEPTH` or has a list or table of more than
        :data:`MAX_ITEMS` items (:func:`check_shape`): one line naming the file, the value and the bound.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise InputError(f"{path}: {size} bytes, above the bound of {MAX_FILE_BYTES} bytes for an input file")
        raw = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read the file ({exc.strerror or type(exc).__name__})") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(
            f"{path}: not UTF-8 text (byte {raw[exc.start]:#04x} at offset {exc.start}); save the file as UTF-8"
        ) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path.name}: not valid TOML ({exc})") from None
    except RecursionError:  # tomllib parses nested inline tables and lists recursively
        raise InputError(f"{path.name}: tables or lists nested deeper than the bound of {MAX_DEPTH} levels") from None
    check_shape(data, path.name)
    return data


def check_shape(data: Any, where: str, max_depth: int = MAX_DEPTH, max_items: int = MAX_ITEMS) -> None:
    """Refuse a parsed document nested too deep or with too long a list or table (iteratively: no recursion).

    Parameters
    ----------
    data : object
        The parsed document (tables, lists, values).
    where : str
        The file's name, for the message.
    max_depth : int
        Deepest nesting of tables and lists.
    max_items : int
        Most items of one list or keys of one table.

    Raises
    ------
    InputError
        One line naming the file, the key path, the depth or the count, and the bound.
    """
    stack = [(data, 0, "")]
    while stack:
        value, depth, key = stack.pop()
        if not isinstance(value, (dict, list)):
            continue
        key = key if len(key) <= 80 else key[:60] + "..."  # a deep path, shortened
        if depth > max_depth:
            raise InputError(
                f"{where}: {key or 'the document'} is nested {depth} levels deep, above the bound of {max_depth}"
            )
        if len(value) > max_items:
            what = "keys" if isinstance(value, dict) else "items"
            raise InputError(
                f"{where}: {key or 'the document'} has {len(value)} {what}, above the bound of {max_items}"
            )
        items = value.items() if isinstance(value, dict) else enumerate(value)
        for k, v in items:
            if isinstance(v, (dict, list)):
                sub = f"{key}[{k}]" if isinstance(k, int) else (f"{key}.{k}" if key else str(k))
                stack.append((v, depth + 1, sub))


def load_schema(package: str, *parts: str) -> dict:
    """A JSON Schema shipped as package data.

    Parameters
    ----------
    package : str
        The package (``"gna"``, ``"planners"``).
    *parts : str
        Path of the ``.schema.json`` file inside the package.

    Returns
    -------
    dict
        The schema.
    """
    return json.loads(resources.files(package).joinpath(*parts).read_text(encoding="utf-8"))


def validate(data: Mapping[str, Any], schema: Mapping[str, Any], where: str) -> None:
    """Check a parsed file against its JSON Schema; the first problem becomes one clear error.

    Parameters
    ----------
    data : mapping
        The parsed TOML document.
    schema : mapping
        Its JSON Schema (draft 2020-12).
    where : str
        The file's name, for the message.

    Raises
    ------
    InputError
        Naming the file, the table, the key and the value: an unknown key (with the closest known
        key), a key of the wrong type, two keys that exclude each other, a value out of range.
    """
    import jsonschema

    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(data), key=lambda e: (len(e.absolute_path), _path_key(e)))
    if errors:
        raise InputError(_message(errors[0], where))


def _path_key(error) -> list[str]:
    return [str(p) for p in error.absolute_path]


def _location(path: list, where: str) -> tuple[str, str | None, int | None]:
    """``(file [table], key, item index)`` of a path in the document."""
    parts = list(path)
    index = parts.pop() if parts and isinstance(parts[-1], int) else None
    key = parts.pop() if parts else None
    table = ""
    for p in parts:
        table += f" #{p + 1}" if isinstance(p, int) else (f".{p}" if table else str(p))
    return (f"{where} [{table}]" if table else where), key, index


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _expected(schema: Mapping[str, Any]) -> str:
    if "enum" in schema:
        return "one of " + ", ".join(repr(v) for v in schema["enum"])
    if "const" in schema:
        return repr(schema["const"])
    t = schema.get("type")
    if isinstance(t, list):
        return " or ".join(_TYPE_WORDS.get(x, x) for x in t)
    if t:
        return _TYPE_WORDS.get(t, t)
    if "oneOf" in schema or "anyOf" in schema:
        return " or ".join(_expected(s) for s in schema.get("oneOf", schema.get("anyOf")))
    if "$ref" in schema:  # the scenario schema's definitions are tables (a spline, a boundary)
        return "a table"
    return "valid"


def _plural(schema: Mapping[str, Any]) -> str:
    if "enum" in schema:
        return "values among " + ", ".join(repr(v) for v in schema["enum"])
    words = {
        "object": "tables",
        "array": "lists",
        "number": "numbers",
        "integer": "whole numbers",
        "string": "strings",
        "boolean": "booleans",
    }
    t = schema.get("type")
    return " or ".join(words.get(x, x) for x in (t if isinstance(t, list) else [t])) if t else "valid items"


def did_you_mean(key, known) -> str:
    """`` (did you mean 'k'?)`` with the closest of ``known`` to ``key`` (difflib), else the one known name that
    starts with ``key`` (a shortened name: ``twin-otter`` for ``twin-otter-single-engine``), or an empty string.

    Parameters
    ----------
    key : object
        The key found (its ``str``).
    known : iterable of str
        The accepted keys.

    Returns
    -------
    str
    """
    known = list(known)
    close = difflib.get_close_matches(str(key), known, n=1)
    if not close and str(key):
        close = [k for k in known if k.startswith(str(key))]
    return f" (did you mean {close[0]!r}?)" if len(close) == 1 else ""


def unknown_key_message(key: str, known, where: str) -> str:
    """The message refusing an unknown key, with the closest known key when there is one.

    Parameters
    ----------
    key : str
        The key found.
    known : iterable of str
        The accepted keys.
    where : str
        File and table, for the message.

    Returns
    -------
    str
    """
    known = list(known)
    return f"{where}: unknown key {key!r}{did_you_mean(key, known)}; known keys: {', '.join(known)}"


def _message(error, where: str) -> str:
    """One line for a :class:`jsonschema.ValidationError`."""
    kind, schema, value = error.validator, error.schema, error.instance
    if kind == "additionalProperties":
        loc, key, index = _location(list(error.absolute_path) + ["?"], where)
        known = list(schema.get("properties", {}))
        patterns = [re.compile(p) for p in schema.get("patternProperties", {})]
        unknown = [k for k in value if k not in known and not any(p.search(k) for p in patterns)]
        k = unknown[0]
        return f"{loc}: unknown key {k!r}{did_you_mean(k, known)} = {_short(value[k])}; known keys: {', '.join(known)}"
    if "propertyNames" in error.schema_path:
        loc, _, _ = _location(list(error.absolute_path) + ["?"], where)
        names = error.schema.get("enum")
        if names:
            close = difflib.get_close_matches(str(value), [str(n) for n in names], n=1, cutoff=0.6)
            hint = (f"did you mean {close[0]!r}? " if close else "") + "known keys: " + ", ".join(map(str, names))
        else:
            hint = error.schema.get("errorMessage", f"it must match {error.schema.get('pattern')}")
        return f"{loc}: key {_short(value)} is not allowed; {hint}"
    loc, key, index = _location(list(error.absolute_path), where)
    if kind == "not" and isinstance(error.validator_value, dict) and "required" in error.validator_value:
        a, b = error.validator_value["required"][:2]
        loc, _, _ = _location(list(error.absolute_path) + ["?"], where)
        return f"{loc}: {a} = {_short(value[a])} and {b} = {_short(value[b])} give the same quantity twice; keep one"
    if kind == "required":
        loc, _, _ = _location(list(error.absolute_path) + ["?"], where)
        missing = [k for k in error.validator_value if k not in value]
        return f"{loc}: missing {missing[0]!r}"
    alternatives = error.validator_value if kind in ("oneOf", "anyOf") else None
    if alternatives and all(isinstance(a, dict) and set(a) == {"required"} for a in alternatives):
        loc, _, _ = _location(list(error.absolute_path) + ["?"], where)
        return f"{loc}: missing one of " + ", ".join(repr(k) for a in alternatives for k in a["required"])
    if kind in ("oneOf", "anyOf") and error.context:
        # the alternative that got furthest names the problem best
        import jsonschema

        best = jsonschema.exceptions.best_match(error.context)
        if best is not None and len(best.absolute_path) > len(error.absolute_path):
            return _message(best, where)
        # the alternative of the value's own type (a table where a table is allowed) names its problem
        deeper = [e for e in error.context if len(e.absolute_path) > len(error.absolute_path)]
        typed = deeper or [e for e in error.context if e.validator not in ("type", "const", "enum")]
        if typed:
            return _message(jsonschema.exceptions.best_match(typed), where)
    name = key if key is not None else "value"
    custom = schema.get("errorMessage")
    if index is not None:
        return f"{loc}: {name} must be a list of {_plural(schema)}; item {index + 1} is {_short(value)}"
    if custom and kind == "pattern":
        return f"{loc}: {name} = {_short(value)}: {custom}"
    if kind in ("type", "enum", "oneOf", "anyOf", "const"):
        return f"{loc}: {name} must be {_expected(schema)}, got {_short(value)}"
    bounds = {
        "minimum": ">=",
        "maximum": "<=",
        "exclusiveMinimum": ">",
        "exclusiveMaximum": "<",
        "minItems": "at least",
        "maxItems": "at most",
        "minLength": "at least",
        "maxLength": "at most",
    }
    if kind in ("maxItems", "maxLength"):
        unit = "items" if kind == "maxItems" else "characters"
        return f"{loc}: {name} has {len(value)} {unit}, above the bound of {error.validator_value}"
    if kind == "uniqueItems":
        return f"{loc}: {name} = {_short(value)} repeats an item; give each once"
    if kind in bounds:
        unit = " items" if "Items" in kind else (" characters" if "Length" in kind else "")
        return f"{loc}: {name} must be {bounds[kind]} {error.validator_value}{unit}, got {_short(value)}"
    if kind == "pattern":
        return f"{loc}: {name} = {_short(value)} does not match {error.validator_value}"
    return f"{loc}: {name} = {_short(value)}: {error.message}"
