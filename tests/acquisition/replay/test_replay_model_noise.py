"""The operator's "measured noise" (a camera's 3D noise in place of the model's noise): a live
session hands it to its model and records it (a ``model_noise`` event), and a replay of the
recording applies it at the same time, so the replayed stop table's model values are the live
ones on both sides of the change; a replay player applies it without recording."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from snrmon.acquisition.prediction import MeasuredNoise, ModelPredictor
from snrmon.acquisition.record.reader import open_session
from snrmon.acquisition.replay.batch import replay_session
from snrmon.acquisition.replay.player import ReplayPlayer
from snrmon.acquisition.replay.recorded import recorded_inputs
from snrmon.acquisition.runtime.session import Session
from snrmon.acquisition.stops.detector import StopConfig
from snrmon.model.presets import load_sensor, load_target
from snrmon.model.snr import predict
from snrmon.sim.devices.ldm_sim import LdmSimulator
from snrmon.sim.devices.shm_camera import ShmProducer
from tests.acquisition.session_factory import write_session
from tests.helpers import SPOT_X, SPOT_Y, H, SpotOnNoise, W, shm_camera_config, wait_until

GRID = np.geomspace(100.0, 2000.0, 12)  # a few ranges keep the model's build fast
RANGE_M = 300.0
NOISE = MeasuredNoise(temporal_dn=7.5, spatial_dn=2.0)


def _predictor() -> ModelPredictor:
    return ModelPredictor({"mwir": "mwir"}, "uav1", ranges_m=GRID)


@pytest.fixture
def live(tmp_path):
    name = f"snrmon-noise-{time.monotonic_ns() % 10**9}"
    producer = ShmProducer(name, W, H, SpotOnNoise(7), fps=60.0, slots=32)
    producer.start()
    lrf = LdmSimulator(lambda t: RANGE_M, rate_hz=20.0, tracking=True).start()
    config = shm_camera_config(name, lrf={"protocol": "ldm", "port": lrf.path, "baud": 9600})
    # stops only where the operator marks them (the steady range would open one after 3 s)
    session = Session(config, predictor=_predictor(), stop_config=StopConfig(steady_s=600.0))
    try:
        yield session, tmp_path / "noise.h5"
    finally:
        session.stop()
        producer.stop()
        lrf.stop()


def _row(session: Session, stop: int):
    rows = [r for r in session.stops() if r.stop == stop]
    return rows[0] if rows else None


def _filled(session: Session, stop: int) -> bool:
    row = _row(session, stop)
    return row is not None and row.reading.n_frames >= 10 and row.place.lrf_range_m is not None


def _final(session: Session, stop: int) -> bool:
    row = _row(session, stop)
    return row is not None and row.final


def test_a_replay_applies_the_recorded_noise_where_the_live_session_did(live):
    session, path = live
    session.start()
    session.start_recording(path)
    session.set_roi("mwir", SPOT_X, SPOT_Y)
    session.mark_stop()  # stop 0: the model's noise
    wait_until(lambda: _filled(session, 0), 15.0, "stop 0's frames and range")
    session.mark_stop()  # stop 1 (stop 0 ends)
    wait_until(lambda: _final(session, 0) and _filled(session, 1), 15.0, "stop 0's final row")
    session.set_measured_noise("mwir", NOISE)
    # stop 1 ends at once: the first frame after the change is the one that freezes its row
    session.mark_stop()  # stop 2 (stop 1 ends)
    assert session.measured_noise == {"mwir": NOISE}
    assert session.predictor is not None and session.predictor.measured_noise == {"mwir": NOISE}
    wait_until(lambda: _final(session, 1), 15.0, "stop 1's final row")
    live_rows = [_row(session, 0), _row(session, 1)]
    session.stop_recording()
    session.stop()

    with open_session(path) as f:
        events = [e for e in f.event_list() if e["kind"] == "model_noise"]
        ends = {
            e["payload"]["stop"]: e["t_host_ns"]
            for e in f.event_list()
            if e["kind"] == "stop_ended"
        }
    assert [(e["camera"], e["payload"]) for e in events] == [
        ("mwir", {"temporal_dn": 7.5, "spatial_dn": 2.0})
    ]
    # at the last frame measured before the change: after stop 0's end, before stop 1's
    assert ends[0] < events[0]["t_host_ns"] < ends[1]

    # Eq. 3: the stop after the change reads the model's SNR times (the model's noise) /
    # (the measured noise in electrons: sqrt(7.5^2 + 2^2) DN x the preset's gain)
    before, after = (r.model.model_snr for r in live_rows)
    assert all(r.place.lrf_range_m == pytest.approx(RANGE_M, abs=0.01) for r in live_rows)
    gain = load_sensor("mwir").gain_e_per_dn
    model_noise_e = predict(
        load_sensor("mwir"), load_target("uav1"), [RANGE_M], band=False, expected=False
    )
    ratio = model_noise_e.noise.total / (math.hypot(7.5, 2.0) * gain)
    for name in ("small", "large", "small_corrected", "large_corrected"):
        assert after[name] == pytest.approx(before[name] * ratio, rel=1e-9), name

    replay = replay_session(path, fast=True, predictor=_predictor())
    replayed = {r.stop: r for r in replay.stops if r.camera == "mwir"}
    for live_row in live_rows:
        got = replayed[live_row.stop].model.model_snr
        assert set(got) == set(live_row.model.model_snr)
        for name, value in live_row.model.model_snr.items():
            assert got[name] == pytest.approx(value, rel=1e-12), (live_row.stop, name)


def test_back_to_the_model_s_noise_and_noise_set_before_the_recording(live):
    """Noise chosen before the recording starts is in the file from its start; None (back to
    the model's) is recorded as {}; a camera the session lacks or a bad value is refused."""
    session, path = live
    session.set_measured_noise("mwir", NOISE)
    session.start()
    session.start_recording(path)
    wait_until(lambda: session.status().cameras["mwir"].frames.written >= 3, 10.0, "frames")
    session.set_measured_noise("mwir", None)
    assert session.measured_noise == {}
    assert session.predictor is not None and session.predictor.measured_noise == {}
    with pytest.raises(ValueError, match="'lwir'"):
        session.set_measured_noise("lwir", NOISE)
    with pytest.raises(ValueError, match="mwir: a measured noise must be a MeasuredNoise, got 7"):
        session.set_measured_noise("mwir", 7)  # type: ignore[arg-type]
    session.stop_recording()
    with open_session(path) as f:
        events = [(e["camera"], e["payload"]) for e in f.event_list() if e["kind"] == "model_noise"]
        inputs = recorded_inputs(f)
    assert events == [("mwir", {"temporal_dn": 7.5, "spatial_dn": 2.0}), ("mwir", {})]
    kinds = [(k, p) for _, k, p in inputs.per_camera["mwir"].model_inputs]
    assert kinds == [("model_noise", events[0][1]), ("model_noise", {})]


def test_the_replay_player_applies_the_operator_s_noise_without_recording(tmp_path):
    sim = write_session(tmp_path / "s.h5", ranges_m=(393.0,), hover_s=2.0, cameras=("mwir",))
    predictor = _predictor()
    plain = predictor.curve("mwir")["small"][1].copy()
    player = ReplayPlayer(sim.path, predictor=predictor)
    try:
        player.set_measured_noise("mwir", NOISE)
        assert player.measured_noise == {"mwir": NOISE}
        assert predictor.measured_noise == {"mwir": NOISE}
        assert not np.allclose(predictor.curve("mwir")["small"][1], plain)
        player.set_measured_noise("mwir", None)
        assert player.measured_noise == {} and predictor.measured_noise == {}
        np.testing.assert_allclose(predictor.curve("mwir")["small"][1], plain, rtol=1e-12)
        with pytest.raises(ValueError, match="no camera 'lwir'"):
            player.set_measured_noise("lwir", NOISE)
    finally:
        player.stop()
    with open_session(sim.path) as f:
        assert not [e for e in f.event_list() if e["kind"] == "model_noise"]
