"""The session's range sources: the GPS receiver and the laser rangefinder (either may be
absent), opened from the ``[gps]`` and ``[lrf]`` tables of the session config
(:mod:`snrmon.drivers.config`), and their latest readings for the console.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from dataclasses import dataclass

from snrmon.drivers.config import DeviceSettings
from snrmon.drivers.device import Device
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.rangefinder.reading import RangeReading

DEFAULT_START_TIMEOUT_S = 10.0
"""How long (s) each device the config names has, from the session's start, to deliver its
first reading (a frame, a sentence, a range); ``start_timeout_s`` in its table overrides it."""


@dataclass(frozen=True, slots=True)
class SerialDeviceSettings:
    """A ``[gps]`` or ``[lrf]`` table of the session config, as the session uses it: which
    table it is, how long its device has to give a first reading, and the table's checked
    settings (:class:`snrmon.drivers.config.DeviceSettings`)."""

    table_name: str  # "gps" or "lrf": the device's name unless the table names it
    start_timeout_s: float
    settings: DeviceSettings

    @classmethod
    def of(cls, settings: DeviceSettings | None, table_name: str) -> SerialDeviceSettings | None:
        """The session's settings of a config table (None: the config has none)."""
        if settings is None:
            return None
        timeout = settings.start_timeout_s
        return cls(table_name, DEFAULT_START_TIMEOUT_S if timeout is None else timeout, settings)

    def device(self) -> Device:
        """The device the table describes (a ConfigError naming the key and value if not)."""
        return self.settings.device(self.table_name)


class RangeDevices:
    """The GPS and rangefinder devices (given, or opened from their settings), the settings
    they came with, and the latest fix and range reading each gave."""

    def __init__(
        self,
        gps_settings: SerialDeviceSettings | None,
        lrf_settings: SerialDeviceSettings | None,
        *,
        gps: Device | None = None,
        lrf: Device | None = None,
    ) -> None:
        self.gps_settings = gps_settings
        self.lrf_settings = lrf_settings
        self.gps = gps if gps is not None or gps_settings is None else gps_settings.device()
        self.lrf = lrf if lrf is not None or lrf_settings is None else lrf_settings.device()
        self._lock = threading.Lock()
        self._last_fix: GpsFix | None = None
        self._last_range: RangeReading | None = None

    def present(self) -> Iterator[Device]:
        """The GPS, then the rangefinder, those the session has."""
        yield from (d for d in (self.gps, self.lrf) if d is not None)

    def start_timeouts_s(self) -> dict[str, float]:
        """Each device's start-up timeout (s), by its name."""
        out = {}
        for dev, settings in ((self.gps, self.gps_settings), (self.lrf, self.lrf_settings)):
            if dev is not None:
                out[dev.name] = (
                    settings.start_timeout_s if settings is not None else DEFAULT_START_TIMEOUT_S
                )
        return out

    def open(self) -> None:
        for dev in self.present():
            dev.open()

    def close(self) -> None:
        for dev in self.present():
            dev.close()

    def fix_taken(self, fix: GpsFix) -> None:
        with self._lock:
            self._last_fix = fix

    def range_taken(self, reading: RangeReading) -> None:
        with self._lock:
            self._last_range = reading

    def latest(self) -> tuple[RangeReading | None, GpsFix | None]:
        """The latest range reading and fix (None: none yet)."""
        with self._lock:
            return self._last_range, self._last_fix
