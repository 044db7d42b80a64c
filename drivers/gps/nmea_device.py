"""NMEA 0183 GPS receiver on a serial link: lines -> :class:`snrmon.drivers.gps.fix.GpsFix`."""

from __future__ import annotations

from collections.abc import Collection

from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.gps.nmea import NmeaAssembler
from snrmon.drivers.serialport import SerialLineDevice


class NmeaGpsDevice(SerialLineDevice[GpsFix]):
    """A GPS receiver speaking NMEA 0183; one fix per GGA or RMC.

    Args:
        url: path or pyserial URL of the receiver's port.
        baudrate: 10 Hz GGA+RMC needs at least 19200 (38400 is comfortable); the NMEA standard
            rate 4800 carries about 1 Hz.
        allow_no_checksum: addresses (e.g. ``{"POLYN"}``) or ``True`` to accept sentences
            without ``*hh``; otherwise they are counted as parse errors.
        name: the device's name; **kwargs go to :class:`SerialLineDevice`.

    ``counts`` holds the proprietary and ignored sentence counts (not errors).
    """

    def __init__(
        self,
        url: str,
        *,
        baudrate: int = 9600,
        allow_no_checksum: bool | Collection[str] = False,
        name: str = "gps",
        **kwargs,
    ) -> None:
        super().__init__(name, url, baudrate=baudrate, **kwargs)
        self._assembler = NmeaAssembler(allow_no_checksum=allow_no_checksum)

    @property
    def counts(self):
        return self._assembler.counts

    def _parse_line(self, line: bytes, t_host_ns: int) -> list[GpsFix]:
        return self._assembler.feed(line, t_host_ns)
