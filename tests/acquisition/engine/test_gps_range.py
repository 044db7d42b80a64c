"""The GPS slant range of each fix (pymap3d, ~20 us a fix) is computed when it is first read
where no stop detector needs it at once (a replay with the recorded stops): the same history,
in the same order, as when every fix is computed as it arrives."""

from __future__ import annotations

import math

import pymap3d
import pytest

from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.engine import range_history
from snrmon.acquisition.engine.session_engine import SessionEngine
from snrmon.acquisition.replay.feeder import RecordedStops
from snrmon.drivers.gps.fix import GpsFix

SITE = {"lat_deg": 32.38, "lon_deg": -106.48, "alt_m": 1200.0}
T0 = 10**12


def _fixes() -> list[GpsFix]:
    """A drone 150-200 m north of the site at 10 Hz, one fix arriving out of order and one
    without a position."""
    out = []
    for i in range(20):
        north = 150.0 + 2.5 * i
        lat, lon, alt = pymap3d.enu2geodetic(0.0, north, 30.0, *SITE.values())
        out.append(GpsFix(T0 + i * 10**8, None, float(lat), float(lon), float(alt), None, 1, 9))
    out[7], out[8] = out[8], out[7]
    out.insert(12, GpsFix(T0 + 1_150_000_000, None, None, None, None, None, 0, 0))
    return out


def _engine(recorded_stops: bool) -> SessionEngine:
    config = session_config_from_dict(
        {
            "site": SITE,
            "cameras": {"cam": {"source": "shm", "address": "x", "width_px": 8, "height_px": 8}},
        }
    )
    stops = RecordedStops() if recorded_stops else None
    return SessionEngine(config, {"cam": (8, 8)}, stops=stops, project_gps=False)


def test_deferred_gps_ranges_equal_the_ones_computed_on_arrival(monkeypatch):
    calls = {"n": 0}
    real = range_history.gps_slant_range_m

    def counted(fix, site):
        calls["n"] += 1
        return real(fix, site)

    monkeypatch.setattr(range_history, "gps_slant_range_m", counted)
    eager, deferred = _engine(recorded_stops=False), _engine(recorded_stops=True)
    fixes = _fixes()
    for fix in fixes:
        eager.on_fix(fix)
    assert calls["n"] == len(fixes)  # the detector took each as it came
    for fix in fixes:
        deferred.on_fix(fix)
    assert calls["n"] == len(fixes)  # none computed yet
    times = [T0 + k * 37_000_000 for k in range(60)]
    ranges = [deferred.range_at(t) for t in times]
    assert calls["n"] == 2 * len(fixes)  # all of them at the first read, once
    assert ranges == [eager.range_at(t) for t in times]
    assert deferred.gps_range.latest() == eager.gps_range.latest()
    assert len(deferred.gps_range) == len(eager.gps_range) == len(fixes) - 2  # out of order, none
    r, source = ranges[30]
    assert source == "gps" and r == pytest.approx(math.hypot(150.0 + 2.5 * 30 * 0.37, 30.0), 0.01)
