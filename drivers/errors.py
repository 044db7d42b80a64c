"""The errors that drivers raise for bad bytes and bad configuration; everything else is a link
failure (OSError)."""

from __future__ import annotations

from snrmon.config_schema import SchemaError, toml_repr  # noqa: F401  (re-exported)


class ParseError(ValueError):
    """A line or message that does not decode; names the device and shows the offending bytes."""


class ChecksumError(ParseError):
    """A sentence whose checksum does not match its contents."""


class ConfigError(SchemaError):
    """A configuration that cannot work (unknown kind, wrong type, bad URL, bad baud rate); the
    message names the table, the key, the value and what was expected
    (:meth:`snrmon.config_schema.SchemaError.expected`)."""


class MissingDependencyError(ImportError):
    """An optional backend whose package is not installed; the message says what to install."""
