"""GPS -> pixel projection against hand-computed cases (module acquisition.geo.projection)."""

from __future__ import annotations

import math

import numpy as np
import pymap3d
import pytest

from snrmon.acquisition.geo.projection import (
    CameraIntrinsics,
    Pointing,
    Site,
    camera_axes,
    gps_slant_range_m,
    project_to_pixel,
    slant_range_m,
)
from snrmon.cli import main
from snrmon.drivers.gps.fix import GpsFix
from snrmon.model.presets import load_sensor
from tests.helpers import strict_json

SITE = Site(32.38, -106.48, 1200.0)
MWIR = CameraIntrinsics(0.016, 8e-6, 1280, 720)  # paper Table 1
LWIR = CameraIntrinsics(0.0167, 17e-6, 640, 480)


def _target(site: Site, pointing: Pointing, right_deg: float, up_deg: float, dist: float):
    """Geodetic point ``dist`` m from the site, at an angle right/up of the optical axis (roll
    0 frame of the pointing)."""
    r0, u0, f = camera_axes(math.radians(pointing.az_deg), math.radians(pointing.el_deg), 0.0)
    d = f + math.tan(math.radians(right_deg)) * r0 + math.tan(math.radians(up_deg)) * u0
    enu = dist * d / np.linalg.norm(d)
    return pymap3d.enu2geodetic(*enu, site.lat_deg, site.lon_deg, site.alt_m)


@pytest.mark.parametrize("cam", [MWIR, LWIR])
@pytest.mark.parametrize("az,el", [(0.0, 0.0), (40.0, 8.0), (271.5, -3.0)])
def test_target_on_the_axis_lands_at_the_centre(cam, az, el):
    pointing = Pointing(az, el, 0.0)
    lat, lon, alt = _target(SITE, pointing, 0.0, 0.0, 336.0)
    p = project_to_pixel(SITE, pointing, cam, lat, lon, alt)
    assert p.x == pytest.approx((cam.width_px - 1) / 2, abs=1e-6)
    assert p.y == pytest.approx((cam.height_px - 1) / 2, abs=1e-6)
    assert p.range_m == pytest.approx(336.0, abs=1e-6)
    assert p.in_view


def test_due_north_level_is_the_centre_by_hand():
    # 100 m due north on the same altitude: geodetic2enu puts it at (0, 100, ~-0.0008 m)
    # (Earth curvature), 1.6e-6 px below the centre for the MWIR.
    lat, lon, alt = pymap3d.enu2geodetic(0.0, 100.0, 0.0, SITE.lat_deg, SITE.lon_deg, SITE.alt_m)
    p = project_to_pixel(SITE, Pointing(0.0, 0.0, 0.0), MWIR, lat, lon, alt)
    assert (p.x, p.y) == (pytest.approx(639.5, abs=1e-3), pytest.approx(359.5, abs=1e-3))


@pytest.mark.parametrize("angle_deg", [0.5, 1.0, 2.0, -1.5])
def test_angular_offset_lands_at_f_tan_over_pitch(angle_deg):
    pointing = Pointing(40.0, 8.0, 0.0)
    expected_px = 0.016 * math.tan(math.radians(angle_deg)) / 8e-6  # 2000 px per rad near axis
    lat, lon, alt = _target(SITE, pointing, angle_deg, 0.0, 200.0)
    p = project_to_pixel(SITE, pointing, MWIR, lat, lon, alt)
    assert p.x - 639.5 == pytest.approx(expected_px, abs=1e-4)
    assert p.y == pytest.approx(359.5, abs=1e-4)
    # Upward offset: the row decreases (y is down).
    lat, lon, alt = _target(SITE, pointing, 0.0, angle_deg, 200.0)
    p = project_to_pixel(SITE, pointing, MWIR, lat, lon, alt)
    assert 359.5 - p.y == pytest.approx(expected_px, abs=1e-4)
    assert p.x == pytest.approx(639.5, abs=1e-4)


def test_roll_rotates_about_the_centre():
    base = Pointing(40.0, 8.0, 0.0)
    lat, lon, alt = _target(SITE, base, 1.0, 0.0, 150.0)  # ~34.9 px right of the centre
    p0 = project_to_pixel(SITE, base, MWIR, lat, lon, alt)
    dx0 = p0.x - 639.5
    for roll in (30.0, 90.0, -45.0):
        p = project_to_pixel(SITE, Pointing(40.0, 8.0, roll), MWIR, lat, lon, alt)
        dx, dy = p.x - 639.5, p.y - 359.5
        # Same distance from the centre ...
        assert math.hypot(dx, dy) == pytest.approx(abs(dx0), rel=1e-9)
        # ... turned counter-clockwise on the screen (camera turned clockwise, right side down):
        # a point on the right moves up (negative dy) by roll degrees.
        assert math.degrees(math.atan2(-dy, dx)) == pytest.approx(roll, abs=1e-6)
    # The centre itself does not move under roll.
    lat, lon, alt = _target(SITE, base, 0.0, 0.0, 150.0)
    pc = project_to_pixel(SITE, Pointing(40.0, 8.0, 63.0), MWIR, lat, lon, alt)
    assert (pc.x, pc.y) == (pytest.approx(639.5, abs=1e-6), pytest.approx(359.5, abs=1e-6))


def test_behind_the_camera_is_not_in_view():
    pointing = Pointing(40.0, 8.0, 0.0)
    behind = Pointing(220.0, -8.0, 0.0)  # the opposite direction
    lat, lon, alt = _target(SITE, behind, 0.0, 0.0, 100.0)
    p = project_to_pixel(SITE, pointing, MWIR, lat, lon, alt)
    assert not p.in_view
    assert math.isnan(p.x) and math.isnan(p.y)
    assert p.range_m == pytest.approx(100.0, abs=1e-6)


def test_outside_the_array_is_not_in_view():
    pointing = Pointing(40.0, 8.0, 0.0)
    # MWIR half-width: 640 px * 0.5 mrad = ~18.1 deg; 25 deg to the right is off the array.
    lat, lon, alt = _target(SITE, pointing, 25.0, 0.0, 100.0)
    p = project_to_pixel(SITE, pointing, MWIR, lat, lon, alt)
    assert p.x > 1279.5 and not p.in_view


def test_slant_range_and_gps_fix():
    lat, lon, alt = pymap3d.enu2geodetic(30.0, 40.0, 0.0, SITE.lat_deg, SITE.lon_deg, SITE.alt_m)
    assert slant_range_m(SITE, lat, lon, alt) == pytest.approx(50.0, abs=1e-6)
    fix = GpsFix(0, None, lat, lon, alt_msl_m=alt, fix_quality=1)
    assert gps_slant_range_m(fix, SITE) == pytest.approx(50.0, abs=1e-6)
    assert gps_slant_range_m(GpsFix(0, None, lat, lon, alt_msl_m=None, fix_quality=1), SITE) is None
    assert gps_slant_range_m(GpsFix(0, None, None, None, fix_quality=0), SITE) is None


def test_bad_input_is_one_clear_error():
    with pytest.raises(ValueError, match="elevation"):
        Pointing(0.0, 95.0)
    with pytest.raises(ValueError, match="pitch_m"):
        CameraIntrinsics(0.016, 0.0, 1280, 720)
    with pytest.raises(ValueError, match="latitude"):
        Site(123.0, 0.0, 0.0)


def test_cli_geo_pixel_json(capsys):
    pointing = Pointing(40.0, 8.0, 0.0)
    lat, lon, alt = _target(SITE, pointing, 1.0, 0.0, 200.0)
    code = main(
        [
            "geo",
            "pixel",
            "--site",
            f"{SITE.lat_deg},{SITE.lon_deg},{SITE.alt_m}",
            "--pointing",
            "40,8,0",
            "--intrinsics",
            "0.016,8,1280,720",
            "--target-at",
            f"{float(lat)!r},{float(lon)!r},{float(alt)!r}",
            "--json",
        ]
    )
    assert code == 0
    out = strict_json(capsys.readouterr().out)
    assert set(out) == {"x", "y", "range_m", "in_view"}
    assert out["x"] == pytest.approx(639.5 + 2000 * math.tan(math.radians(1.0)), abs=1e-4)
    assert out["y"] == pytest.approx(359.5, abs=1e-4)
    assert out["range_m"] == pytest.approx(200.0, abs=1e-6)
    assert out["in_view"] is True


def test_cli_geo_pixel_bad_site_is_one_line(capsys):
    code = main(
        [
            "geo",
            "pixel",
            "--site",
            "1,2",
            "--pointing",
            "0,0,0",
            "--intrinsics",
            "0.016,8,1280,720",
            "--target-at",
            "1,2,3",
        ]
    )
    err = capsys.readouterr().err
    assert code != 0 and "--site" in err and len(err.strip().splitlines()) == 1


def test_agrees_with_the_simulated_flight_camera():
    # The simulator renders the drone where its own pinhole puts it; the GPS cue must land on
    # the same pixel (same az/el convention, roll 0, IFOV = pitch / f).
    flight = pytest.importorskip("snrmon.sim.flight")
    plan = flight.FlightPlan(flight.FlightConfig(azimuth_deg=40.0, elevation_deg=8.0, seed=3))
    s = plan.config.site
    site = Site(s.lat_deg, s.lon_deg, s.alt_m)
    cam_sim = flight.CameraPointing(8e-6 / 0.016, 1280, 720)
    for t_s in (5.0, 30.0, 77.7, 140.0):
        truth = plan.truth(t_s)
        p = project_to_pixel(
            site, Pointing(40.0, 8.0, 0.0), MWIR, truth.lat_deg, truth.lon_deg, truth.alt_m
        )
        x_sim, y_sim = cam_sim.pixel_of(truth)
        assert (p.x, p.y) == (pytest.approx(x_sim, abs=1e-3), pytest.approx(y_sim, abs=1e-3))
        assert p.range_m == pytest.approx(truth.range_m, abs=1e-4)


@pytest.mark.parametrize(
    "name,f_m,pitch_m,w,h", [("mwir", 0.016, 8e-6, 1280, 720), ("lwir", 0.0167, 17e-6, 640, 480)]
)
def test_cli_with_sensor_preset(name, f_m, pitch_m, w, h, capsys):
    # Paper Table 1 through the model's presets: the axis at the centre, 1 degree off at
    # f tan(1 deg) / pitch pixels.
    cam = CameraIntrinsics.from_sensor(load_sensor(name))
    assert (cam.focal_length_m, cam.pitch_m, cam.width_px, cam.height_px) == (
        pytest.approx(f_m),
        pytest.approx(pitch_m),
        w,
        h,
    )
    lat, lon, alt = _target(SITE, Pointing(40.0, 8.0, 0.0), 1.0, 0.0, 200.0)
    code = main(
        [
            "geo",
            "pixel",
            "--site",
            "32.38,-106.48,1200",
            "--pointing",
            "40,8,0",
            "--sensor",
            name,
            "--target-at",
            f"{float(lat)!r},{float(lon)!r},{float(alt)!r}",
            "--json",
        ]
    )
    assert code == 0
    out = strict_json(capsys.readouterr().out)
    assert out["x"] == pytest.approx((w - 1) / 2 + f_m * math.tan(math.radians(1.0)) / pitch_m)
    assert out["y"] == pytest.approx((h - 1) / 2, abs=1e-4)


def test_enu_offsets_are_pymap3ds_bit_for_bit():
    """enu_of keeps the site's ECEF between calls; the offsets are pymap3d.geodetic2enu's own,
    for single points and arrays."""
    from snrmon.acquisition.geo.projection import Site, enu_of

    rng = np.random.default_rng(11)
    site = Site(38.0, -77.2, 60.0)
    lat = 38.0 + rng.normal(0.0, 0.02, 300)
    lon = -77.2 + rng.normal(0.0, 0.02, 300)
    alt = 60.0 + rng.uniform(-10.0, 800.0, 300)
    for k in range(300):
        e, n, u = pymap3d.geodetic2enu(lat[k], lon[k], alt[k], 38.0, -77.2, 60.0, deg=True)
        want = [float(e), float(n), float(u)]
        assert repr(enu_of(site, lat[k], lon[k], alt[k]).tolist()) == repr(want)
    e, n, u = pymap3d.geodetic2enu(lat, lon, alt, 38.0, -77.2, 60.0, deg=True)
    assert repr(enu_of(site, lat, lon, alt).tolist()) == repr(np.stack([e, n, u], -1).tolist())
