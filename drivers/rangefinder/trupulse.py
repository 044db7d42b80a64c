"""Laser Technology TruPulse 200/360/360R (CR400 ``$PLTIT`` sentences) -> RangeReading.

Sentence (TruPulse 200 manual sec. 8; notes 1.2)::

    $PLTIT,HV,<HD>,<u>,<AZ>,D,<INC>,D,<SD>,<u>*hh

HD horizontal distance, AZ azimuth (the 200 sends 0.00), INC inclination, SD slope distance;
units F (feet), Y (yards) or M. With two decimals the last digit is not a distance digit but the
target quality (0 high, 1 low). Empty distance fields mean an inclination-only shot; ``$E01`` is
a shot with no target. The 360R takes remote commands (``$GO`` fire, ``$ST`` stop, ``$MM,0``
horizontal-vector mode, ``$DU,0`` metres), each acknowledged with ``$OK``.
"""

from __future__ import annotations

import re

from snrmon.drivers.checksum import xor_checksum
from snrmon.drivers.errors import ChecksumError, ParseError
from snrmon.drivers.rangefinder.reading import RangeReading, RangeStatus
from snrmon.drivers.serialport import SerialLineDevice

UNIT_TO_M = {"M": 1.0, "F": 0.3048, "Y": 0.9144}
_VALUE = re.compile(r"^-?\d+\.(\d{1,2})$")
_ERROR = re.compile(r"^\$E(\d\d)$")


def _value(text: str, what: str) -> tuple[float, int | None]:
    """A field's value and the quality digit it carries (None when it has one decimal)."""
    m = _VALUE.match(text)
    if not m:
        raise ParseError(f"TruPulse: {what} {text!r} is not a decimal number")
    if len(m[1]) == 2:
        return float(text[:-1]), int(text[-1])
    return float(text), None


def parse_trupulse(line: bytes | str, t_host_ns: int) -> RangeReading | None:
    """Decode one TruPulse line.

    Returns a reading for ``$PLTIT,HV`` and ``$Exx``, ``None`` for acknowledgements and other
    replies (``$OK``, ``$PLTIT,ID``, ``$BV``, height or missing-line results).

    Raises:
        ChecksumError: a ``*hh`` that does not match.
        ParseError: anything else malformed.
    """
    if isinstance(line, bytes):
        try:
            line = line.decode("ascii")
        except UnicodeDecodeError:
            raise ParseError(f"TruPulse: non-ASCII bytes in {line[:60]!r}") from None
    text = line.rstrip("\r\n")
    if not text.startswith("$") or not text.isprintable():
        raise ParseError(f"TruPulse: not a sentence: {text[:60]!r}")
    m = _ERROR.match(text)
    if m:
        status = RangeStatus.NO_TARGET if m[1] == "01" else RangeStatus.ERROR
        return RangeReading(t_host_ns, None, status=status, raw=text)
    star = text.rfind("*")
    if star < 0:
        if text == "$OK" or text.startswith("$BV,"):
            return None
        raise ParseError(f"TruPulse: no checksum in {text[:60]!r}")
    body, given = text[1:star], text[star + 1 :]
    if len(given) != 2 or any(c not in "0123456789ABCDEFabcdef" for c in given):
        raise ChecksumError(f"TruPulse: malformed checksum {given!r} in {text[:60]!r}")
    if int(given, 16) != xor_checksum(body):
        raise ChecksumError(
            f"TruPulse: checksum {given} != computed {xor_checksum(body):02X} in {text[:60]!r}"
        )
    f = body.split(",")
    if f[0] != "PLTIT" or len(f) < 2:
        raise ParseError(f"TruPulse: unknown sentence {text[:60]!r}")
    if f[1] != "HV":
        return None  # ID, HT, ML...: valid, but not a range to the target
    if len(f) != 10:
        raise ParseError(f"TruPulse: HV needs 8 fields, got {len(f) - 2} in {text[:60]!r}")
    hd, hd_u, az, az_u, inc, inc_u, sd, sd_u = f[2:]
    if az_u != "D" or inc_u != "D":
        raise ParseError(f"TruPulse: angle units {az_u!r},{inc_u!r} are not D in {text[:60]!r}")
    # The quality digit is documented for distances; angles are taken as written.
    azimuth = float(az) if az and _VALUE.match(az) else None
    inclination = float(inc) if inc and _VALUE.match(inc) else None
    if (az and azimuth is None) or (inc and inclination is None):
        raise ParseError(f"TruPulse: angle {az!r} or {inc!r} is not a decimal number")
    if azimuth is not None and not 0.0 <= azimuth < 360.0001:
        raise ParseError(f"TruPulse: azimuth {azimuth} outside 0..360")
    if inclination is not None and not -90.0 <= inclination <= 90.0:
        raise ParseError(f"TruPulse: inclination {inclination} outside -90..90")

    def distance(v: str, u: str, what: str) -> tuple[float | None, int | None]:
        if v == "" and u == "":
            return None, None
        if u not in UNIT_TO_M:
            raise ParseError(f"TruPulse: {what} unit {u!r} is not F, Y or M in {text[:60]!r}")
        value, q = _value(v, what)
        if value < 0:
            raise ParseError(f"TruPulse: negative {what} {v!r}")
        return value * UNIT_TO_M[u], q

    horizontal, _ = distance(hd, hd_u, "horizontal distance")
    slope, quality = distance(sd, sd_u, "slope distance")
    if slope is None:  # inclination-only shot: no range to report
        return RangeReading(
            t_host_ns, None, RangeStatus.NO_TARGET, horizontal, azimuth, inclination, None, text
        )
    return RangeReading(
        t_host_ns, slope, RangeStatus.OK, horizontal, azimuth, inclination, quality, text
    )


class TruPulseDevice(SerialLineDevice[RangeReading]):
    """A TruPulse on a serial or Bluetooth-SPP port.

    Args:
        url: path or pyserial URL.
        baudrate: default 4800 (the CR400 follows NMEA's data rate).
        remote: a 360R that takes commands: on every (re)open send ``$MM,0`` (horizontal
            vector mode) and ``$DU,0`` (metres) so readings come back the same way every time.
        name: the device's name; **kwargs go to :class:`SerialLineDevice` (the watchdog is off
            by default: a hand-held rangefinder speaks only when fired).
    """

    def __init__(
        self,
        url: str,
        *,
        baudrate: int = 4800,
        remote: bool = False,
        name: str = "lrf",
        **kwargs,
    ) -> None:
        kwargs.setdefault("stale_after_s", None)
        super().__init__(name, url, baudrate=baudrate, **kwargs)
        self.remote = remote
        self.acks = 0

    def fire(self) -> None:
        """Fire one shot (360R ``$GO``); the reading arrives through the subscribers."""
        self.send("$GO")

    def stop(self) -> None:
        """Stop a measurement in progress (360R ``$ST``)."""
        self.send("$ST")

    def _on_connected(self) -> None:
        if self.remote:
            self.send("$MM,0")
            self.send("$DU,0")

    def _parse_line(self, line: bytes, t_host_ns: int) -> list[RangeReading]:
        reading = parse_trupulse(line, t_host_ns)
        if reading is None:
            self.acks += 1
            self._mark_alive()
            return []
        return [reading]
