"""The common clock: every device thread stamps with ``time.monotonic_ns()``; this maps it to UTC.

The monotonic clock never jumps, so frames, range readings and GPS fixes from different threads
can be ordered and interpolated on it. UTC for the record comes from a reference pair
(monotonic ns, UTC ns) taken from the host clock at start and, once the GPS has a fix, from the
receiver's time (the host clock of a field laptop is often minutes off).
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from datetime import UTC, datetime


@dataclass(frozen=True, slots=True)
class ClockReference:
    """One pairing of the monotonic clock with UTC; ``source`` is "host" or "gps"."""

    monotonic_ns: int
    utc_ns: int
    source: str


class ClockMap:
    """Maps ``time.monotonic_ns()`` values to UTC nanoseconds since the Unix epoch."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._ref = ClockReference(time.monotonic_ns(), time.time_ns(), "host")

    @property
    def reference(self) -> ClockReference:
        with self._lock:
            return self._ref

    def update_from_gps(self, t_host_ns: int, utc: datetime) -> None:
        """Re-anchor UTC on a GPS fix's receiver time (received at ``t_host_ns``)."""
        utc_ns = int(utc.replace(tzinfo=utc.tzinfo or UTC).timestamp() * 1e9)
        with self._lock:
            self._ref = ClockReference(t_host_ns, utc_ns, "gps")

    def utc_ns(self, monotonic_ns: int) -> int:
        """UTC ns since the epoch for a monotonic timestamp."""
        ref = self.reference
        return ref.utc_ns + (monotonic_ns - ref.monotonic_ns)

    def utc(self, monotonic_ns: int) -> datetime:
        """UTC as an aware datetime for a monotonic timestamp."""
        return datetime.fromtimestamp(self.utc_ns(monotonic_ns) / 1e9, tz=UTC)
