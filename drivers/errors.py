"""The errors that drivers raise for bad bytes; everything else is a link failure (OSError)."""


class ParseError(ValueError):
    """A line or message that does not decode; names the device and shows the offending bytes."""


class ChecksumError(ParseError):
    """A sentence whose checksum does not match its contents."""


class ConfigError(ValueError):
    """A device configuration that cannot work (unknown kind, bad URL, bad baud rate); the
    message names the table key and the value."""


class MissingDependencyError(ImportError):
    """An optional backend whose package is not installed; the message says what to install."""
