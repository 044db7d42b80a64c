"""The errors that drivers raise for bad bytes; everything else is a link failure (OSError)."""


class ParseError(ValueError):
    """A line or message that does not decode; names the device and shows the offending bytes."""


class ChecksumError(ParseError):
    """A sentence whose checksum does not match its contents."""
