"""The one declarative schema of snrmon's TOML files: each key declared once, with what a valid
value is (in words and as a check), its default and its unit in its name.

The session config (:mod:`snrmon.acquisition.config`), the device tables
(:mod:`snrmon.drivers.config`) and the sensor, target and atmosphere presets
(:mod:`snrmon.model.presets`) declare their tables as ``{key: Key}``; from those declarations
come the one check (:func:`checked`: an unknown key, a missing required one or a value of the
wrong type or range is one :class:`SchemaError` naming the table, the key, the value as TOML
spells it and what was expected), the template an operator starts from (:func:`template`) and
the key tables of the docs (:func:`markdown_table`, compared with the docs by a test).

This module imports nothing of snrmon's, so every layer can declare its tables with it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

NO_DEFAULT = object()
"""A key whose absence means "not given" (the program decides), rather than a value."""


class SchemaError(ValueError):
    """A TOML table that does not fit its schema; the message names the table, the key, the
    value and what was expected."""

    @classmethod
    def expected(cls, table: str, key: str, value: object, expected: str) -> SchemaError:
        """``[table] key = value: expected ...``, the value written as in the TOML file."""
        return cls(f"[{table}] {key} = {toml_repr(value)}: expected {expected}")


def toml_repr(value: object) -> str:
    """A value as a TOML file spells it (``"north"``, ``true``, ``[1, 2]``), for messages."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_repr(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {toml_repr(v)}" for k, v in value.items()) + " }"
    return repr(value)


@dataclass(frozen=True)
class Key:
    """One key of a table: what a valid value is, in words (``expected``, also the docs' and the
    template's text) and as a predicate (``check``); ``convert`` turns a valid TOML value into
    the program's (a pair into a tuple of floats); ``default`` is the value used when the key is
    absent (:data:`NO_DEFAULT`: none; the program decides, or the key is ``required``);
    ``example`` is what the template writes for a key without a default."""

    expected: str
    check: Callable[[Any], bool]
    required: bool = False
    default: Any = NO_DEFAULT
    example: Any = NO_DEFAULT
    convert: Callable[[Any], Any] | None = None


Table = Mapping[str, Key]


# ------------------------------------------------------------------------ checks of one value
def is_number(v: Any) -> bool:
    """A finite TOML integer or float (not a boolean)."""
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def is_integer(v: Any) -> bool:
    """A TOML integer (not a boolean)."""
    return isinstance(v, int) and not isinstance(v, bool)


def is_text(v: Any) -> bool:
    """A non-empty string."""
    return isinstance(v, str) and v != ""


def is_string(v: Any) -> bool:
    """Any string, the empty one too."""
    return isinstance(v, str)


def is_bool(v: Any) -> bool:
    """true or false."""
    return isinstance(v, bool)


def is_table(v: Any) -> bool:
    """A TOML table."""
    return isinstance(v, dict)


def between(lo: float, hi: float) -> Callable[[Any], bool]:
    """A number in [lo, hi]."""
    return lambda v: is_number(v) and lo <= v <= hi


def above(lo: float) -> Callable[[Any], bool]:
    """A number > lo."""
    return lambda v: is_number(v) and v > lo


def at_least(lo: float) -> Callable[[Any], bool]:
    """A number >= lo."""
    return lambda v: is_number(v) and v >= lo


def fraction(v: Any) -> bool:
    """A number in (0, 1]."""
    return is_number(v) and 0 < v <= 1


def int_at_least(minimum: int) -> Callable[[Any], bool]:
    """An integer >= minimum."""
    return lambda v: is_integer(v) and v >= minimum


def odd_int(minimum: int) -> Callable[[Any], bool]:
    """An odd integer >= minimum."""
    return lambda v: is_integer(v) and v >= minimum and v % 2 == 1


def one_of(choices: Iterable[Any]) -> Callable[[Any], bool]:
    """One of ``choices`` (compared as given: "mwir" is not "MWIR")."""
    known = tuple(choices)
    return lambda v: not isinstance(v, bool) and isinstance(v, str | int) and v in known


def list_of(item: Callable[[Any], bool], lengths: Iterable[int] | None = None) -> Callable:
    """A non-empty list whose every item passes ``item`` (of one of ``lengths``, if given)."""
    allowed = None if lengths is None else tuple(lengths)

    def check(v: Any) -> bool:
        if not isinstance(v, list) or not v or (allowed is not None and len(v) not in allowed):
            return False
        return all(item(x) for x in v)

    return check


def any_of(*checks: Callable[[Any], bool]) -> Callable[[Any], bool]:
    """A value that passes one of ``checks``."""
    return lambda v: any(c(v) for c in checks)


# ------------------------------------------------------------------------ a table
def checked(
    table: Any,
    keys: Table,
    name: str,
    *,
    error: type[SchemaError] = SchemaError,
    defaults: bool = False,
) -> dict[str, Any]:
    """``table``'s values after checking every key against ``keys`` (converted where the key
    says how; with ``defaults`` the absent keys that have one filled in): an unknown key, a
    missing required one or a value of the wrong type or range is one ``error`` naming the
    table (``name``), the key, the value and what was expected."""
    if not isinstance(table, dict):
        raise error(f"[{name}] = {toml_repr(table)}: expected a table")
    unknown = sorted(set(table) - set(keys))
    if unknown:
        raise error(f"[{name}]: unknown key {unknown[0]!r} (known: {', '.join(sorted(keys))})")
    out: dict[str, Any] = {}
    for key, spec in keys.items():
        if key not in table:
            if spec.required:
                raise error(f"[{name}] is missing {key!r}: expected {spec.expected}")
            if defaults and spec.default is not NO_DEFAULT:
                out[key] = spec.default
            continue
        value = table[key]
        if not spec.check(value):
            raise error.expected(name, key, value, spec.expected)
        out[key] = spec.convert(value) if spec.convert is not None else value
    return out


def default_of(keys: Table, key: str) -> Any:
    """The declared default of ``key`` (KeyError when it has none)."""
    value = keys[key].default
    if value is NO_DEFAULT:
        raise KeyError(f"{key!r} has no default")
    return value


# ------------------------------------------------------------------------ template and docs
def _shown(spec: Key) -> str:
    if spec.default is not NO_DEFAULT:
        return "(none)" if spec.default is None else toml_repr(spec.default)
    if spec.required:
        return "required"
    return "-"


def markdown_table(keys: Table) -> str:
    """The docs' table of a TOML table's keys: key, what is expected, default."""
    lines = ["| key | expected | default |", "|---|---|---|"]
    for key, spec in keys.items():
        expected = spec.expected.replace("|", "\\|")
        lines.append(f"| `{key}` | {expected} | {_shown(spec)} |")
    return "\n".join(lines)


def template(
    tables: Mapping[str, Table], active: Iterable[str] = ("",), skip: Iterable[str] = ()
) -> str:
    """A TOML document naming every key of every table (the top level under ``""``), each with
    what it expects as its comment. In the ``active`` tables a key with an example is set to it
    and a key with a default is shown commented out with its default (so the file, as written,
    means the defaults); every other table is commented out whole, its examples shown, to be
    filled in. ``skip`` names keys left out (``table.key``: old spellings)."""
    out: list[str] = []
    on, skipped = set(active), set(skip)
    for name, keys in tables.items():
        live = name in on
        if name:
            out.append(f"\n{'' if live else '# '}[{name}]")
        for key, spec in keys.items():
            if f"{name}.{key}" in skipped:
                continue
            if live and spec.example is not NO_DEFAULT:
                out.append(f"{key} = {toml_repr(spec.example)}   # {spec.expected}")
                continue
            shown = spec.example if spec.example is not NO_DEFAULT else spec.default
            value = "" if shown is NO_DEFAULT or shown is None else toml_repr(shown)
            out.append(f"# {key} = {value}   # {spec.expected}".replace(" =    #", " =   #"))
    return "\n".join(out).lstrip("\n") + "\n"


def dataclass_default(cls: type, name: str) -> Any:
    """The default a dataclass declares for its field ``name`` (the one declaration of a
    setting's default: the schema's key reads it from the dataclass that holds the setting)."""
    import dataclasses

    for f in dataclasses.fields(cls):
        if f.name == name:
            if f.default is not dataclasses.MISSING:
                return f.default
            if f.default_factory is not dataclasses.MISSING:
                return f.default_factory()
            return NO_DEFAULT
    raise KeyError(f"{cls.__name__} has no field {name!r}")
