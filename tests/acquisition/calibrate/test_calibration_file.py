"""Calibration files: npz maps + TOML sidecar, exact round trip, validation against the sensor."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

from snrmon.acquisition.calibrate.calibration import BlackbodyCapture, calibrate_sensor
from snrmon.acquisition.calibrate.calibration_file import (
    load_calibration,
    save_calibration,
    sidecar_path,
)
from snrmon.model.presets import load_sensor
from tests.acquisition.calibration_scene import camera


@pytest.fixture(scope="module")
def full_cal():
    cam = camera("mwir", shape=(720, 1280), seed=5)
    caps = [BlackbodyCapture(t, cam.blackbody(t, 3, seed=i)) for i, t in enumerate((288.0, 313.0))]
    return calibrate_sensor(caps, cam.sensor)


@pytest.fixture(scope="module")
def saved(full_cal, module_tmp):
    return save_calibration(full_cal, module_tmp("cal") / "mwir.npz")


def test_round_trip_is_exact_and_the_sidecar_is_readable(tmp_path, full_cal):
    path = save_calibration(full_cal, tmp_path / "mwir_cal.npz")
    meta = tomllib.loads(sidecar_path(path).read_text())["calibration"]
    assert meta["camera"] == "mwir"
    assert meta["band_um"] == [3.45, 5.25]
    assert meta["t_int_s"] == 0.003
    assert meta["blackbody_temps_c"] == pytest.approx([14.85, 39.85])
    assert meta["frames_per_temp"] == [3, 3]
    assert meta["date"] == full_cal.date
    back = load_calibration(path, load_sensor("mwir"))
    for name in ("responsivity", "offset_dn", "bad", "fit_rms_dn", "temporal_noise_dn"):
        assert np.array_equal(getattr(back, name), getattr(full_cal, name))
    assert back.temps_k == pytest.approx(full_cal.temps_k)
    frame = np.full((720, 1280), 5000, np.uint16)
    assert np.array_equal(back.temperature_k(frame), full_cal.temperature_k(frame))


@pytest.mark.parametrize(
    "change, message",
    [
        ({"name": "lwir"}, "is for camera 'mwir', not 'lwir'"),
        ({"band_um": (3.0, 5.0)}, r"is for band 3.45-5.25 um, not the sensor's 3.0-5.0 um"),
        ({"t_int_s": 0.002}, "made at integration time 3 ms, the sensor runs 2 ms"),
        ({"width_px": 640}, "is for 1280x720 frames, the frames are 640x720"),
    ],
)
def test_calibration_for_another_camera_is_refused(saved, change, message):
    path = saved
    other = dataclasses.replace(load_sensor("mwir"), **change)
    with pytest.raises(ValueError, match=message):
        load_calibration(path, other)


def test_a_recorded_frame_size_overrides_the_sensor_format(tmp_path):
    cam = camera("lwir", shape=(48, 64), seed=2)
    caps = [BlackbodyCapture(t, cam.blackbody(t, 3, seed=i)) for i, t in enumerate((280.0, 300.0))]
    path = save_calibration(calibrate_sensor(caps, cam.sensor), tmp_path / "l.npz")
    assert load_calibration(path, cam.sensor, frame_shape=(48, 64)).shape == (48, 64)
    with pytest.raises(ValueError, match="is for 64x48 frames, the frames are 640x480"):
        load_calibration(path, cam.sensor)


def test_missing_or_foreign_files_are_one_clear_error(tmp_path, full_cal):
    with pytest.raises(OSError, match=r"calibration file .*nope\.npz not found"):
        load_calibration(tmp_path / "nope.npz")
    path = save_calibration(full_cal, tmp_path / "c.npz")
    sidecar_path(path).write_text("[calibration]\nformat = 'other'\n")
    with pytest.raises(ValueError, match="not a snrmon calibration sidecar"):
        load_calibration(path)
    with pytest.raises(ValueError, match=r"must end in \.npz"):
        save_calibration(full_cal, tmp_path / "c.h5")
