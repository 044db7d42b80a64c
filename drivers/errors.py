"""The errors that drivers raise for bad bytes and bad configuration; everything else is a link
failure (OSError)."""

from __future__ import annotations


class ParseError(ValueError):
    """A line or message that does not decode; names the device and shows the offending bytes."""


class ChecksumError(ParseError):
    """A sentence whose checksum does not match its contents."""


class ConfigError(ValueError):
    """A configuration that cannot work (unknown kind, wrong type, bad URL, bad baud rate); the
    message names the table, the key, the value and what was expected."""

    @classmethod
    def expected(cls, table: str, key: str, value: object, expected: str) -> ConfigError:
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


class MissingDependencyError(ImportError):
    """An optional backend whose package is not installed; the message says what to install."""
