"""Model options and the noise panel of the console (offscreen, pytest-qt).

The curves drawn must be ModelPredictor's own numbers for the chosen target, curves and
background; a bad background temperature is refused with a message and changes nothing; the
noise panel shows the processing side's section 6 figures and 3D noise.
"""

from __future__ import annotations

import dataclasses
import math
import uuid

import numpy as np
import pytest
from PySide6.QtCore import QSettings, Qt

from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.prediction import ModelPredictor
from snrmon.acquisition.runtime.session import Session
from snrmon.drivers.camera.shm import ShmCamera
from snrmon.gui.app import console_application
from snrmon.gui.main_window import ConsoleWindow
from snrmon.gui.model_curves import ModelOptions
from snrmon.sim.devices.shm_camera import ShmProducer
from tests.gui.test_console import NOISE_DN, SPOT_X, SPOT_Y, H, W, console_render


@pytest.fixture
def window(qtbot, tmp_path):
    name = f"snrmon-modeltest-{uuid.uuid4().hex[:10]}"
    producer = ShmProducer(name, W, H, console_render(), fps=60.0)
    producer.start()
    config = session_config_from_dict(
        {"cameras": {"mwir": {"source": "shm", "address": name, "width_px": W, "height_px": H}}}
    )
    predictor = ModelPredictor({"mwir": "mwir"}, "uav1")
    session = Session(
        config,
        cameras={"mwir": ShmCamera("mwir", name)},
        shapes={"mwir": (H, W)},
        predictor=predictor,
    )
    session.start()
    console_application(headless=True)
    settings = QSettings(str(tmp_path / "console.ini"), QSettings.Format.IniFormat)
    win = ConsoleWindow(session, curves=predictor.curve, settings=settings)
    qtbot.addWidget(win)
    win.show()
    try:
        yield win
    finally:
        win.close()
        session.stop()
        producer.close()


def _drawn(win: ConsoleWindow, name: str) -> tuple[np.ndarray, np.ndarray]:
    return win.range_plots["mwir"].curve_items[name].getData()


def test_applying_model_options_redraws_the_predictors_curves(window):
    plot = window.range_plots["mwir"]
    assert {"small", "large", "small_corrected", "large_corrected"} <= set(plot.curve_items)
    uav1 = ModelPredictor({"mwir": "mwir"}, "uav1").curve("mwir")
    x, y = _drawn(window, "small_corrected")
    np.testing.assert_allclose(y, uav1["small_corrected"][1])

    options = ModelOptions(target="uav2", shown=("small_corrected",), background_temp_k=280.0)
    assert window.apply_model_options(options) is None
    want = ModelPredictor({"mwir": "mwir"}, "uav2", background_temp_k=280.0).curve("mwir")
    names = {n for n in plot.curve_items if not n.endswith((" low", " high"))}
    assert names == {"small_corrected", "small_corrected band"}
    x, y = _drawn(window, "small_corrected")
    np.testing.assert_allclose(x, want["small_corrected"][0])
    np.testing.assert_allclose(y, want["small_corrected"][1])
    assert not np.allclose(y, uav1["small_corrected"][1])  # another target, another curve
    _, lo = _drawn(window, "small_corrected band low")
    np.testing.assert_allclose(lo, want["small_corrected band"][1])
    # the session's engine built the model the dialog asked for; its stop table asks it, and
    # the console holds no predictor of its own (it reads the engine's two)
    engine = window.session.engine
    assert engine.predictor is window.model.sky and engine.reference_predictor is window.model.own
    assert window.session.stop_table.predictor is window.model.sky
    assert engine.predictor.background_temp_k["mwir"] == 280.0
    assert engine.predictor.target.name == engine.reference_predictor.target.name == "uav2"
    assert not [v for v in vars(window.model).values() if isinstance(v, ModelPredictor)]


def test_the_dialog_refuses_a_bad_temperature_with_a_message(qtbot, window):
    dialog = window.model_options()
    before = _drawn(window, "small")[1].copy()
    for bad, why in (("warm", "number of kelvin"), ("-5", "> 0 K"), ("nan", "> 0 K")):
        dialog.background.setText(bad)
        dialog.target.setCurrentText("uav2")
        qtbot.mouseClick(dialog.apply_button, Qt.MouseButton.LeftButton)
        assert why in dialog.error.text() and repr(bad) in dialog.error.text()
        np.testing.assert_array_equal(_drawn(window, "small")[1], before)
    dialog.target.setCurrentText("uav9")  # the model refuses an unknown target
    dialog.background.setText("")
    qtbot.mouseClick(dialog.apply_button, Qt.MouseButton.LeftButton)
    assert "uav9" in dialog.error.text() and "model options refused" in window.messages[-1]
    dialog.target.setCurrentText("uav2")
    dialog.shown["large"].setChecked(False)
    qtbot.mouseClick(dialog.apply_button, Qt.MouseButton.LeftButton)
    assert dialog.error.text() == ""
    assert "large" not in window.range_plots["mwir"].curve_items
    want = ModelPredictor({"mwir": "mwir"}, "uav2").curve("mwir")["small"][1]
    np.testing.assert_allclose(_drawn(window, "small")[1], want)


def test_a_measured_sky_adds_the_curves_at_that_background(window):
    """The session's engine follows the measured sky (as it does for a calibrated camera, or as
    a replay applies the recorded change); the console draws the curves at it and never sets
    the sky itself: a model rebuilt from the options takes the followed sky over."""
    session = window.session
    session.engine.set_background("mwir", 255.0)
    assert session.model_sky_temp_k("mwir") == 255.0
    window.refresh_status()
    plot = window.range_plots["mwir"]
    sky = ModelPredictor({"mwir": "mwir"}, "uav1", background_temp_k=255.0).curve("mwir")
    own = ModelPredictor({"mwir": "mwir"}, "uav1").curve("mwir")
    np.testing.assert_allclose(
        _drawn(window, "small_corrected @ sky 255.0 K")[1], sky["small_corrected"][1]
    )
    np.testing.assert_allclose(_drawn(window, "small_corrected")[1], own["small_corrected"][1])
    assert not np.allclose(sky["small_corrected"][1], own["small_corrected"][1])
    assert "large @ sky 255.0 K" in plot.curve_items

    assert window.apply_model_options(ModelOptions(target="uav2")) is None
    assert session.predictor is window.model.sky
    assert window.model.sky.background_temp_k["mwir"] == 255.0  # carried over by the engine
    assert window.model.own.background_temp_k["mwir"] is None  # the model's own background


def test_noise_panel_shows_the_rendered_noise_split_and_3d(qtbot, window):
    window.set_roi("mwir", SPOT_X, SPOT_Y)
    label = window.noise_panel.labels[("mwir", "noise_temporal_dn")]
    qtbot.waitUntil(lambda: label.text() != "--", timeout=10_000)
    # 8 DN rendered noise (+ rounding), no fixed pattern: 10 % is > 5 sigma for 1632 pixels
    assert float(label.text()) == pytest.approx((NOISE_DN**2 + 1 / 12) ** 0.5, rel=0.10)
    spatial = float(window.noise_panel.labels[("mwir", "noise_spatial_dn")].text())
    # no pattern: total^2 - temporal^2 is noise of ~3 DN^2 (1 sigma) around 0; 16 DN^2 is 5 sigma
    assert spatial < 0.5 * NOISE_DN
    assert "sqrt(2)" in label.toolTip() and "DN" in label.toolTip()

    # beside it, the 3D noise of the background clear of the drone
    label = window.noise_panel.labels[("mwir", "noise_3d_tvh")]
    qtbot.waitUntil(lambda: label.text() != "--", timeout=15_000)
    st = window.session.status().cameras["mwir"].figures.noise_3d
    # the largest band clear of the spot by 20 px: the 80 columns left of it, full height
    assert st.region == (0, 0, SPOT_X - 21, H - 1)
    assert (st.noise.frames, st.noise.rows, st.noise.cols) == (100, H, SPOT_X - 20)
    # independent white noise of 8 DN, rounded: sigma_tvh = sqrt(64 + 1/12) DN; the interval
    # standard error over ~1e6 degrees of freedom is 0.07 %: 1 % is far outside chance
    tvh = float(label.text())
    assert tvh == pytest.approx((NOISE_DN**2 + 1 / 12) ** 0.5, rel=0.01)
    for comp in ("t", "v", "h", "tv", "th", "vh"):  # none rendered: each within noise of 0
        assert float(window.noise_panel.labels[("mwir", f"noise_3d_{comp}")].text()) < 0.3
    assert "95 % interval" in label.toolTip() and "100 frames" in label.toolTip()


def test_model_options_are_remembered_for_the_next_start(qtbot, window):
    options = ModelOptions(
        target="uav2", shown=("small", "large_corrected"), background_temp_k=262.5
    )
    # the noise choice is not remembered (like the met readings: the session's cameras')
    assert window.apply_model_options(dataclasses.replace(options, noise="measured")) is None
    # A new console on the same settings (the next start) draws the same model.
    again = ConsoleWindow(window.session, settings=window.settings)
    qtbot.addWidget(again)
    assert again.model.options == options and again.model.options.noise == "model"
    want = ModelPredictor({"mwir": "mwir"}, "uav2", background_temp_k=262.5).curve("mwir")
    _, y = again.range_plots["mwir"].curve_items["large_corrected"].getData()
    np.testing.assert_allclose(y, want["large_corrected"][1])
    assert "small_corrected" not in again.range_plots["mwir"].curve_items
    # A damaged entry is reported by name and the model's defaults stay.
    window.settings.setValue("model/background_temp_k", "warm")
    third = ConsoleWindow(window.session, settings=window.settings)
    qtbot.addWidget(third)
    assert any("saved model options ignored" in m and "'warm'" in m for m in third.messages)
    assert third.model.options == ModelOptions()


def test_the_dialog_takes_the_days_met_readings_and_the_session_records_them(
    qtbot, window, tmp_path
):
    """The operator types today's readings: the curves are the model's through that air, the
    session's stop table asks the same model, and the recording holds the readings."""
    from snrmon.acquisition.prediction import Weather
    from snrmon.acquisition.record.reader import open_session

    session = window.session
    session.start_recording(tmp_path / "met.h5")
    dialog = window.model_options()
    for key, text in (("air_temp_c", "28"), ("rh_percent", "95"), ("visibility_km", "8")):
        dialog.met[key].setText(text)
    dialog.season.setCurrentText("midlat_summer")
    qtbot.mouseClick(dialog.apply_button, Qt.MouseButton.LeftButton)
    assert dialog.error.text() == ""
    want = Weather(air_temp_c=28.0, rh_percent=95.0, visibility_km=8.0, season="midlat_summer")
    assert window.model.options.weather == want and session.met_readings == want
    assert session.predictor is window.model.sky and window.model.sky.weather["mwir"] == want
    through = ModelPredictor({"mwir": "mwir"}, "uav1", atmosphere=want).curve("mwir")
    _, y = _drawn(window, "small_corrected")
    np.testing.assert_allclose(y, through["small_corrected"][1])
    default = ModelPredictor({"mwir": "mwir"}, "uav1").curve("mwir")
    assert np.all(y[-50:] < default["small_corrected"][1][-50:])  # humid hazy air, far out
    # a bad reading is refused, naming it; nothing changes
    dialog.met["rh_percent"].setText("wet")
    qtbot.mouseClick(dialog.apply_button, Qt.MouseButton.LeftButton)
    assert "relative humidity must be a number of % (or empty), got 'wet'" in dialog.error.text()
    dialog.met["rh_percent"].setText("120")
    qtbot.mouseClick(dialog.apply_button, Qt.MouseButton.LeftButton)
    assert "relative humidity must be 0 to 100 %, got 120" in dialog.error.text()
    assert session.met_readings == want
    session.stop_recording()
    with open_session(tmp_path / "met.h5") as f:
        events = [e["payload"] for e in f.event_list() if e["kind"] == "met_readings"]
    assert events == [want.as_dict()]


def _frozen_status(monkeypatch, session, **noise_3d) -> None:
    """The session's status as it is now, held (the next 100 frames' 3D noise would replace
    the figures the test compares with); ``noise_3d``: a camera's 3D noise replaced."""
    st = session.status()
    cams = {
        n: dataclasses.replace(c, figures=dataclasses.replace(c.figures, noise_3d=noise_3d[n]))
        if n in noise_3d
        else c
        for n, c in st.cameras.items()
    }
    frozen = dataclasses.replace(st, cameras=cams)
    monkeypatch.setattr(session, "status", lambda: frozen)


def test_measured_noise_without_a_3d_noise_yet_keeps_the_models_curves(qtbot, window, monkeypatch):
    """No track, no 3D noise: the camera is named and keeps the model's noise; a 3D noise of
    0 DN (a flat band) likewise; an unknown choice is refused."""
    assert window.session.status().cameras["mwir"].figures.noise_3d is None  # nothing tracked
    before = _drawn(window, "small_corrected")[1].copy()
    dialog = window.model_options()
    assert dialog.noise.currentText() == "model"
    assert [dialog.noise.itemText(i) for i in range(dialog.noise.count())] == ["model", "measured"]
    tip = dialog.noise.toolTip()
    assert "sigma_tvh" in tip and "sigma_vh" in tip and "bias-corrected" in tip and "100" in tip
    dialog.noise.setCurrentText("measured")
    qtbot.mouseClick(dialog.apply_button, Qt.MouseButton.LeftButton)
    assert dialog.error.text() == ""
    assert window.messages[-1].endswith(
        "mwir: no 3D noise yet (100 frames of background): the model's noise kept"
    )
    assert "noise measured (3D noise)" in window.messages[-1]
    assert window.model.options.noise == "measured"
    assert window.session.measured_noise == {} and window.model.sky.measured_noise == {}
    np.testing.assert_allclose(_drawn(window, "small_corrected")[1], before, rtol=1e-12)

    from snrmon.acquisition.measure.noise3d import FIGURES, Noise3d
    from snrmon.acquisition.measure.track_noise import RegionNoise3d

    zeros = dict.fromkeys(FIGURES, 0.0)
    flat = Noise3d(100, 40, 40, 1000.0, zeros, zeros, dict.fromkeys(FIGURES, (0.0, 0.0)), {})
    _frozen_status(monkeypatch, window.session, mwir=RegionNoise3d((0, 0, 39, 39), flat))
    qtbot.mouseClick(dialog.apply_button, Qt.MouseButton.LeftButton)
    assert window.messages[-1].endswith(
        "mwir: measured noise of 0 DN: the SNR would be infinite: the model's noise kept"
    )
    assert window.session.measured_noise == {}
    np.testing.assert_allclose(_drawn(window, "small_corrected")[1], before, rtol=1e-12)
    with pytest.raises(ValueError, match="noise must be one of model, measured, got 'mesured'"):
        ModelOptions(noise="mesured")


def test_measured_noise_reaches_the_curves_and_the_session_records_it(
    qtbot, window, monkeypatch, tmp_path
):
    """With a 3D noise measured around the track, "measured" scales every curve by the model's
    noise over sqrt(sigma_tvh^2 + sigma_vh^2) x the sensor's gain, the session's stop table asks
    the same model, and the recording holds the camera's figures; "model" goes back."""
    from snrmon.acquisition.record.reader import open_session
    from snrmon.model.presets import load_sensor, load_target
    from snrmon.model.snr import predict

    session = window.session
    session.start_recording(tmp_path / "noise.h5")
    window.set_roi("mwir", SPOT_X, SPOT_Y)
    qtbot.waitUntil(
        lambda: session.status().cameras["mwir"].figures.noise_3d is not None, timeout=15_000
    )
    _frozen_status(monkeypatch, session)
    sigma = session.status().cameras["mwir"].figures.noise_3d.noise.sigma_corrected
    tvh, vh = sigma["tvh"], sigma["vh"]
    # the rendered white noise of 8 DN (rounded): sigma_tvh ~ 8 DN, sigma_vh ~ 0
    assert tvh == pytest.approx((NOISE_DN**2 + 1 / 12) ** 0.5, rel=0.01) and vh < 0.3
    model = {n: _drawn(window, n)[1].copy() for n in ("small", "small_corrected")}

    dialog = window.model_options()
    dialog.noise.setCurrentText("measured")
    qtbot.mouseClick(dialog.apply_button, Qt.MouseButton.LeftButton)
    assert dialog.error.text() == ""
    assert f"mwir: noise sigma_tvh {tvh:.3g} DN, sigma_vh {vh:.3g} DN" in window.messages[-1]
    # Eq. 3: signal / noise, so the curves scale by (model's noise) / (measured noise, e-)
    sensor = load_sensor("mwir")
    own = predict(sensor, load_target("uav1"), [500.0], band=False, expected=False)
    ratio = own.noise.total / (math.hypot(tvh, vh) * 109.0)  # the MWIR preset's 109 e-/DN
    assert sensor.gain_e_per_dn == 109.0 and 0.5 < ratio < 2.0
    for name, y in model.items():
        np.testing.assert_allclose(_drawn(window, name)[1], y * ratio, rtol=1e-9, err_msg=name)
    assert session.predictor is window.model.sky
    want = {"mwir": (tvh, vh)}
    for predictor in (window.model.own, window.model.sky):
        got = {c: (n.temporal_dn, n.spatial_dn) for c, n in predictor.measured_noise.items()}
        assert got == want
    assert {c: (n.temporal_dn, n.spatial_dn) for c, n in session.measured_noise.items()} == want

    dialog.noise.setCurrentText("model")
    qtbot.mouseClick(dialog.apply_button, Qt.MouseButton.LeftButton)
    assert session.measured_noise == {} and window.model.sky.measured_noise == {}
    for name, y in model.items():
        np.testing.assert_allclose(_drawn(window, name)[1], y, rtol=1e-12, err_msg=name)
    assert "noise the model's own" in window.messages[-1]
    session.stop_recording()
    with open_session(tmp_path / "noise.h5") as f:
        events = [(e["camera"], e["payload"]) for e in f.event_list() if e["kind"] == "model_noise"]
    assert events == [("mwir", {"temporal_dn": tvh, "spatial_dn": vh}), ("mwir", {})]


def test_each_camera_s_noise_is_taken_or_the_camera_named():
    """Two cameras, one with a 3D noise of its background, one without: the first's figures
    become its measured noise, the second keeps the model's and is named (no Qt needed)."""
    from types import SimpleNamespace

    from snrmon.acquisition.engine.status import AnalysisFigures, CameraStatus, FrameAccounting
    from snrmon.acquisition.measure.noise3d import FIGURES, Noise3d
    from snrmon.acquisition.measure.track_noise import RegionNoise3d
    from snrmon.drivers.device import DeviceStatus
    from snrmon.gui.model_curves import describe_noise, measured_noise_now

    sigma = {**dict.fromkeys(FIGURES, 0.1), "tvh": 6.62, "vh": 1.35}
    noise = Noise3d(100, 64, 64, 1000.0, sigma, sigma, dict.fromkeys(FIGURES, (0.0, 1.0)), {})
    figures = AnalysisFigures(noise_3d=RegionNoise3d((0, 0, 63, 63), noise))
    cameras = {
        "mwir": CameraStatus("mwir", DeviceStatus("mwir"), FrameAccounting(), figures=figures),
        "lwir": CameraStatus("lwir", DeviceStatus("lwir"), FrameAccounting()),
    }
    session = SimpleNamespace(
        config=SimpleNamespace(cameras=[SimpleNamespace(name=c, sensor=c) for c in cameras]),
        status=lambda: SimpleNamespace(cameras=cameras),
    )
    assert measured_noise_now(session, ModelOptions()) == ({}, {})  # "model": nothing taken
    got, kept = measured_noise_now(session, ModelOptions(noise="measured"))
    assert {c: (n.temporal_dn, n.spatial_dn) for c, n in got.items()} == {"mwir": (6.62, 1.35)}
    assert describe_noise(got, kept) == (
        "mwir: noise sigma_tvh 6.62 DN, sigma_vh 1.35 DN; "
        "lwir: no 3D noise yet (100 frames of background): the model's noise kept"
    )
