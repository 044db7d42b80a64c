"""The console on a real Session fed by a simulated shared-memory camera (offscreen, pytest-qt).

The camera is the real path: a producer process writes a frame ring, ``ShmCamera`` reads it, the
session measures every frame; the console only peeks and displays.
"""

from __future__ import annotations

import os
import shutil
import uuid

import numpy as np
import pytest
from PySide6.QtCore import QSettings, Qt
from PySide6.QtGui import QImage

from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.record.reader import open_session
from snrmon.acquisition.runtime.session import Session
from snrmon.drivers.camera.shm import ShmCamera
from snrmon.gui.app import console_application, run_console
from snrmon.gui.main_window import ConsoleWindow
from snrmon.sim.devices.shm_camera import ShmProducer
from tests import helpers

W, H = 160, 128
SPOT_X, SPOT_Y = 100, 60
SKY_DN, NOISE_DN, SPOT_DN = 1000.0, 8.0, 400.0


def console_render(seed: int = 7) -> helpers.SpotOnNoise:
    """The console tests' render: a Gaussian spot (sigma 0.8 px) at (SPOT_X, SPOT_Y) on seeded
    noise, a picklable instance of the helpers' render (whose module the camera process
    imports without Qt)."""
    return helpers.SpotOnNoise(
        seed,
        width=W,
        height=H,
        spot_x=SPOT_X,
        spot_y=SPOT_Y,
        amplitude_dn=SPOT_DN,
        sigma_px=0.8,
        sky_dn=SKY_DN,
        noise_dn=NOISE_DN,
    )


def curves(camera: str) -> dict:
    """Stand-in model curves (the GUI draws what it is given; the model computes them)."""
    r = np.linspace(100.0, 3000.0, 30)
    return {"small": (r, 5e4 / r), "band": (r, 4e4 / r, 6e4 / r)}


@pytest.fixture
def rig():
    name = f"snrmon-guitest-{uuid.uuid4().hex[:10]}"
    producer = ShmProducer(name, W, H, console_render(), fps=60.0)
    producer.start()
    config = session_config_from_dict(
        {"cameras": {"mwir": {"source": "shm", "address": name, "width_px": W, "height_px": H}}}
    )
    camera = ShmCamera("mwir", name, stale_after_s=0.5)
    session = Session(config, cameras={"mwir": camera}, shapes={"mwir": (H, W)})
    session.start()
    try:
        yield session, producer
    finally:
        session.stop()
        producer.close()


@pytest.fixture
def window(qtbot, rig, tmp_path):
    console_application(headless=True)
    session, _ = rig
    settings = QSettings(str(tmp_path / "console.ini"), QSettings.Format.IniFormat)
    win = ConsoleWindow(session, curves=curves, settings=settings)
    qtbot.addWidget(win)
    win.set_size(1400, 900)
    win.show()
    qtbot.waitUntil(lambda: win.panels["mwir"].view.frames_shown > 3, timeout=10_000)
    return win


def _click_pixel(qtbot, win: ConsoleWindow, x: int, y: int) -> None:
    view = win.panels["mwir"].view
    pos = view.viewport_pos_of_pixel(x, y)
    qtbot.mouseClick(view.graphics.viewport(), Qt.MouseButton.LeftButton, pos=pos)


def test_click_on_the_spot_sets_the_roi_and_feeds_the_chart(qtbot, window, rig):
    session, _ = rig
    _click_pixel(qtbot, window, SPOT_X, SPOT_Y)
    qtbot.waitUntil(
        lambda: session.status().cameras["mwir"].roi_xy == (SPOT_X, SPOT_Y), timeout=5000
    )
    chart = window.panels["mwir"].chart
    qtbot.waitUntil(lambda: chart.points_drawn >= 20, timeout=10_000)
    last = session.status().cameras["mwir"].last.result
    assert (last.peak_x, last.peak_y) == (SPOT_X, SPOT_Y)
    # a 400 DN spot (~ 400 * 0.46 in the peak pixel after noise) on 8 DN noise: SNR well above 5
    assert last.snr > 5.0
    # the inset shows the box centred on that peak, cut from the displayed frame
    qtbot.waitUntil(lambda: window.panels["mwir"].inset.grid.values is not None, timeout=5000)
    box = window.panels["mwir"].inset.grid.values
    assert box.shape == (7, 7) and np.nanargmax(box) == 24  # the centre cell is the brightest


def test_click_off_the_image_sets_no_roi(qtbot, window, rig):
    session, _ = rig
    view = window.panels["mwir"].view
    view.view.setRange(xRange=(-200, W + 200), yRange=(-200, H + 200), padding=0)
    qtbot.wait(50)  # let the new range reach the scene transform (not a synchronisation)
    assert (
        view.click_at_scene(
            view.view.mapViewToScene(view.view.mapToView(view.view.boundingRect().topLeft()))
        )
        is None
    )
    assert session.status().cameras["mwir"].roi_xy is None


def test_recording_from_the_console_creates_a_session_file(qtbot, window, tmp_path):
    path = tmp_path / "run.h5"
    assert window.start_recording(path)
    assert not window.actions_by_key["record_start"].isEnabled()
    qtbot.waitUntil(
        lambda: window.session.status().cameras["mwir"].frames.written >= 30, timeout=10_000
    )
    window.add_note("drone hovering at the first stop")
    window.actions_by_key["record_stop"].trigger()
    assert window.actions_by_key["record_start"].isEnabled()
    with open_session(path) as f:
        assert f.complete
        assert f.cameras["mwir"].n_frames >= 30
        assert f.cameras["mwir"].frame(0).shape == (H, W)
    # The recording's log beside it keeps what the operator did and was told.
    log = (tmp_path / "run.log").read_text()
    assert f"snrmon.gui.main_window: recording to {path}" in log
    assert "note: drone hovering at the first stop" in log


def test_release_event_and_reselect_keys_go_into_the_record(qtbot, window, tmp_path):
    """Esc releases the active camera's track, E marks an event, T sets the ROI again at the
    last peak: each is recorded (roi_cleared, note, roi_set) at the frame it took effect on."""
    path = tmp_path / "keys.h5"
    window.set_roi("mwir", SPOT_X, SPOT_Y)
    assert window.start_recording(path)
    qtbot.waitUntil(lambda: window.session.status().cameras["mwir"].frames.written >= 5)
    window.refresh_status()
    window.actions_by_key["release"].trigger()
    qtbot.waitUntil(
        lambda: window.session.status().cameras["mwir"].track_state.value == "idle", timeout=5000
    )
    window.actions_by_key["event"].trigger()
    window.refresh_status()
    window.actions_by_key["reselect"].trigger()
    qtbot.waitUntil(
        lambda: window.session.status().cameras["mwir"].track_state.value == "tracking",
        timeout=5000,
    )
    assert f"mwir: track re-selected at the last peak (column {SPOT_X}, row {SPOT_Y})" in (
        window.messages
    )
    window.stop_recording()
    with open_session(path) as f:
        events = [(e["kind"], e["camera"], e["payload"]) for e in f.event_list()]
    kinds = [(k, c) for k, c, _ in events]
    released = kinds.index(("roi_cleared", "mwir"))
    event = events.index(("note", "", {"text": "event"}))
    reselected = [i for i, k in enumerate(kinds) if k == ("roi_set", "mwir") and i > released]
    assert released < event < reselected[0]
    payload = events[reselected[0]][2]
    assert (payload["x"], payload["y"]) == (SPOT_X, SPOT_Y)
    # each at the frame it took effect on, in the frames' order
    assert events[released][2]["counter"] < payload["counter"]


def test_marked_stop_fills_the_stop_table(qtbot, window):
    window.set_roi("mwir", SPOT_X, SPOT_Y)
    window.mark_stop()
    qtbot.waitUntil(lambda: len(window.stop_table.cells()) == 1, timeout=5000)
    assert window.stop_table.cells()[0][:2] == ["0 M", "mwir"]
    qtbot.waitUntil(lambda: int(window.stop_table.cells()[0][4]) > 0, timeout=10_000)


def test_alarm_when_the_camera_stops_and_cleared_when_it_returns(qtbot, window, rig):
    _, producer = rig
    banner = window.banner
    assert not banner.isVisible()
    producer.pause()
    qtbot.waitUntil(lambda: "mwir" in banner.tracker.active, timeout=10_000)
    assert banner.isVisible() and banner.text().startswith("ALARM") and "mwir" in banner.text()
    producer.resume()
    qtbot.waitUntil(lambda: not banner.tracker.active, timeout=15_000)
    assert banner.isVisible() and banner.text().startswith("BACK") and "mwir" in banner.text()
    assert [m.split()[0] for _, m in banner.tracker.log] == ["LOST", "BACK"]


def _check_png(path) -> None:
    img = QImage(str(path))
    assert not img.isNull() and img.width() >= 800 and img.height() >= 500
    small = img.scaled(200, 120)
    colours = {small.pixel(x, y) for x in range(200) for y in range(120)}
    assert len(colours) > 50, "the screenshot is (nearly) uniform"


def test_screenshot_of_the_main_window(qtbot, window, tmp_path):
    window.set_roi("mwir", SPOT_X, SPOT_Y)
    qtbot.waitUntil(lambda: window.panels["mwir"].chart.points_drawn >= 30, timeout=10_000)
    window.refresh_status()
    path = window.save_screenshot(tmp_path / "console.png")
    assert path is not None and path.stat().st_size > 20_000
    _check_png(path)
    out_dir = os.environ.get("SNRMON_SCREENSHOT_DIR")
    if out_dir:
        os.makedirs(out_dir, exist_ok=True)
        shutil.copy(path, os.path.join(out_dir, "console.png"))


def test_run_console_headless_for_a_duration_saves_a_screenshot(qtbot, rig, tmp_path):
    session, _ = rig
    session.set_roi("mwir", SPOT_X, SPOT_Y)
    png = tmp_path / "run.png"
    settings = QSettings(str(tmp_path / "run.ini"), QSettings.Format.IniFormat)
    rc = run_console(
        session, curves=curves, headless=True, duration_s=1.0, screenshot=png, settings=settings
    )
    assert rc == 0
    _check_png(png)
    assert settings.value("window/geometry") is not None  # layout remembered


def test_run_console_refuses_a_bad_duration(rig):
    with pytest.raises(ValueError, match="duration"):
        run_console(rig[0], duration_s=0)


def test_the_status_bar_counts_frames_shown_against_frames_delivered(qtbot, window):
    """Every frame the camera delivers is offered to the view once; the status bar says how
    many of them were shown (all, unless the event loop fell a whole frame behind)."""
    label = window.display_label
    qtbot.waitUntil(
        lambda: label.text().startswith("frames shown/delivered per s: MWIR"), timeout=5000
    )
    feed = window.feeds["mwir"]
    assert 0 < feed.shown <= feed.delivered
    assert window.panels["mwir"].view.frames_shown == feed.shown
    shown, delivered = window.display_rates.sample(window.feeds)["mwir"]
    assert 0 < shown <= delivered


def test_the_status_refresh_is_spread_in_steps_and_says_when_it_is_whole(qtbot, window):
    """The status timer runs one step of a refresh at a time (the session's panels, the
    camera's panels, its chart), evenly over 200 ms; once the last step has run, every panel
    shows the snapshot the window holds, and it says so (the status file is written then)."""
    _click_pixel(qtbot, window, SPOT_X, SPOT_Y)
    qtbot.waitUntil(lambda: window.panels["mwir"].chart.points_drawn >= 20, timeout=10_000)
    status_timer = window._timers[1]
    assert status_timer.interval() == 200 // 3  # one camera: three steps
    headers = []

    def whole() -> None:
        cam = window.last_status.cameras["mwir"]
        headers.append((window.panels["mwir"].header.text(), cam.last.snr_mean, cam.snr_sem))

    window.status_refreshed.connect(whole)
    qtbot.waitUntil(lambda: len(headers) >= 3, timeout=5000)
    for text, mean, sem in headers:  # each header from the snapshot the window holds
        assert f"SNR(100) ± error {mean:.2f} ± {sem:.2f}" in text
    window.status_refreshed.disconnect(whole)
    status_timer.stop()
    told: list[None] = []

    def tell() -> None:  # no reference to the window: no cycle for the collector to free
        told.append(None)

    window.status_refreshed.connect(tell)
    window.refresh_status()  # an action's immediate refresh is whole at once, and says so
    window.status_refreshed.disconnect(tell)
    assert len(told) == 1


def test_the_console_s_pixmap_cache_holds_its_cached_plot_items():
    """Qt's default 10 MB pixmap cache held less than a 1920x1080 console's cached axes and
    curves (evicted, they were drawn afresh at each repaint): the console's application gives
    it twelve screens of 32-bit pixels."""
    from PySide6.QtGui import QPixmapCache

    from snrmon.gui.app import PIXMAP_CACHE_SCREENS

    app = console_application(headless=True)
    size = app.primaryScreen().size()
    screens_kb = PIXMAP_CACHE_SCREENS * size.width() * size.height() * 4 // 1024
    assert QPixmapCache.cacheLimit() == max(screens_kb, 10240) > 10240
