"""Configuration fields that carry their own documentation and range.

A settings dataclass declares each configuration key once, as a field made by
:func:`knob`: its default, its description and, where it has one, its range or its
choices. :func:`fields_schema` turns such a dataclass into the JSON schema of its
section and :func:`check_keys` rejects a key that the section does not define, in one
line. The pipeline's whole schema (``workflow/schemas/config.schema.yaml``), its
defaults and the docs' table of keys are generated from these fields
(:mod:`microdoppler.settings`).
"""

from __future__ import annotations

import dataclasses
import re
import types
import typing
from dataclasses import MISSING

from .errors import ConfigError, unknown_key

__all__ = ["knob", "fields_schema", "check_keys", "unknown_key", "config_fields", "config_names"]

#: the key of a field's configuration metadata
META = "config"

#: knob() keywords -> their JSON schema names, in the order the schema lists them
_CONSTRAINTS = (
    ("enum", "enum"),
    ("minimum", "minimum"),
    ("exclusive_minimum", "exclusiveMinimum"),
    ("maximum", "maximum"),
    ("exclusive_maximum", "exclusiveMaximum"),
    ("min_items", "minItems"),
)


def knob(
    default=MISSING,
    description: str = "",
    *,
    default_factory=MISSING,
    enum=None,
    minimum=None,
    exclusive_minimum=None,
    maximum=None,
    exclusive_maximum=None,
    items: dict | None = None,
    min_items: int | None = None,
    schema: dict | None = None,
    config: bool = True,
):
    """A dataclass field that is a configuration key.

    Parameters
    ----------
    default, default_factory
        As :func:`dataclasses.field`.
    description : str
        What the key means, with its unit in brackets; the schema's and the docs'
        text. Empty: the field's entry in the class docstring's Parameters.
    enum : sequence, optional
        The values allowed.
    minimum, exclusive_minimum, maximum, exclusive_maximum : number, optional
        The range allowed (JSON schema's keywords).
    items : dict, optional
        The JSON schema of a list's items (default from the field's type).
    min_items : int, optional
        Fewest items of a list.
    schema : dict, optional
        Extra JSON schema keywords (they win over the derived ones).
    config : bool
        False: a field of the class that no configuration key sets (it is fixed, or
        comes from another section); it is left out of the schema.

    Returns
    -------
    dataclasses.Field

    Examples
    --------
    >>> from dataclasses import dataclass
    >>> @dataclass(frozen=True)
    ... class Demo:
    ...     rate_hz: float = knob(10.0, "Rate [Hz].", exclusive_minimum=0)
    >>> fields_schema(Demo)["rate_hz"]
    {'description': 'Rate [Hz].', 'type': 'number', 'exclusiveMinimum': 0, 'default': 10.0}
    """
    meta = {"description": description, "config": config, "items": items, "schema": schema or {}}
    for name, _ in _CONSTRAINTS:
        meta[name] = locals()[name]
    kw = {"default": default} if default_factory is MISSING else {"default_factory": default_factory}
    return dataclasses.field(**kw, metadata={META: meta})


def config_fields(cls) -> list[dataclasses.Field]:
    """The fields of dataclass ``cls`` that are configuration keys, in order."""
    return [f for f in dataclasses.fields(cls) if f.metadata.get(META, {}).get("config", True)]


def config_names(cls) -> list[str]:
    """The configuration keys of dataclass ``cls``."""
    return [f.name for f in config_fields(cls)]


def default_of(f: dataclasses.Field):
    """The default value of field ``f`` (a dataclass default as a mapping)."""
    value = f.default_factory() if f.default is MISSING and f.default_factory is not MISSING else f.default
    if value is MISSING:
        raise TypeError(f"configuration field {f.name} has no default")
    return plain(value)


def plain(value):
    """``value`` as YAML/JSON data: dataclasses as mappings of their configuration
    keys, tuples as lists."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: plain(getattr(value, f.name)) for f in config_fields(type(value))}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    return value


def docstring_parameters(cls) -> dict[str, str]:
    """name -> description of the numpydoc ``Parameters`` section of ``cls``'s
    docstring (one line; ``a, b : type`` gives both names the text)."""
    import inspect

    doc = inspect.getdoc(cls) or ""
    lines = doc.splitlines()
    out, names, text, inside = {}, [], [], False

    def flush():
        for n in names:
            out[n] = " ".join(text).strip()

    for i, line in enumerate(lines):
        if line.strip() == "Parameters" and i + 1 < len(lines) and set(lines[i + 1].strip()) == {"-"}:
            inside = True
            continue
        if not inside or set(line.strip()) == {"-"}:
            continue
        if line and not line.startswith(" "):
            if i + 1 < len(lines) and lines[i + 1].strip() and set(lines[i + 1].strip()) == {"-"}:
                break  # the next section
            flush()
            m = re.match(r"(\w+(?:\s*,\s*\w+)*)\s*:", line)
            names, text = ([n.strip() for n in m.group(1).split(",")] if m else []), []
        elif line.strip():
            text.append(line.strip())
    flush()
    return out


def _json_type(tp) -> dict:
    """The JSON schema of the Python type ``tp`` (a field's annotation)."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        inner = _json_type(args[0]) if len(args) == 1 else {}
        if "type" in inner and len(args) < len(typing.get_args(tp)):
            return {"type": [inner["type"], "null"]}
        return inner
    if tp is bool:
        return {"type": "boolean"}
    if tp is int:
        return {"type": "integer"}
    if tp is float:
        return {"type": "number"}
    if tp is str:
        return {"type": "string"}
    if tp is dict or origin is dict:
        return {"type": "object"}
    if tp in (list, tuple) or origin in (list, tuple):
        args = [a for a in typing.get_args(tp) if a is not Ellipsis]
        return {"type": "array", **({"items": _json_type(args[0])} if args else {})}
    if dataclasses.is_dataclass(tp):
        return {"type": "object"}
    return {}


def fields_schema(cls, defaults: dict | None = None) -> dict:
    """The JSON schema ``properties`` of dataclass ``cls``'s configuration keys.

    Each key has its description, type, range and default; a field whose type is a
    settings dataclass is a nested object whose keys are that class's, and which
    accepts no other key. ``defaults`` overrides some keys' defaults (a section whose
    pipeline default differs from the class's).
    """
    hints = typing.get_type_hints(cls)
    docs = docstring_parameters(cls)
    defaults = defaults or {}
    props = {}
    for f in config_fields(cls):
        meta = f.metadata.get(META, {})
        tp = hints[f.name]
        entry = {"description": meta.get("description") or docs.get(f.name, "")}
        if not entry["description"]:
            raise TypeError(f"{cls.__name__}.{f.name}: a configuration key needs a description")
        entry.update(_json_type(tp))
        if meta.get("items") is not None:
            entry["items"] = meta["items"]
        for name, key in _CONSTRAINTS:
            if meta.get(name) is not None:
                entry[key] = list(meta[name]) if name == "enum" else meta[name]
        entry["default"] = plain(defaults[f.name]) if f.name in defaults else default_of(f)
        if dataclasses.is_dataclass(tp):
            entry["properties"] = fields_schema(tp)
            entry["additionalProperties"] = False
        entry.update(meta.get("schema") or {})
        props[f.name] = entry
    return props


def range_text(f: dataclasses.Field) -> str:
    """The range of field ``f``'s knob as text (``> 0``, ``in [0, 1)``), or ''."""
    m = f.metadata.get(META, {})
    lo, lo_open = (
        (m["exclusive_minimum"], True) if m.get("exclusive_minimum") is not None else (m.get("minimum"), False)
    )
    hi, hi_open = (
        (m["exclusive_maximum"], True) if m.get("exclusive_maximum") is not None else (m.get("maximum"), False)
    )
    if lo is not None and hi is not None:
        return f"in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
    if lo is not None:
        return f"{'>' if lo_open else '>='} {lo:g}"
    if hi is not None:
        return f"{'<' if hi_open else '<='} {hi:g}"
    return ""


def check_ranges(obj, source, *, all_fields: bool = False) -> None:
    """Raise :class:`~microdoppler.errors.ConfigError` for the first number of
    dataclass ``obj`` outside its knob's range (``<source>: <name>: <name>=<value>
    must be <range>``): a class's ``__post_init__`` checks what its schema says.
    ``all_fields``: the ``config=False`` knobs' ranges too (fixed settings that no
    configuration key sets).

    Examples
    --------
    >>> from dataclasses import dataclass
    >>> @dataclass(frozen=True)
    ... class Demo:
    ...     rate_hz: float = knob(10.0, "Rate [Hz].", exclusive_minimum=0)
    ...     def __post_init__(self):
    ...         check_ranges(self, "demo")
    >>> Demo(rate_hz=0.0)
    Traceback (most recent call last):
    ...
    microdoppler.errors.ConfigError: demo: rate_hz: rate_hz=0.0 must be > 0
    """
    for f in dataclasses.fields(obj) if all_fields else config_fields(type(obj)):
        m = f.metadata.get(META, {})
        v = getattr(obj, f.name)
        if not isinstance(v, (int, float)) or isinstance(v, bool):
            continue
        ok = (
            (m.get("minimum") is None or v >= m["minimum"])
            and (m.get("exclusive_minimum") is None or v > m["exclusive_minimum"])
            and (m.get("maximum") is None or v <= m["maximum"])
            and (m.get("exclusive_maximum") is None or v < m["exclusive_maximum"])
        )
        if not ok:
            raise ConfigError(source, f.name, f"{f.name}={v} must be {range_text(f)}")


def check_keys(mapping, known, section: str, source="config") -> dict:
    """``mapping`` (None: empty) when every key of it is in ``known``; else the
    :class:`~microdoppler.errors.ConfigError` of :func:`unknown_key` for the first
    that is not. A value that is not a mapping is an error too."""
    if mapping is None:
        return {}
    if not isinstance(mapping, dict):
        raise ConfigError(source, section, f"is a {type(mapping).__name__}", "a mapping of settings")
    known = list(known)
    for key in mapping:
        if key not in known:
            raise unknown_key(source, section, key, known)
    return dict(mapping)
