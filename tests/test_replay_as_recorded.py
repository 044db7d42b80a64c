"""A recording with a large (resolved, 37 m) drone replays to the live run frame for frame, both
cameras, however its frames are read (``--fast`` memory map or full frames) and whether the
recorded Eq. (4) settings are passed explicitly (as ``snrmon campaign`` does) or left implicit.

The campaign once differed from ``snrmon replay`` at the 37 m stop: passing the recorded
settings made the replay a re-analysis that dropped the live GPS cues and engine states."""

from __future__ import annotations

import math

import numpy as np
import pytest

from snrmon.acquisition.record.reader import open_session
from snrmon.acquisition.replay.batch import replay_session
from snrmon.acquisition.replay.recorded import recorded_inputs
from snrmon.campaign.settings import AnalysisSettings
from snrmon.campaign.tasks import analyse_camera
from tests.helpers import replay_frames_text, replay_rows_text, twin_recording


def _none(v: float) -> float | None:
    return None if math.isnan(v) else v


@pytest.fixture(scope="module")
def recording(module_tmp):
    return twin_recording(module_tmp("as-recorded") / "s.h5", stops="37,126", speed=4)


@pytest.mark.slow
def test_fast_full_and_explicit_settings_replay_every_frame_of_a_37m_stop(recording, capsys):
    capsys.readouterr()
    with open_session(recording) as f:
        inputs = recorded_inputs(f)
    assert set(inputs.cameras) == {"lwir", "mwir"}
    full = replay_session(recording)
    fast = replay_session(recording, fast=True)
    explicit = replay_session(recording, fast=True, measurement=inputs.config.measurement)
    assert full.stops and full.stops[0].range_m is not None and full.stops[0].range_m < 40
    for name in inputs.cameras:
        c = full.cameras[name]
        assert c.identical == c.compared > 0, (name, c.tally.first_difference)
        assert replay_frames_text(fast, name) == replay_frames_text(full, name), name
        assert replay_frames_text(explicit, name) == replay_frames_text(full, name), name
        assert explicit.cameras[name].identical == c.compared, name
    rows = replay_rows_text(full)
    assert replay_rows_text(fast) == rows and replay_rows_text(explicit) == rows
    assert full.stops_identical == fast.stops_identical == explicit.stops_identical
    assert explicit.stops_identical == len(full.recorded_rows) > 0
    # The campaign's own task (fast, the recorded settings given explicitly) gives the same rows.
    for name in inputs.cameras:
        task = analyse_camera(str(recording), name, AnalysisSettings(), frames=True)
        want = [
            (r.stop, r.reading.n_frames, _none(r.reading.snr_mean), _none(r.reading.snr_std))
            for r in full.stops
            if r.camera == name
        ]
        got = [(r["stop"], r["n_frames"], r["snr_mean"], r["snr_std"]) for r in task.stops]
        assert got == want, name
        assert task.frames is not None
        snr = [m.result.snr for m in full.cameras[name].tally.measurements]
        np.testing.assert_array_equal(task.frames["snr"], snr)
