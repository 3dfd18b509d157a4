"""One checker for every settings and config table: each value against its dataclass field's type.

The daemon's settings (jetson.settings: the TOML file and command-line options) and the
simulator's training and evaluation configs (sim.config, sim.training.config) are frozen
dataclasses. `merge` applies a table (a TOML table, a dict of options) onto one of them: a key
the dataclass does not have is an error listing the ones it has; every value is checked against
the field's annotation by msgspec in strict mode (a string is never a number or a boolean, a
boolean never a number; an integer may stand for a float) and must be a finite number wherever
it is a number; nested tables merge into the nested dataclasses. The dataclasses' own
__post_init__ checks (ranges, names) run as before. Every error names the key as a TOML path
(`[link] port`, `[env.world] control_hz`), what the field expects and what was found; the
loader that read the file puts its name in front.

Values are stored as given, once checked: a valid table loads to exactly what it did before
the checker existed (an integer in a float field stays an integer).
"""

from __future__ import annotations

import dataclasses
import math
import re
import types
from collections.abc import Callable, Mapping
from functools import cache
from typing import Any, Literal, TypeVar, Union, get_args, get_origin, get_type_hints

import msgspec

T = TypeVar("T")

__all__ = ["check_value", "describe", "error_at", "found", "key_label", "merge"]

_NAMES: dict[Any, str] = {
    bool: "boolean",
    int: "integer",
    float: "number",
    str: "string",
    type(None): "none",
    Any: "anything",
}


def key_label(table: str, key: str | None = None) -> str:
    """`[table] key` (TOML's way of naming a key), `key` at the top level, `[table]` alone."""
    if key is None:
        return f"[{table}]" if table else ""
    return f"[{table}] {key}" if table else key


def error_at(error: type[Exception], label: str, message: str) -> Exception:
    """`error` saying `label: message`, marked as naming its key (an enclosing table's check
    passes it on as it is)."""
    exc = error(f"{label}: {message}" if label else message)
    exc.config_key = label  # type: ignore[attr-defined]  # named already: not wrapped again
    return exc


def describe(hint: Any) -> str:
    """What a field of this annotation takes, in TOML's words."""
    if hint in _NAMES:
        return _NAMES[hint]
    origin, args = get_origin(hint), get_args(hint)
    if origin is Literal:
        return "one of " + ", ".join(repr(a) for a in args)
    if origin in (Union, types.UnionType):
        return " or ".join(describe(a) for a in args)
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return f"an array [{describe(args[0])}, ...]"
        return f"an array [{', '.join(describe(a) for a in args)}]"
    if origin in (list, set, frozenset):
        return f"an array [{describe(args[0])}, ...]" if args else "an array"
    if origin is dict or hint is dict:
        if not args or args[1] is Any:
            return "a table"
        return f"a table {{name: {describe(args[1])}}}"
    if dataclasses.is_dataclass(hint):
        return "a table"
    return getattr(hint, "__name__", str(hint))


def found(value: Any) -> str:
    """What a value is, in TOML's words, and the value."""
    kinds = {bool: "boolean", int: "integer", float: "float", str: "string", type(None): "none"}
    kind = kinds.get(type(value))
    if kind is None:
        if isinstance(value, list | tuple):
            kind = "an array"
        elif isinstance(value, Mapping):
            kind = "a table"
        else:
            kind = type(value).__name__
    text = str(value).lower() if isinstance(value, bool) else repr(value)
    return f"{kind} {text if len(text) <= 60 else text[:57] + '...'}"


def _plain(value: Any) -> Any:
    """numpy scalars and arrays as Python numbers and lists (for checking only)."""
    if type(value).__module__ == "numpy" and hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, list | tuple):
        return type(value)(_plain(v) for v in value)
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    return value


def _not_finite(value: Any) -> float | None:
    if isinstance(value, float) and not math.isfinite(value):
        return value
    if isinstance(value, list | tuple):
        values = value
    elif isinstance(value, dict):
        values = list(value.values())
    else:
        return None
    for v in values:
        bad = _not_finite(v)
        if bad is not None:
            return bad
    return None


def check_value(value: Any, hint: Any, label: str, error: type[Exception] = ValueError) -> None:
    """Raise `error` naming `label` unless `value` is of type `hint` (msgspec, strict) and
    every number in it is finite."""
    plain = _plain(value)
    try:
        msgspec.convert(plain, type=hint, strict=True)
    except msgspec.ValidationError as exc:
        detail, _, where = str(exc).partition(" - at `$")
        inner = f" ({label}{where.rstrip('`')}: {detail})" if where else ""
        if not where and not detail.startswith(("Expected", "Invalid enum")):
            # A nested dataclass's own check (__post_init__) said what is wrong.
            raise error_at(error, label, detail) from None
        message = f"expected {describe(hint)}, found {found(value)}{inner}"
        raise error_at(error, label, message) from None
    bad = _not_finite(plain)
    if bad is not None:
        raise error_at(error, label, f"expected a finite number, found {bad!r}")


@cache
def _hints(cls: type) -> dict[str, Any]:
    return get_type_hints(cls)


def _dataclass_of(hint: Any) -> type | None:
    """The dataclass a field holds (its annotation, or one member of `X | None`)."""
    if dataclasses.is_dataclass(hint):
        return hint  # type: ignore[return-value]
    if get_origin(hint) in (Union, types.UnionType):
        classes = [a for a in get_args(hint) if dataclasses.is_dataclass(a)]
        if len(classes) == 1:
            return classes[0]  # type: ignore[no-any-return]
    return None


def merge(
    base: T,
    data: Mapping[str, Any] | None,
    table: str = "",
    *,
    error: type[Exception] = ValueError,
    new_entry: Callable[[type, str], Any] | None = None,
) -> T:
    """A copy of dataclass `base` with the values in `data` applied, every one checked.

    `table` is where `data` sits in its file ("" at the top, "env.world" for [env.world]); errors
    are raised as `error`. A nested table merges into the nested dataclass, so
    {"camera": {"tilt_deg": -20}} keeps the other camera values, and a table of dataclasses
    (dict[str, SomeConfig]) merges per entry; `new_entry(cls, name)` makes the template of an
    entry the base does not have (default: cls()). An array becomes a tuple where the base holds
    a tuple.
    """
    if data is None:
        return base
    cls = type(base)
    if not isinstance(data, Mapping):
        label = key_label(table) or "the config"
        raise error_at(error, label, f"expected a table, found {found(data)}")
    hints = _hints(cls)
    names = sorted(f.name for f in dataclasses.fields(cls))  # type: ignore[arg-type]
    unknown = sorted((k for k in data if k not in hints), key=str)
    if unknown:
        if all(_dataclass_of(hints[n]) for n in names):
            tables = ", ".join(names)
            raise error_at(
                error, key_label(table), f"unknown table [{unknown[0]}] (tables: {tables})"
            )
        raise error_at(error, key_label(table), f"unknown keys {unknown} (known: {names})")
    changes: dict[str, Any] = {}
    for key, value in data.items():
        changes[key] = _merge_value(
            getattr(base, key), value, hints[key], table, key, error, new_entry
        )
    try:
        return dataclasses.replace(base, **changes)  # type: ignore[type-var]
    except (TypeError, ValueError) as exc:
        if getattr(exc, "config_key", None) is not None:
            raise
        # A dataclass's own check (a range, a name): name the key it is about when the message
        # names exactly one of the keys given, with the value found.
        named = [k for k in data if re.search(rf"\b{re.escape(str(k))}\b", str(exc))]
        if len(named) == 1:
            value = data[named[0]]
            message = str(exc) if repr(value) in str(exc) else f"{exc} (found {found(value)})"
            raise error_at(error, key_label(table, named[0]), message) from exc
        raise error_at(error, key_label(table), str(exc)) from exc


def _merge_value(
    current: Any,
    value: Any,
    hint: Any,
    table: str,
    key: str,
    error: type[Exception],
    new_entry: Callable[[type, str], Any] | None,
) -> Any:
    at = f"{table}.{key}" if table else key
    nested = _dataclass_of(hint)
    if nested is not None and isinstance(value, Mapping):
        template = current if isinstance(current, nested) else nested()
        return merge(template, value, at, error=error, new_entry=new_entry)
    if nested is not None and isinstance(value, nested):
        return value  # built in Python: its constructor checked it
    if get_origin(hint) is dict and isinstance(current, dict) and isinstance(value, Mapping):
        entry_class = _dataclass_of(get_args(hint)[1]) if get_args(hint) else None
        out = dict(current)
        for name, entry in value.items():
            if entry_class is not None and isinstance(entry, Mapping):
                template = current.get(name)
                if not isinstance(template, entry_class):
                    template = new_entry(entry_class, name) if new_entry else entry_class()
                out[name] = merge(template, entry, f"{at}.{name}", error=error, new_entry=new_entry)
            else:
                check_value(
                    entry, get_args(hint)[1] if get_args(hint) else Any,
                    key_label(at, str(name)), error,
                )  # fmt: skip
                out[name] = entry
        return out
    check_value(value, hint, key_label(table, key), error)
    if isinstance(current, tuple) and isinstance(value, list):
        return tuple(value)
    return value
