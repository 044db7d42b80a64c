"""ASTECH LDM41/42 and Jenoptik LDM-family ASCII rangefinders -> RangeReading.

Commands are two letters and CR LF (ASTECH manual v1.6 sec. 8): ``DT`` continuous tracking,
``DM`` single measurement, ``SD d|h|s`` output format, ``SA n`` averaging; ESC stops tracking.
Output lines carry no checksum, so each is validated by its pattern:

* ``SD d``: ``004.996`` (metres)
* ``SD h``: `` 001384`` (hex millimetres)
* ``SD s``: ``004.996 000985`` (metres and signal quality 0..1024)
* ``E15`` (and other ``Exx``): no target / weak return (``E15``), other device errors.
"""

from __future__ import annotations

import re

from snrmon.drivers.errors import ParseError
from snrmon.drivers.rangefinder.reading import RangeReading, RangeStatus
from snrmon.drivers.serialport import SerialLineDevice

_DEC = re.compile(r"^(-?\d{1,6}\.\d{1,4})(?: +(\d{1,6}))?$")
_HEX = re.compile(r"^ ?([0-9A-Fa-f]{6,8})$")
_ERR = re.compile(r"^E(\d\d)$")
NO_TARGET_CODES = frozenset({"15"})
OUTPUT_FORMATS = ("d", "h", "s")


def parse_ldm(line: bytes | str, t_host_ns: int) -> RangeReading | None:
    """Decode one LDM line; ``None`` for an empty line or the ``?`` of a refused command.

    Raises:
        ParseError: a line that matches none of the documented patterns.
    """
    if isinstance(line, bytes):
        try:
            line = line.decode("ascii")
        except UnicodeDecodeError:
            raise ParseError(f"LDM: non-ASCII bytes in {line[:60]!r}") from None
    text = line.rstrip("\r\n")
    if text.strip() in ("", "?"):
        return None
    m = _ERR.match(text.strip())
    if m:
        status = RangeStatus.NO_TARGET if m[1] in NO_TARGET_CODES else RangeStatus.ERROR
        return RangeReading(t_host_ns, None, status=status, quality=None, raw=text)
    m = _DEC.match(text.strip())
    if m:
        quality = int(m[2]) if m[2] is not None else None
        if quality is not None and quality > 1024:
            raise ParseError(f"LDM: signal quality {quality} above 1024 in {text[:40]!r}")
        return RangeReading(t_host_ns, float(m[1]), quality=quality, raw=text)
    m = _HEX.match(text)
    if m:
        value = int(m[1], 16)
        bits = 4 * len(m[1])
        if value >= 1 << (bits - 1):  # the manual's two's complement for negative values
            value -= 1 << bits
        return RangeReading(t_host_ns, value / 1000.0, raw=text)
    raise ParseError(f"LDM: line {text[:40]!r} matches no output format")


class LdmDevice(SerialLineDevice[RangeReading]):
    """A continuous-tracking LDM rangefinder.

    Args:
        url: path or pyserial URL.
        baudrate: default 9600 (the LDM factory setting).
        output_format: ``"s"`` (distance and signal quality, default), ``"d"`` or ``"h"``; sent
            as ``SD`` on every (re)open.
        averaging: ``SA n`` (1..20) sent on open when given.
        track: send ``DT`` on every (re)open, so a power-cycled unit resumes tracking.
        name: the device's name; **kwargs go to :class:`SerialLineDevice`.
    """

    def __init__(
        self,
        url: str,
        *,
        baudrate: int = 9600,
        output_format: str = "s",
        averaging: int | None = None,
        track: bool = True,
        name: str = "lrf",
        **kwargs,
    ) -> None:
        if output_format not in OUTPUT_FORMATS:
            raise ValueError(f"{name}: output_format must be one of d, h, s; got {output_format!r}")
        if averaging is not None and not 1 <= averaging <= 20:
            raise ValueError(f"{name}: averaging must be 1..20, got {averaging}")
        super().__init__(name, url, baudrate=baudrate, **kwargs)
        self.output_format = output_format
        self.averaging = averaging
        self.track = track

    def measure_once(self) -> None:
        """One measurement (``DM``)."""
        self.send("DM")

    def start_tracking(self) -> None:
        self.send("DT")

    def stop_tracking(self) -> None:
        """ESC stops continuous output on the LDM41/42."""
        self.send("\x1b")

    def _on_connected(self) -> None:
        self.send(f"SD {self.output_format}")
        if self.averaging is not None:
            self.send(f"SA {self.averaging}")
        if self.track:
            self.send("DT")

    def _parse_line(self, line: bytes, t_host_ns: int) -> list[RangeReading]:
        reading = parse_ldm(line, t_host_ns)
        return [] if reading is None else [reading]
