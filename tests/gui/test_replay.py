"""Replay in the console: a recorded session file played through ReplayPlayer (offscreen).

The file is written by the real recorder (tests/acquisition/session_factory.write_session): one
Gaussian spot on seeded noise at known ranges, with the operator's click recorded.
"""

from __future__ import annotations

import numpy as np
import pytest
from PySide6.QtCore import QSettings

from snrmon.acquisition.engine.frame_measurer import FrameMeasurer
from snrmon.acquisition.replay.player import ReplayPlayer
from snrmon.acquisition.streams.ring import RingFrame
from snrmon.gui.app import console_application
from snrmon.gui.main_window import ConsoleWindow
from tests.acquisition.session_factory import NOISE_DN, SPOT_XY, write_session


def curves(camera: str) -> dict:
    r = np.linspace(50.0, 400.0, 30)
    return {"small": (r, 6e5 / r**2)}


@pytest.fixture(scope="module")
def recording(module_tmp):
    path = module_tmp("replay") / "flight.h5"
    return write_session(path, cameras=("mwir",), ranges_m=(120.0, 240.0), hover_s=6.0)


@pytest.fixture
def player(recording):
    with ReplayPlayer(recording.path) as p:
        yield p


@pytest.fixture
def window(qtbot, player, tmp_path):
    console_application(headless=True)
    settings = QSettings(str(tmp_path / "console.ini"), QSettings.Format.IniFormat)
    win = ConsoleWindow(player, curves=curves, settings=settings)
    qtbot.addWidget(win)
    win.set_size(1400, 900)
    win.show()
    return win


def _shown(qtbot, win, counter: int) -> None:
    qtbot.waitUntil(lambda: win.shown_counter.get("mwir") == counter, timeout=5000)


def test_step_and_seek_move_the_shown_frame_exactly(qtbot, window, player, recording):
    assert window.replay_bar is not None and window.replay_bar.isVisible()
    assert window.actions_by_key["replay_play"].shortcut().toString() == "Space"
    window.actions_by_key["replay_step"].trigger()
    _shown(qtbot, window, 0)
    for _ in range(3):
        window.replay_step()
    _shown(qtbot, window, 3)
    assert player.position().index == 3
    player.seek(150)
    _shown(qtbot, window, 150)
    frame = player.pipelines["mwir"].latest_frame()
    np.testing.assert_array_equal(frame.pixels, recording.frames["mwir"][150])
    window.replay_back()
    _shown(qtbot, window, 149)
    # after the seek the track restarts at the recorded peak: the spot
    qtbot.waitUntil(lambda: player.status().cameras["mwir"].last is not None, timeout=5000)
    last = player.status().cameras["mwir"].last.result
    assert (last.peak_x, last.peak_y) == SPOT_XY
    qtbot.waitUntil(lambda: "  150 / " in window.replay_bar.label.text(), timeout=5000)  # 1-based


def test_play_fills_the_chart_and_the_stop_table(qtbot, window, player):
    player.set_speed(40.0)
    window.replay_toggle()
    chart = window.panels["mwir"].chart
    qtbot.waitUntil(lambda: chart.points_drawn >= 50, timeout=10_000)
    qtbot.waitUntil(lambda: not player.position().playing, timeout=20_000)  # the end
    assert player.position().index == player.position().length - 1
    window.refresh_stops()
    rows = player.stops()
    assert [round(r.range_m) for r in rows] == [120, 240]
    assert all(r.reading.n_frames > 50 for r in rows)
    assert (
        rows[0].reading.snr_mean > 2 * rows[1].reading.snr_mean
    )  # (240/120)^2 fainter at the second stop
    assert len(window.stop_table.cells()) >= 2


def test_click_remeasures_the_shown_frame_and_recording_is_refused(
    qtbot, window, player, recording
):
    for _ in range(5):
        window.replay_step()
    _shown(qtbot, window, 4)
    window.set_roi("mwir", 48, 34)
    assert player.wait_idle()
    # the same frame measured by the same class at that click, outside the console
    expected = FrameMeasurer(player.config.measurement, window=player.config.window_frames)
    expected.set_roi(48, 34)
    pixels = recording.frames["mwir"][4]
    want = expected.measure(pixels, RingFrame(pixels, 4, 4, 0, None, "mwir")).result
    assert player.status().cameras["mwir"].last.result == want
    assert not window.start_recording(window.settings.fileName() + ".h5")
    assert "not available in replay" in window.messages[-1]
    window.mark_stop()
    assert "not available in replay" in window.messages[-1]


def test_bad_seek_and_speed_are_refused(player):
    with pytest.raises(ValueError, match="frame index"):
        player.seek(10**6)
    with pytest.raises(ValueError, match="speed"):
        player.set_speed(0.0)


def test_gps_cross_is_drawn_at_the_projection_and_hidden_without_one(qtbot, window):
    from snrmon.acquisition.engine.status import CameraStatus, FrameAccounting
    from snrmon.drivers.device import DeviceStatus

    view = window.panels["mwir"].view
    cs = CameraStatus("mwir", DeviceStatus("mwir"), FrameAccounting(), gps_xy=(12.0, 7.5))
    view.show_status(cs)
    assert view.gps_marker.isVisible()
    assert view.gps_marker.centre() == (
        12.5,
        8.0,
    )  # the centre of pixel (12, 7.5) in image coordinates
    view.show_status(CameraStatus("mwir", DeviceStatus("mwir"), FrameAccounting()))
    assert not view.gps_marker.isVisible()


def test_measured_noise_in_a_replay_goes_to_its_model_unrecorded(qtbot, window, player):
    """The operator's "measured noise" on a replay: the replayed 3D noise of the background
    around the track becomes the model's noise (the player records nothing: it cannot)."""
    from snrmon.gui.model_curves import ModelOptions

    player.set_speed(100.0)
    window.replay_toggle()
    qtbot.waitUntil(lambda: not player.position().playing, timeout=20_000)  # the end
    region = player.status().cameras["mwir"].figures.noise_3d
    assert region is not None
    sigma = region.noise.sigma_corrected
    # the recording's sky noise: white, rounded to counts; 100 frames of a 10 x 40 px band
    # clear of the spot pin sigma_tvh to ~0.4 % (1 sigma): 2 % is far outside chance
    assert sigma["tvh"] == pytest.approx((NOISE_DN**2 + 1 / 12) ** 0.5, rel=0.02)
    assert region.region == (0, 0, SPOT_XY[0] - 21, 39)
    assert window.apply_model_options(ModelOptions(noise="measured")) is None
    noise = player.measured_noise["mwir"]
    assert (noise.temporal_dn, noise.spatial_dn) == (sigma["tvh"], sigma["vh"])
    assert player.predictor is window.model.sky
    assert window.model.sky.measured_noise == window.model.own.measured_noise == {"mwir": noise}
    assert "mwir: noise sigma_tvh" in window.messages[-1]
    assert window.apply_model_options(ModelOptions()) is None
    assert player.measured_noise == {} and window.model.sky.measured_noise == {}
