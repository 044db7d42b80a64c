"""Analysis results beside the recording: ``snrmon psf`` leaves the recording's bytes and time
as recorded, keeps its fit in ``F.analysis.json``, and a replay of the recording uses the fitted
PSF as the model's corrected PSF, as it uses one written into the file with ``--write``."""

from __future__ import annotations

import json
import shutil

import pytest

from snrmon.acquisition.prediction import ModelPredictor
from snrmon.acquisition.record.analysis_file import read_results, sidecar_path
from snrmon.acquisition.record.reader import open_session
from snrmon.acquisition.replay.batch import replay_session
from snrmon.cli import main
from tests.acquisition.session_factory import write_session


@pytest.fixture(scope="module")
def far_stops(module_tmp):
    """Two unresolved MWIR stops (393 m, 508 m) of a bright point: enough for a PSF fit."""
    d = module_tmp("analysis")
    return write_session(
        d / "f.h5", ranges_m=(393.0, 508.0), cameras=("mwir",), amplitude_dn=3000.0
    ).path


def _psf(path, capsys, *extra) -> dict:
    assert main(["psf", str(path), "--camera", "mwir", "--stop", "1", "--json", *extra]) == 0
    return json.loads(capsys.readouterr().out)


def _replayed_psf(path) -> set:
    rows = replay_session(path, fast=True, predictor=ModelPredictor({"mwir": "mwir"}, "uav1")).stops
    return {
        None if r.model.model_psf is None else round(r.model.model_psf.sigma_px, 9) for r in rows
    }


def test_psf_keeps_the_recording_raw_and_its_fit_beside_it(far_stops, tmp_path, capsys):
    session = tmp_path / "f.h5"
    shutil.copy2(far_stops, session)
    raw, mtime_ns = session.read_bytes(), session.stat().st_mtime_ns
    assert _replayed_psf(session) == {None}  # the sensor preset's PSF before
    out = _psf(session, capsys)
    assert session.read_bytes() == raw and session.stat().st_mtime_ns == mtime_ns
    (entry,) = read_results(session)
    assert entry["kind"] == "psf_measured" and entry["camera"] == "mwir"
    assert entry["payload"]["pvf"] == out["pvf"] and entry["payload"]["stops"] == [1]
    assert entry["payload"]["estimate"]["blur_px"] == out["blur_px"]
    with open_session(session) as f:
        assert not [e for e in f.event_list() if e["kind"] == "psf_measured"]
    # A replay (and so a report and a campaign) of the recording uses the fit as the corrected
    # PSF from the first frame on: the Airy of the sensor blurred by the fitted Gaussian.
    assert _replayed_psf(session) == {round(out["blur_px"], 9)}
    assert session.read_bytes() == raw


def test_psf_write_puts_the_fit_into_the_recording_instead(far_stops, tmp_path, capsys):
    session = tmp_path / "f.h5"
    shutil.copy2(far_stops, session)
    raw = session.read_bytes()
    out = _psf(session, capsys, "--write")
    assert session.read_bytes() != raw and not sidecar_path(session).exists()
    with open_session(session) as f:
        (event,) = [e for e in f.event_list() if e["kind"] == "psf_measured"]
    assert event["payload"]["pvf"] == out["pvf"]
    assert _replayed_psf(session) == {round(out["blur_px"], 9)}


def test_a_sidecar_of_another_recording_is_refused(far_stops, tmp_path, capsys):
    """A recording of the same name made at another time: its sidecar is not applied."""
    session = tmp_path / "f.h5"
    shutil.copy2(far_stops, session)
    _psf(session, capsys, "--no-record")
    assert not sidecar_path(session).exists()
    _psf(session, capsys)
    other = tmp_path / "other"
    other.mkdir()
    write_session(other / "f.h5", ranges_m=(393.0,), cameras=("mwir",), hover_s=2.0)
    shutil.copy(sidecar_path(session), sidecar_path(other / "f.h5"))
    assert main(["replay", str(other / "f.h5"), "--fast"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "f.analysis.json: it belongs to 'f.h5' created" in err
