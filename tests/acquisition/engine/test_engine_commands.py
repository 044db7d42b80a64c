"""The engine applies a frame's commands the same way whatever order two threads posted them in.

A click (SetRoi) makes a new tracker. Live, the GPS thread's cue and the operator's click can
reach the engine in either order before the same frame; a replay posts the recorded click first.
If the cue were applied in posting order, a cue posted before the click went to the old tracker
and was lost live but kept in the replay, and the replay then searched where live had not (an
intermittent replay difference at a 37 m stop). The cue is applied after the click.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from snrmon.acquisition.engine.camera_engine import CameraEngine
from snrmon.acquisition.engine.inputs import Cue, SetRoi
from snrmon.acquisition.streams.ring import RingFrame

H, W = 64, 96


def _frame(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.rint(1000.0 + rng.normal(0.0, 5.0, (H, W))).astype(np.uint16)  # no object


@pytest.mark.parametrize("cue_first", [True, False])
def test_a_cue_posted_with_a_click_reaches_the_clicked_track(cue_first):
    engine = CameraEngine("cam", (H, W))
    commands = [Cue(70.5, 20.25), SetRoi(30, 40)]
    for c in commands if cue_first else commands[::-1]:
        engine.post(c)
    out = engine.process(RingFrame(_frame(1), 0, 0, 10**12, None, engine.name))
    tracker = engine.measurer.tracker
    assert tracker is not None
    assert tracker.last_cue == (70.5, 20.25)
    assert out.measurement is not None
    assert out.measurement.cue_xy == (70.5, 20.25)  # recorded as applied at this frame
    assert [type(c).__name__ for c in out.applied] == ["SetRoi", "Cue"]


def test_a_cue_without_a_track_is_not_kept_for_a_later_click():
    engine = CameraEngine("cam", (H, W))
    engine.post(Cue(70.5, 20.25))
    assert engine.process(RingFrame(_frame(1), 0, 0, 10**12, None, engine.name)).measurement is None
    engine.post(SetRoi(30, 40))
    engine.process(RingFrame(_frame(2), 1, 1, 10**12 + 16_666_667, None, engine.name))
    assert engine.measurer.tracker is not None
    assert engine.measurer.tracker.last_cue is None


def test_the_operators_model_keeps_the_sessions_footprint_and_its_worker(tmp_path):
    """The console's model options (a ModelRequest) change the target, background and met
    readings (here the background); the session's footprint (its config's ``outline``) stays
    the model's, and a live session's predictor, computing a new sky's curves in the worker
    process, is replaced by one that does the same (the measurement threads never wait on the
    model)."""
    from snrmon.acquisition.config import session_config_from_dict
    from snrmon.acquisition.engine.session_engine import SessionEngine
    from snrmon.acquisition.prediction import ModelRequest, config_predictor

    # a target file with its outline, as ``snrmon characterize --target-out`` writes one
    preset = (Path(__file__).parents[3] / "model" / "presets" / "uav1.toml").read_text()
    target = tmp_path / "uav1-outlined.toml"
    target.write_text(
        preset.replace('name = "uav1"', 'name = "uav1-outlined"')
        + 'outline = ["010", "111", "010"]\noutline_pixel_m = 0.06\n'
    )
    config = session_config_from_dict(
        {
            "target": str(target),
            "footprint": "outline",
            "cameras": {"mwir": {"source": "shm", "address": "x"}},
        }
    )
    live = config_predictor(config, asynchronous=True)
    engine = SessionEngine(config, {"mwir": (96, 128)}, predictor=live)
    engine.set_model(ModelRequest(str(target), background_temp_k=280.0))
    new, reference = engine.predictor, engine.reference_predictor
    assert new is not live and new.target.name == "uav1-outlined"
    assert new.options_in_force("mwir")["footprint"] == "outline"
    assert reference.options_in_force("mwir")["footprint"] == "outline"
    assert new.asynchronous and not reference.asynchronous
    assert new.background_temp_k["mwir"] == 280.0
