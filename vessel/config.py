"""Validated configuration: YAML mappings into frozen dataclasses with ranges, and one-line errors.

Every field declares its allowed range (and unit) in its dataclass metadata with :func:`bounded`.
Loading rejects unknown keys, wrong types, non-finite numbers and out-of-range values with a
:class:`ConfigError` whose message names the source, the field and the allowed range.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any, TypeVar

import yaml

T = TypeVar("T")


class ConfigError(ValueError):
    """A configuration value or file is unusable; the message is one line meant for the user.

    ``key`` and ``default`` name the field that was refused and its default, when one field was (set by
    :func:`from_mapping`), so that a file's loader can say what to do (:func:`in_file`).
    """

    key: str | None = None
    default: Any = None


def in_file(path: str | Path, exc: ConfigError) -> ConfigError:
    """``exc`` as a file's error: the file, the key and the range, then what to do about it."""
    text = str(exc)
    if exc.key is None:
        return ConfigError(f"{path}: {text}")
    default = "none" if exc.default is None else f"{exc.default!r}"
    fix = f"correct {exc.key} in {path}, or delete the line to use its default ({default})"
    error = ConfigError(f"{path}: {text}; {fix}")
    error.key, error.default = exc.key, exc.default
    return error


def bounded(default: Any, lo: float | None = None, hi: float | None = None, unit: str = "",
            doc: str = "", lo_open: bool = False, hi_open: bool = False) -> Any:
    """A dataclass field with an allowed closed (or half-open) range, a unit and a one-line doc."""
    meta = {"lo": lo, "hi": hi, "unit": unit, "doc": doc, "lo_open": lo_open, "hi_open": hi_open}
    if isinstance(default, (list, dict, tuple)):
        return dataclasses.field(default_factory=lambda: default, metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def describe_range(meta: Mapping[str, Any]) -> str:
    """Human-readable range of a bounded field, e.g. '[0, 100] %' or '> 0 s'."""
    lo, hi, unit = meta.get("lo"), meta.get("hi"), meta.get("unit", "")
    lo_b = "(" if meta.get("lo_open") else "["
    hi_b = ")" if meta.get("hi_open") else "]"
    if lo is not None and hi is not None:
        text = f"{lo_b}{lo:g}, {hi:g}{hi_b}"
    elif lo is not None:
        text = f"{'>' if meta.get('lo_open') else '>='} {lo:g}"
    elif hi is not None:
        text = f"{'<' if meta.get('hi_open') else '<='} {hi:g}"
    else:
        text = "any finite value"
    return f"{text} {unit}".strip()


def check_number(value: Any, where: str, meta: Mapping[str, Any]) -> float:
    """Return ``value`` as a finite float within the field's range, or raise ConfigError naming ``where``."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f"{where}: expected a number in {describe_range(meta)}, got {value!r}")
    number = float(value)
    lo, hi = meta.get("lo"), meta.get("hi")
    bad = not math.isfinite(number)
    if lo is not None:
        bad = bad or number < lo or (meta.get("lo_open") and number == lo)
    if hi is not None:
        bad = bad or number > hi or (meta.get("hi_open") and number == hi)
    if bad:
        raise ConfigError(f"{where}: {value!r} is outside the allowed range {describe_range(meta)}")
    return number


def _int(value: Any, where: str, meta: Mapping[str, Any]) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ConfigError(f"{where}: expected an integer in {describe_range(meta)}, got {value!r}")
    return int(check_number(value, where, meta))


def _bool(value: Any, where: str, meta: Mapping[str, Any]) -> bool:
    if not isinstance(value, bool):
        raise ConfigError(f"{where}: expected true or false, got {value!r}")
    return value


def _str(value: Any, where: str, meta: Mapping[str, Any]) -> str:
    if not isinstance(value, str):
        raise ConfigError(f"{where}: expected text, got {value!r}")
    choices = meta.get("choices")
    if choices and value not in choices:
        raise ConfigError(f"{where}: {value!r} is not one of {', '.join(choices)}")
    return value


SCALARS = {float: check_number, int: _int, bool: _bool, str: _str}


def _convert(value: Any, hint: Any, where: str, meta: Mapping[str, Any]) -> Any:
    """Convert a YAML value to the annotated type ``hint``, validating ranges on the way."""
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        non_none = [a for a in args if a is not type(None)]
        return _convert(value, non_none[0], where, meta)
    if hasattr(hint, "from_config"):  # a type with its own forms (e.g. a vessel: a name, a mapping or a file)
        return hint.from_config(value, where)
    if dataclasses.is_dataclass(hint):
        return from_mapping(hint, value, where)
    if hint in SCALARS:
        return SCALARS[hint](value, where, meta)
    if origin is tuple:
        if not isinstance(value, (list, tuple)) or len(value) != len(args):
            raise ConfigError(f"{where}: expected a list of {len(args)} numbers, got {value!r}")
        return tuple(_convert(v, a, f"{where}[{i}]", meta) for i, (v, a) in enumerate(zip(value, args,
                                                                                           strict=True)))
    return value


def from_mapping(cls: type[T], data: Any, where: str) -> T:
    """Build dataclass ``cls`` from a mapping; unknown keys and bad values raise ConfigError."""
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise ConfigError(f"{where or 'configuration'}: expected a mapping of fields, got {type(data).__name__}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(map(str, data)) - set(fields))
    if unknown:
        at = f"{where}: " if where else ""
        raise ConfigError(f"{at}unknown key '{unknown[0]}' (allowed: {', '.join(sorted(fields))})")
    values = {}
    for name, value in data.items():
        key = f"{where}.{name}" if where else name
        try:
            values[name] = _convert(value, hints[name], key, fields[name].metadata)
        except ConfigError as exc:
            if exc.key is None and not dataclasses.is_dataclass(hints[name]):  # the innermost scalar refused
                exc.key, exc.default = key, _default_of(fields[name])
            raise
    try:
        obj = cls(**values)
    except ConfigError as exc:  # cross-field checks in __post_init__: they name their field first
        error = ConfigError(f"{where}: {exc}" if where else str(exc))
        name = str(exc).partition(":")[0]
        if exc.key is None and name in fields:
            error.key, error.default = (f"{where}.{name}" if where else name), _default_of(fields[name])
        raise error from None
    return obj


def _default_of(f: dataclasses.Field[Any]) -> Any:
    """A field's default value (for a message), None where it has none."""
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return None


def validate(obj: Any, where: str = "") -> None:
    """Check every bounded numeric field of a dataclass instance (recursively) against its range."""
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        name = f"{where}.{f.name}" if where else f.name
        if dataclasses.is_dataclass(value):
            validate(value, name)
        elif isinstance(value, (int, float)) and not isinstance(value, bool) and "lo" in f.metadata:
            check_number(value, name, f.metadata)


def read_yaml(path: str | Path) -> Any:
    """Read a YAML file, turning I/O and syntax problems into one-line ConfigErrors."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read file ({exc.strerror or exc})") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" at line {mark.line + 1}" if mark is not None else ""
        raise ConfigError(f"{path}: not valid YAML{at}") from None


def to_mapping(obj: Any) -> Any:
    """A plain dict/list version of a dataclass tree, for saving the resolved configuration."""
    if hasattr(obj, "to_config"):  # a type that writes itself as its loader reads it
        return obj.to_config()
    if dataclasses.is_dataclass(obj):
        return {f.name: to_mapping(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, (list, tuple)):
        return [to_mapping(v) for v in obj]
    return obj
