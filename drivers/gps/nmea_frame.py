"""NMEA 0183 framing: ``$`` + address + fields + ``*hh``, verified into a :class:`Sentence`.

Rules (gpsd ``www/NMEA.adoc``): ``$`` + address (talker GP/GN/GL/GA/GB/BD/QZ + type, or ``P`` +
maker for proprietary) + ``,`` fields + ``*hh`` where hh is the XOR of the bytes between ``$`` and
``*``. The decoding of the fields is :mod:`snrmon.drivers.gps.nmea`.
"""

from __future__ import annotations

import re
from collections.abc import Collection
from dataclasses import dataclass

from snrmon.drivers.checksum import xor_checksum
from snrmon.drivers.errors import ChecksumError, ParseError

TALKERS = frozenset({"GP", "GN", "GL", "GA", "GB", "BD", "QZ", "GI"})
POSITION_TYPES = frozenset({"GGA", "RMC"})
KNOWN_TYPES = frozenset({"GGA", "RMC", "GSA", "VTG", "ZDA", "GSV", "GLL", "GST", "TXT"})
_ADDRESS = re.compile(r"^[A-Z][A-Z0-9]{1,15}$")


nmea_checksum = xor_checksum  # the name NMEA users look for


@dataclass(frozen=True, slots=True)
class Sentence:
    """One framed sentence: ``talker`` ("P" for proprietary), ``kind`` (GGA, or the maker's
    code for proprietary), the fields after the address, and whether a checksum was present."""

    talker: str
    kind: str
    fields: tuple[str, ...]
    has_checksum: bool
    raw: str

    @property
    def address(self) -> str:
        return self.talker + self.kind

    @property
    def proprietary(self) -> bool:
        return self.talker == "P"


def parse_sentence(
    line: bytes | str, *, allow_no_checksum: bool | Collection[str] = False
) -> Sentence:
    """Frame and verify one line.

    Args:
        line: the line with or without its CR/LF.
        allow_no_checksum: ``True`` accepts any sentence without ``*hh``; a collection of
            addresses (``{"POLYN", "STI"}``) accepts only those; ``False`` accepts none.

    Raises:
        ChecksumError: the checksum is present and wrong (or not two hex digits).
        ParseError: anything else that is not a sentence.
    """
    if isinstance(line, bytes):
        try:
            text = line.decode("ascii")
        except UnicodeDecodeError:
            raise ParseError(f"NMEA: non-ASCII bytes in {line[:60]!r}") from None
    else:
        text = line
    text = text.rstrip("\r\n")
    if not text.startswith("$"):
        raise ParseError(f"NMEA: no '$' at start of {text[:60]!r}")
    if not text.isprintable():
        raise ParseError(f"NMEA: control characters in {text[:60]!r}")
    star = text.rfind("*")
    if star >= 0:
        body, given = text[1:star], text[star + 1 :]
        if len(given) != 2 or any(c not in "0123456789ABCDEFabcdef" for c in given):
            raise ChecksumError(f"NMEA: malformed checksum {given!r} in {text[:60]!r}")
        if int(given, 16) != nmea_checksum(body):
            raise ChecksumError(
                f"NMEA: checksum {given} != computed {nmea_checksum(body):02X} in {text[:60]!r}"
            )
    else:
        body = text[1:]
    parts = body.split(",")
    address = parts[0]
    if not _ADDRESS.match(address):
        raise ParseError(f"NMEA: bad address {address[:20]!r} in {text[:60]!r}")
    if star < 0:
        allowed = allow_no_checksum is True or (
            not isinstance(allow_no_checksum, bool) and address in allow_no_checksum
        )
        if not allowed:
            raise ParseError(f"NMEA: no checksum in {text[:60]!r}")
    if address.startswith("P"):
        talker, kind = "P", address[1:]
    elif len(address) == 5 or (len(address) == 6 and address[:2] in TALKERS):
        # a talker and a type: GPGGA, or a Unicore high-precision type (GNGGAH, GNRMCH)
        talker, kind = address[:2], address[2:]
    else:  # e.g. SkyTraq's loader messages "$STI,...": framed, but no talker to decode
        talker, kind = "", address
    return Sentence(talker, kind, tuple(parts[1:]), star >= 0, text)
