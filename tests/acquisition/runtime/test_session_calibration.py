"""A calibrated camera in a live Session: the calibration is applied before Eq. (4),
the sky's apparent temperature is followed live, recorded, and the replay is exact."""

from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest

from snrmon.acquisition.calibrate.calibration import BlackbodyCapture, calibrate_sensor
from snrmon.acquisition.calibrate.calibration_file import load_calibration, save_calibration
from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.record.reader import open_session
from snrmon.acquisition.replay.batch import replay_session
from snrmon.acquisition.replay.player import ReplayPlayer
from snrmon.acquisition.runtime.session import Session
from snrmon.sim.devices.shm_camera import ShmProducer
from tests.acquisition.calibration_scene import camera
from tests.helpers import running_n, shm_camera_config, wait_until

SKY_K = 280.0


class CalibratedSky:
    """Picklable render callable: the calibration scene's camera looking at a 280 K sky."""

    def __init__(self, seed: int) -> None:
        self.cam = camera("mwir", shape=(96, 128), seed=7)
        self.sky_e = self.cam.electrons(SKY_K)
        self.seed = seed

    def __call__(self, counter: int) -> np.ndarray:
        return self.cam.frames(self.sky_e, 1, seed=self.seed * 100_000 + counter)[0]


@pytest.fixture
def calibration_file(tmp_path):
    cam = camera("mwir", shape=(96, 128), seed=7)
    caps = [
        BlackbodyCapture(t, cam.blackbody(t, 16, seed=i))
        for i, t in enumerate((283.15, 303.15, 323.15))
    ]
    cal = calibrate_sensor(caps, cam.sensor)
    return save_calibration(cal, tmp_path / "mwir-cal.npz")


def test_calibrated_session_follows_the_sky_temperature_and_replays_exactly(
    tmp_path, calibration_file, capsys
):
    name = f"snrmon-cal-{time.monotonic_ns() % 10**9}"
    producer = ShmProducer(name, 128, 96, CalibratedSky(1), fps=60.0, slots=16)
    producer.start()
    config = shm_camera_config(name, calibration=str(calibration_file))
    session = Session(config, track=False)
    path = tmp_path / "cal.h5"
    try:
        session.start()
        session.start_recording(path)
        session.set_roi("mwir", 60, 50)
        wait_until(lambda: running_n(session.status(), "mwir") >= 50, 10, "50 frames")
        session.stop_recording()
        st = session.status().cameras["mwir"]
    finally:
        session.stop()
        producer.stop()
    assert st.figures.sky_temp_k == pytest.approx(SKY_K, abs=0.3)
    cal = load_calibration(calibration_file)
    with open_session(path) as f:
        (event,) = [e for e in f.event_list() if e["kind"] == "calibration"]
        assert event["camera"] == "mwir" and event["payload"]["path"] == str(calibration_file)
        # The recording keeps the calibration whole: every map bit for bit, and its metadata.
        meta, maps = f.calibration_record("mwir")
        assert meta["camera"] == cal.camera and meta["bad_pixels"] == np.count_nonzero(cal.bad)
        for key, values in maps.items():
            np.testing.assert_array_equal(values, getattr(cal, key))
    # netCDF readers see the maps on the frames' pixel axes
    import xarray as xr

    with xr.open_dataset(path, group="cameras/mwir/calibration", engine="h5netcdf") as ds:
        assert ds["responsivity"].dims == ("row", "col") and ds["bad"].shape == (96, 128)
        assert ds["offset_dn"].attrs["units"] == "1" and "DN" in ds["offset_dn"].attrs["long_name"]
    # ... so the replay and the noise below need nothing beside it.
    calibration_file.unlink()
    calibration_file.with_suffix(".toml").unlink()
    replay = replay_session(path).cameras["mwir"]
    assert replay.compared >= 50 and replay.identical == replay.compared
    # the recorded calibration named by its (now missing) path, as a campaign passes the
    # recorded settings: the same calibration, the same replay
    again = replay_session(path, calibrations={"mwir": str(calibration_file)}).cameras["mwir"]
    assert again.identical == again.compared == replay.compared
    # A batch replay reports no raw-SNR figure, so it does not track the raw frames (half of
    # a frame's work); the console's player below does, as live.
    assert all(m.raw is None for m in replay.tally.measurements)
    # The console's replay follows the sky from the recorded frames through the recorded
    # calibration, and measures the raw frames beside the corrected ones, as live.
    with ReplayPlayer(path) as player:
        player.step(player.position().length)
        assert player.wait_idle(30.0)
        cs = player.status().cameras["mwir"]
    assert cs.figures.sky_temp_k == pytest.approx(SKY_K, abs=0.3)
    assert cs.last.raw is not None and math.isfinite(cs.last.raw.mean) and cs.last.snr_n >= 50
    # snrmon noise on the recording: NETD from sigma_tvh through the recorded calibration
    from snrmon.cli import main

    assert main(["noise", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["scene_temp_k"] == pytest.approx(SKY_K, abs=0.3)
    sitf = cal.dn_per_k(out["scene_temp_k"])
    assert out["sitf_dn_per_k"] == pytest.approx(sitf)
    assert out["netd_mk"] == pytest.approx(1e3 * out["sigma_corrected_dn"]["tvh"] / sitf)
    sky = CalibratedSky(1)
    c = sky.cam.config  # the rendered temporal noise and the rounding are sigma_tvh
    rendered = math.sqrt((c.floor_noise_e**2 + sky.sky_e) / c.gain_e_per_dn**2 + 1 / 12)
    assert out["sigma_corrected_dn"]["tvh"] == pytest.approx(rendered, rel=0.02)


def test_a_calibration_of_another_camera_is_refused(tmp_path, calibration_file):
    config = session_config_from_dict(
        {
            "cameras": {
                "lwir": {
                    "source": "shm",
                    "address": "nothing",
                    "sensor": "lwir",
                    "width_px": 128,
                    "height_px": 96,
                    "calibration": str(calibration_file),
                }
            }
        }
    )
    with pytest.raises(ValueError, match="mwir"):
        Session(config)
