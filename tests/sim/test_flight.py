"""The simulated collection flight: stops, transit speed, geodesy, pixel positions."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pymap3d
import pytest

from snrmon.sim.flight import PAPER_STOPS_M, CameraPointing, FlightConfig, FlightPlan


def test_the_drone_hovers_at_each_planned_range():
    plan = FlightPlan(FlightConfig(seed=1))
    windows = plan.stop_windows()
    assert [w[2] for w in windows] == list(PAPER_STOPS_M)
    for i, (t0, t1, planned) in enumerate(windows):
        assert t1 - t0 == pytest.approx(6.0)
        for t in np.linspace(t0 + 0.01, t1 - 0.01, 25):
            truth = plan.truth(t)
            assert truth.stop_index == i
            assert truth.planned_range_m == planned
            assert truth.nominal_range_m == planned
            # Wind drift moves the drone by tens of centimetres, not metres.
            assert abs(truth.range_m - planned) < 0.5
    assert plan.truth(plan.duration_s + 100).stop_index == len(PAPER_STOPS_M) - 1


def test_transit_runs_at_the_set_speed_between_stops():
    config = FlightConfig(speed_mps=4.0, stops_m=(50.0, 130.0), start_range_m=10.0, seed=2)
    plan = FlightPlan(config)
    (t0a, t1a, _), (t0b, _, _) = plan.stop_windows()
    assert t0a == pytest.approx(40.0 / 4.0)
    assert t0b - t1a == pytest.approx(80.0 / 4.0)
    mid = 0.5 * (t1a + t0b)
    assert plan.truth(mid).stop_index is None
    assert plan.truth(mid).nominal_range_m == pytest.approx(90.0)
    dt = 0.5
    speed = (plan.truth(mid + dt).nominal_range_m - plan.truth(mid).nominal_range_m) / dt
    assert speed == pytest.approx(4.0)


def test_positions_lie_on_the_line_of_sight_from_the_site():
    config = FlightConfig(
        azimuth_deg=120.0, elevation_deg=10.0, seed=3, drift_amplitude_m=(0.0, 0.0, 0.0)
    )
    plan = FlightPlan(config)
    t = plan.stop_windows()[3][0] + 1.0
    lat, lon, alt = plan.position(t)
    s = config.site
    e, n, u = pymap3d.geodetic2enu(lat, lon, alt, s.lat_deg, s.lon_deg, s.alt_m)
    assert math.hypot(e, n, u) == pytest.approx(336.0, abs=1e-3)
    assert math.degrees(math.atan2(e, n)) == pytest.approx(120.0, abs=1e-6)
    assert math.degrees(math.asin(u / 336.0)) == pytest.approx(10.0, abs=1e-6)
    assert plan.range_m(t) == pytest.approx(336.0, abs=1e-6)


def test_drift_is_seeded_and_sweeps_more_than_a_pixel_at_the_far_stop():
    a, b = FlightPlan(FlightConfig(seed=4)), FlightPlan(FlightConfig(seed=4))
    c = FlightPlan(pickle.loads(pickle.dumps(FlightConfig(seed=5))))
    assert a.truth(100.0) == b.truth(100.0)
    assert a.truth(100.0) != c.truth(100.0)
    mwir = CameraPointing(5e-4, 1280, 720)
    t0 = a.stop_windows()[-1][0]
    xy = np.array([mwir.pixel_of(a.truth(t0 + k / 60)) for k in range(100)])
    assert np.ptp(xy[:, 0]) > 1.0 or np.ptp(xy[:, 1]) > 1.0
    # Near the image centre: the optical axis points at the clear-sky patch.
    assert np.all(np.abs(xy - [639.5, 359.5]) < 5.0)


def test_pixel_position_follows_the_angular_offset_and_ifov():
    plan = FlightPlan(FlightConfig(seed=6))
    pointing = CameraPointing(1e-3, 640, 480, boresight_offset_px=(3.0, -2.0))
    truth = plan.truth(50.0)
    x, y = pointing.pixel_of(truth)
    assert x == pytest.approx(319.5 + 3.0 + truth.right_m / truth.along_m / 1e-3)
    assert y == pytest.approx(239.5 - 2.0 - truth.above_m / truth.along_m / 1e-3)
    assert pointing.size_px(0.157, 157.0) == pytest.approx(1.0)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"stops_m": (37.0, -1.0)}, "stops"),
        ({"speed_mps": 0.0}, "speed"),
        ({"hover_s": 0.0}, "hover"),
        ({"elevation_deg": 95.0}, "elevation"),
    ],
)
def test_bad_flight_settings_are_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        FlightConfig(**kwargs)
