"""MAVLink telemetry backend (optional extra ``pymavlink``): GLOBAL_POSITION_INT -> GpsFix.

``GLOBAL_POSITION_INT`` (id 33) gives ``lat``/``lon`` in degE7 and ``alt`` (MSL) in mm;
``GPS_RAW_INT`` (id 24) gives ``fix_type``, ``satellites_visible``, ``eph`` (HDOP x 100) and
``time_usec``; its fix type and satellites are attached to the next position. pymavlink is
imported only when the device connects, so the rest of snrmon works without it.
"""

from __future__ import annotations

import importlib
import time
from datetime import UTC, datetime

from snrmon.drivers.device import Device
from snrmon.drivers.errors import MissingDependencyError
from snrmon.drivers.gps.fix import GpsFix

# MAVLink GPS_FIX_TYPE -> GGA fix quality
FIX_TYPE_TO_QUALITY = {0: 0, 1: 0, 2: 1, 3: 1, 4: 2, 5: 5, 6: 4, 7: 1, 8: 1}


def mavutil():
    """pymavlink's ``mavutil`` module, or a clear error naming what to install."""
    try:
        return importlib.import_module("pymavlink.mavutil")
    except ImportError:
        raise MissingDependencyError(
            "MAVLink telemetry needs pymavlink: pip install pymavlink (or snrmon[mavlink])"
        ) from None


class MavlinkGpsDevice(Device[GpsFix]):
    """Positions from a drone's MAVLink stream.

    Args:
        url: a pymavlink connection string: ``udpin:0.0.0.0:14550``, ``udpout:host:port``,
            ``tcp:host:port`` or a serial path (with ``baudrate``).
        baudrate: for serial links.
        name: the device's name; **kwargs go to :class:`snrmon.drivers.device.Device`.
    """

    def __init__(self, url: str, *, baudrate: int = 57600, name: str = "gps", **kwargs) -> None:
        super().__init__(name, **kwargs)
        if not url:
            raise ValueError(f"{name}: MAVLink connection string is empty")
        self.url, self.baudrate = url, baudrate
        self._conn = None
        self._raw = None

    def _connect(self) -> None:
        try:
            mu = mavutil()
        except MissingDependencyError as exc:
            raise ValueError(str(exc)) from None  # not retried: installing takes a person
        self._conn = mu.mavlink_connection(self.url, baud=self.baudrate, autoreconnect=False)

    def _disconnect(self) -> None:
        conn, self._conn = self._conn, None
        if conn is not None:
            conn.close()

    def _read(self) -> list[GpsFix]:
        if self._conn is None:
            raise OSError(f"{self.name}: not connected to {self.url}")
        msg = self._conn.recv_match(
            type=["GLOBAL_POSITION_INT", "GPS_RAW_INT"], blocking=True, timeout=0.1
        )
        if msg is None:
            return []
        t_host_ns = time.monotonic_ns()
        if msg.get_type() == "GPS_RAW_INT":
            self._raw = msg
            self._mark_alive()
            return []
        raw = self._raw
        quality = FIX_TYPE_TO_QUALITY.get(raw.fix_type, 1) if raw is not None else 1
        utc = None
        if raw is not None and raw.time_usec > 1_000_000_000_000_000:  # Unix time, not boot time
            utc = datetime.fromtimestamp(raw.time_usec / 1e6, tz=UTC)
        return [
            GpsFix(
                t_host_ns=t_host_ns,
                utc=utc,
                lat_deg=msg.lat / 1e7,
                lon_deg=msg.lon / 1e7,
                alt_msl_m=msg.alt / 1000.0,
                alt_ellipsoid_m=(
                    raw.alt_ellipsoid / 1000.0
                    if raw is not None and getattr(raw, "alt_ellipsoid", 0)
                    else None
                ),
                fix_quality=quality,
                sats=raw.satellites_visible if raw is not None else None,
                hdop=raw.eph / 100.0 if raw is not None and raw.eph != 65535 else None,
                raw=str(msg),
            )
        ]
