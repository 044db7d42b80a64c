"""The range at a frame's time: short histories of the rangefinder's readings and of the GPS
slant range from the site, on the common monotonic clock (docs/architecture.md, "Time"). A
frame's range is the rangefinder's while its reading is fresh, else the GPS slant range.
"""

from __future__ import annotations

import logging
import threading
from collections import deque

from snrmon.acquisition.geo.projection import Site, gps_slant_range_m
from snrmon.acquisition.streams.history import ScalarHistory
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.rangefinder.reading import RangeReading, RangeStatus

log = logging.getLogger(__name__)


class RangeHistory:
    """The rangefinder's ranges (fresh for ``lrf_fresh_s``) and the GPS slant ranges from
    ``site``, and the rule that picks a frame's range from them."""

    def __init__(self, site: Site | None, lrf_fresh_s: float) -> None:
        self.site = site
        self.lrf = ScalarHistory(max_gap_ns=int(lrf_fresh_s * 1e9))
        self._gps = ScalarHistory()
        # Fixes whose slant range nobody has needed yet (gps): with the stops a replay
        # recorded there is no detector to feed, and a frame reads the GPS range only when the
        # rangefinder's is stale, so most fixes never need one (pymap3d: 20 us a fix).
        self._fixes: deque[GpsFix] = deque()
        self._fixes_lock = threading.Lock()

    def add_range(self, reading: RangeReading) -> bool:
        """Keep a rangefinder reading; False for one that holds no range (not kept)."""
        if reading.status is not RangeStatus.OK or reading.range_m is None:
            return False
        try:
            self.lrf.append(reading.t_host_ns, reading.range_m)
        except ValueError:
            log.warning("rangefinder reading out of order dropped from the history")
        return True

    def add_fix(self, fix: GpsFix) -> float | None:
        """Keep a fix's slant range from the site now; returns it (None: none)."""
        r = None if self.site is None else gps_slant_range_m(fix, self.site)
        if r is None:
            return None
        try:
            self._gps.append(fix.t_host_ns, r)
        except ValueError:
            log.warning("GPS fix out of order dropped from the history")
        return r

    def defer_fix(self, fix: GpsFix) -> None:
        """Keep a fix whose slant range is computed when :attr:`gps` is read, in order."""
        self._fixes.append(fix)

    @property
    def gps(self) -> ScalarHistory:
        """The GPS slant ranges from the site, fix by fix (those of deferred fixes computed
        now, in the order the fixes came: the same history either way)."""
        if self._fixes:
            with self._fixes_lock:
                while self._fixes:
                    self.add_fix(self._fixes.popleft())
        return self._gps

    def range_at(self, t_host_ns: int) -> tuple[float | None, str]:
        """The range for a frame received at ``t_host_ns``: the rangefinder if its reading is
        fresh, else the GPS slant range, else None."""
        r = self.lrf.value_at(t_host_ns)
        if r is not None:
            return r, "lrf"
        g = self.gps.value_at(t_host_ns)
        return (g, "gps") if g is not None else (None, "")
