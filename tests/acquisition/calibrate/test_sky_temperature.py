"""Live apparent sky temperature from the Eq. 4 rim or an operator rectangle."""

from __future__ import annotations

import numpy as np
import pytest

from snrmon.acquisition.calibrate.calibration import BlackbodyCapture, calibrate_sensor
from snrmon.acquisition.calibrate.sky_temperature import SkyTemperature
from snrmon.acquisition.measure.peak_snr import measure_peak_snr
from tests.acquisition.calibration_scene import camera


@pytest.fixture(scope="module")
def setup():
    cam = camera("lwir", shape=(64, 80), seed=8)
    caps = [BlackbodyCapture(t, cam.blackbody(t, 24, seed=i)) for i, t in enumerate((270.0, 300.0))]
    return cam, calibrate_sensor(caps, cam.sensor)


def test_rim_and_rectangle_follow_a_warming_sky(setup):
    cam, cal = setup
    rim = SkyTemperature("lwir", cal)
    rect = SkyTemperature("lwir", cal, rect=(5, 5, 24, 20))
    sky = np.linspace(275.0, 285.0, 20)  # the sky warms 10 K over the series
    spot = np.zeros(cam.shape)
    spot[30, 40] = cam.electrons(320.0) - cam.electrons(280.0)
    for i, t in enumerate(sky):
        frame = cam.frames(cam.electrons(t) + spot, 1, seed=50 + i)[0]
        result = measure_peak_snr(frame, (40, 30))
        s = rim.add(1_000 * i, frame, result)
        rect.add(1_000 * i, frame)
        assert s.n_pixels == 24
    times, temps = rim.series()
    assert list(times) == [1_000 * i for i in range(20)]
    # 24 pixels of 50 mK NETD each: ~10 mK per frame; NUC makes the rim and rect agree
    assert np.max(np.abs(temps - sky)) < 0.1
    assert np.max(np.abs(rect.series()[1] - sky)) < 0.05
    assert rim.mean_temp_k(last=5) == pytest.approx(np.mean(sky[-5:]), abs=0.05)


def test_bad_inputs(setup):
    cam, cal = setup
    with pytest.raises(ValueError, match="calibration is for camera 'lwir', not 'mwir'"):
        SkyTemperature("mwir", cal)
    with pytest.raises(ValueError, match="leaves the 80x64 image"):
        SkyTemperature("lwir", cal, rect=(0, 0, 100, 10))
    with pytest.raises(ValueError, match="needs the frame's PeakSnr"):
        SkyTemperature("lwir", cal).add(0, np.zeros(cam.shape, np.uint16))
    assert np.isnan(SkyTemperature("lwir", cal).mean_temp_k())


def test_a_drone_wider_than_the_box_is_not_read_as_sky(setup):
    """A resolved drone (a 9-px warm square, measured against its extent rim) puts
    itself on the 7x7 rim: the sky is read on the rim outside its extent and guard instead, as
    Eq. 4's background is, so the model's path-radiance correction gets the sky's 280 K."""
    from snrmon.acquisition.measure.blob import analyse_blob
    from snrmon.acquisition.measure.peak_snr import PeakSnrConfig
    from snrmon.acquisition.measure.target_snr import measure_target

    cam, cal = setup
    scene = np.full(cam.shape, cam.electrons(280.0))
    scene[28:37, 36:45] = cam.electrons(300.0)  # the drone, 20 K warmer than the sky
    scene[32, 40] = cam.electrons(305.0)  # its hottest pixel (the engine's peak)
    sky = SkyTemperature("lwir", cal)
    for i, frame in enumerate(cam.frames(scene, 5, seed=31)):
        blob = analyse_blob(frame.astype(np.float64), (40, 32))
        result = measure_target(frame, blob, PeakSnrConfig())
        assert result.background == "extent_rim" and result.extent_w_px == 9
        s = sky.add(1_000 * i, frame, result)
        assert s.n_pixels > 24  # a rim outside the drone, not the 7x7 box's 24 pixels
        assert s.temp_k == pytest.approx(280.0, abs=0.1)
        on_drone = SkyTemperature("lwir", cal).add(0, frame, measure_peak_snr(frame, (40, 32)))
        assert on_drone.temp_k > 290.0  # what the 7x7 rim reads: the drone itself
