"""The position fix that every GPS or telemetry driver delivers."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime


@dataclass(frozen=True, slots=True)
class GpsFix:
    """One position fix.

    Attributes:
        t_host_ns: ``time.monotonic_ns()`` when the sentence or message was received.
        utc: UTC time of the fix from the receiver (date from RMC/ZDA combined with the GGA
            time), ``None`` until the receiver has given a date.
        lat_deg, lon_deg: WGS-84 latitude and longitude in degrees (north and east positive).
        alt_msl_m: altitude above mean sea level in metres.
        alt_ellipsoid_m: height above the WGS-84 ellipsoid in metres where known.
        fix_quality: GGA fix quality (0 none, 1 GPS, 2 DGPS, 4 RTK fixed, 5 RTK float, ...).
        sats: satellites used.
        hdop: horizontal dilution of precision.
        raw: the sentence(s) or message this fix came from.
    """

    t_host_ns: int
    utc: datetime | None
    lat_deg: float | None
    lon_deg: float | None
    alt_msl_m: float | None = None
    alt_ellipsoid_m: float | None = None
    fix_quality: int = 0
    sats: int | None = None
    hdop: float | None = None
    raw: str = ""

    @property
    def has_fix(self) -> bool:
        """True when the receiver reports a position (quality > 0 and coordinates present)."""
        return self.fix_quality > 0 and self.lat_deg is not None and self.lon_deg is not None
