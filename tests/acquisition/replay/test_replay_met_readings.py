"""The day's met readings (air, humidity, pressure, visibility) reach the model: from the
session's [weather] table, from the operator mid-session (a ``met_readings`` event the session
records), in a replay at the recorded time, and in the report's curves and budget."""

from __future__ import annotations

import time

import pytest

from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.prediction import ModelPredictor, session_model_options
from snrmon.acquisition.record.reader import append_event, open_session
from snrmon.acquisition.replay.batch import replay_session
from snrmon.acquisition.report.data import (
    assemble_report,
    session_weather,
    uncertainty_budget,
)
from snrmon.acquisition.runtime.session import Session
from snrmon.model.atmosphere_table import Weather
from snrmon.sim.devices.shm_camera import ShmProducer
from tests.acquisition.session_factory import write_session
from tests.helpers import H, SpotOnNoise, W, shm_camera_config

HUMID = Weather(air_temp_c=28.0, rh_percent=95.0, pressure_hpa=1005.0, visibility_km=8.0)


def test_the_session_config_weather_table_sets_the_model():
    cfg = session_config_from_dict(
        {
            "cameras": {"mwir": {"sensor": "mwir"}},
            "weather": {
                "air_temp_c": 28.0,
                "rh_percent": 95.0,
                "pressure_hpa": 1005.0,
                "visibility_km": 8.0,
            },
        }
    )
    assert cfg.weather == HUMID and cfg.air_temp_k == pytest.approx(301.15)
    humid = ModelPredictor({"mwir": "mwir"}, "uav1", **session_model_options(cfg))
    plain = ModelPredictor({"mwir": "mwir"}, "uav1")
    # humid hazy air: less signal through 1 km of it
    assert humid("mwir", 1000.0)["small_corrected"] < 0.8 * plain("mwir", 1000.0)["small_corrected"]


def test_set_weather_recomputes_once_per_new_reading():
    p = ModelPredictor({"mwir": "mwir", "lwir": "lwir"}, "uav1")
    before = {c: p(c, 800.0)["small_corrected"] for c in ("mwir", "lwir")}
    version = p.version
    p.set_weather(HUMID)
    assert p.version == version + 2  # both cameras
    p.set_weather(HUMID)
    assert p.version == version + 2  # the same readings: nothing recomputed
    for c in ("mwir", "lwir"):
        assert p(c, 800.0)["small_corrected"] < before[c]


def test_the_operator_s_readings_are_recorded_and_applied(tmp_path):
    name = f"snrmon-met-{time.monotonic_ns() % 10**9}"
    producer = ShmProducer(name, W, H, SpotOnNoise(3), fps=30.0, slots=8)
    producer.start()
    config = shm_camera_config(name)
    predictor = ModelPredictor({"mwir": "mwir"}, "uav1")
    session = Session(config, track=False, predictor=predictor)
    try:
        session.start_recording(tmp_path / "s.h5")
        session.set_met_readings(HUMID)
        assert predictor.weather["mwir"] == HUMID
        session.stop_recording()
    finally:
        session.stop()
        producer.stop()
    with open_session(tmp_path / "s.h5") as f:
        events = [e for e in f.event_list() if e["kind"] == "met_readings"]
    assert [e["payload"] for e in events] == [HUMID.as_dict()]
    assert session_weather(tmp_path / "s.h5") == (None, HUMID)


def test_a_replay_applies_the_recorded_readings_and_the_report_uses_them(tmp_path):
    sim = write_session(tmp_path / "s.h5", ranges_m=(393.0, 508.0), cameras=("mwir",))
    # an event added afterwards (time -1): applied from the first frame on
    append_event(sim.path, "met_readings", payload=HUMID.as_dict())
    live = ModelPredictor({"mwir": "mwir"}, "uav1", atmosphere=HUMID)
    plain = ModelPredictor({"mwir": "mwir"}, "uav1")
    replay = replay_session(sim.path, fast=True, predictor=ModelPredictor({"mwir": "mwir"}, "uav1"))
    rows = [r for r in replay.stops if r.camera == "mwir"]
    assert len(rows) == 2
    for row in rows:
        want = live("mwir", row.range_m)
        assert row.model.model_snr["small_corrected"] == pytest.approx(
            want["small_corrected"], rel=1e-9
        )
        assert (
            row.model.model_snr["small_corrected"] < plain("mwir", row.range_m)["small_corrected"]
        )
    # the report: its curves, budget and detection ranges through the same air
    first, last = session_weather(sim.path)
    assert first is None and last == HUMID
    data = assemble_report(sim.path, {"mwir": "mwir"}, "uav1", rows, [], seconds=1.0, weather=last)
    assert data.weather == HUMID and "RH 95 %" in data.model.curves["mwir"].atmosphere
    humid_budget = data.model.budgets["mwir"][0].terms["transmission"]
    plain_budget = uncertainty_budget("mwir", "mwir", "uav1", [rows[0].range_m])[0]
    assert humid_budget > plain_budget.terms["transmission"]  # more optical depth
