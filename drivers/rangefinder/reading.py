"""The reading that every laser rangefinder driver delivers."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum


class RangeStatus(StrEnum):
    """Outcome of one rangefinder shot."""

    OK = "ok"
    NO_TARGET = "no_target"
    ERROR = "error"


@dataclass(frozen=True, slots=True)
class RangeReading:
    """One rangefinder reading, always converted to metres.

    Attributes:
        t_host_ns: ``time.monotonic_ns()`` when the line was received.
        range_m: slant range in metres, ``None`` when the shot gave none (no target, or an
            inclination-only shot).
        status: ok / no_target / error.
        horizontal_m: horizontal distance in metres where the device gives it.
        azimuth_deg: azimuth in degrees clockwise from north where the device gives it.
        inclination_deg: inclination in degrees above the horizon where the device gives it.
        quality: device-specific quality (TruPulse: 0 high, 1 low; LDM: signal strength).
        raw: the line as received, without its line ending.
    """

    t_host_ns: int
    range_m: float | None
    status: RangeStatus = RangeStatus.OK
    horizontal_m: float | None = None
    azimuth_deg: float | None = None
    inclination_deg: float | None = None
    quality: int | None = None
    raw: str = ""
