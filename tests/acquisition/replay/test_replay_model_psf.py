"""A PSF the live console adopted from the flight (a ``model_psf`` event) is used again by a
replay of the recording, so the replayed stop rows' corrected values and the report's curves are
the ones the live rows were compared with."""

from __future__ import annotations

import pytest

from snrmon.acquisition.calibrate.psf_estimate import psf_from_record
from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.engine.session_engine import SessionEngine
from snrmon.acquisition.prediction import ModelPredictor
from snrmon.acquisition.record.reader import append_event
from snrmon.acquisition.replay.batch import replay_session
from snrmon.model.presets import load_sensor
from tests.acquisition.session_factory import write_session

MW = load_sensor("mwir")
ESTIMATE = {  # PsfEstimate.as_dict of the twin's MWIR (snrmon hil, seed 5)
    "sigma_px": 0.82,
    "sigma_px_std": 0.01,
    "blur_px": 0.57,
    "blur_px_std": 0.02,
    "pvf": 0.139,
    "pvf_std": 0.003,
    "n_frames": 400,
    "chi2_per_dof": {"airy_gauss": 1.02},
    "f_number": MW.f_number,
    "pitch_um": MW.pitch_um,
    "band_um": list(MW.band_um),
    "fill_factor": MW.fill_factor,
}


class _Sink:
    def __init__(self) -> None:
        self.changes: list[tuple[str, str, dict, int]] = []

    def stop_changed(self, kind, stop) -> None: ...

    def row_final(self, row) -> None: ...

    def model_changed(self, camera, kind, payload, t_host_ns) -> None:
        self.changes.append((camera, kind, payload, t_host_ns))


def test_adopting_a_psf_sets_the_curves_and_tells_the_sink():
    predictor = ModelPredictor({"mwir": "mwir"}, "uav1")
    preset = predictor("mwir", 393.0)["small_corrected"]
    config = session_config_from_dict(
        {"cameras": {"mwir": {"source": "shm", "address": "none", "sensor": "mwir"}}}
    )
    engine = SessionEngine(config, {"mwir": (720, 1280)}, predictor=predictor)
    sink = engine.sink = _Sink()
    engine.adopt_psf("mwir", ESTIMATE, 123)
    assert sink.changes == [("mwir", "model_psf", ESTIMATE, 123)]
    assert predictor.curves_psf["mwir"].sigma_px == 0.57
    assert predictor("mwir", 393.0)["small_corrected"] > 1.4 * preset
    # which PSF the curves used, in words the console can show
    assert predictor.curves_psf_source["mwir"] == "fitted: sigma 0.57 px from this flight's stops"


def test_the_preset_psf_is_named_until_one_is_fitted():
    """The MWIR preset's blur is solved from the paper's average PVF 0.082 (section 8)."""
    predictor = ModelPredictor({"mwir": "mwir", "lwir": "lwir"}, "uav1")
    assert predictor.curves_psf_source == {
        "mwir": "preset: PVF 0.082 (sensor mwir)",
        "lwir": "preset: PVF 0.45 (sensor lwir)",
    }


def test_a_replay_applies_the_recorded_psf(tmp_path):
    sim = write_session(tmp_path / "s.h5", ranges_m=(393.0, 508.0), cameras=("mwir",))
    append_event(sim.path, "model_psf", camera="mwir", payload=ESTIMATE)
    live = ModelPredictor({"mwir": "mwir"}, "uav1")
    live.set_psf("mwir", psf_from_record(ESTIMATE), wait=True)
    replay = replay_session(sim.path, fast=True, predictor=ModelPredictor({"mwir": "mwir"}, "uav1"))
    rows = [r for r in replay.stops if r.camera == "mwir"]
    assert len(rows) == 2
    for row in rows:
        assert row.model.model_psf is not None and row.model.model_psf.sigma_px == 0.57
        want = live("mwir", row.range_m)
        for name in ("small_corrected", "expected_eq4_rim", "expected_eq4_extent"):
            assert row.model.model_snr[name] == pytest.approx(want[name], rel=1e-9), name


@pytest.mark.parametrize("written_by", ["snrmon hil before", "snrmon hil now", "snrmon psf"])
def test_the_console_s_replay_applies_the_flight_s_psf_fit(tmp_path, written_by):
    """The PSF fitted from the flight's unresolved stops (a ``psf_measured`` event written once
    the flight is over) is the camera's from the first frame on in the console's replay too:
    as the demo and ``snrmon hil --out`` wrote it until now (the fit's own fields, no
    ``estimate``), as they write it now and as ``snrmon psf`` writes it (with ``estimate``).
    Without it the MWIR read 1.4-1.9x the model at every unresolved stop."""
    from snrmon.acquisition.replay.player import ReplayPlayer

    sim = write_session(tmp_path / "s.h5", ranges_m=(393.0, 508.0), cameras=("mwir",))
    payload = {**ESTIMATE, "camera": "mwir", "source": "snrmon hil: the unresolved stops"}
    if written_by != "snrmon hil before":
        payload["estimate"] = ESTIMATE
    append_event(sim.path, "psf_measured", camera="mwir", payload=payload)
    want = ModelPredictor({"mwir": "mwir"}, "uav1")
    want.set_psf("mwir", psf_from_record(ESTIMATE), wait=True)
    # as `snrmon gui --replay` builds it: the player first, its model from the file's config
    with ReplayPlayer(sim.path, speed=1000.0) as player:
        player.set_predictor(ModelPredictor({"mwir": "mwir"}, "uav1"))
        player.play()
        assert player.wait_end(120)
        rows = [r for r in player.stop_table.rows() if r.camera == "mwir"]
    assert [round(r.range_m) for r in rows] == [393, 508]
    for row in rows:
        assert row.model.model_psf is not None and row.model.model_psf.sigma_px == 0.57
        at = want("mwir", row.range_m)
        for name in ("small_corrected", "expected_eq4_rim", "expected_eq4_extent"):
            assert row.model.model_snr[name] == pytest.approx(at[name], rel=1e-9), name
