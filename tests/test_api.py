"""The public API (snrmon.api): its examples run, its page is current, and its labelled results
hold the numbers the product computed, checked against an independent reading of the same data
(plain h5py on the file, the recorded stop table, the model's own arrays)."""

from __future__ import annotations

import doctest
import json
import runpy
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest
import xarray as xr

import snrmon
from snrmon import api, examples

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("module", [api, examples], ids=lambda m: m.__name__)
def test_every_example_in_the_docstrings_runs(module, tmp_path, monkeypatch):
    # the examples make their sessions in tempfile.mkdtemp(), as a user would: here, under
    # this test's own folder, which pytest removes when the test passes
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    failed, tried = doctest.testmod(
        module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    )
    assert tried >= 4 and failed == 0


def test_the_api_page_is_the_docstrings():
    tool = runpy.run_path(str(REPO / ".ci" / "api_doc.py"))
    assert tool["main"](["--check", str(REPO / "docs" / "api.md")]) == 0


def test_the_top_level_names_are_the_api_and_import_lazily():
    assert set(snrmon.__all__) == set(api.__all__)
    code = "import sys, snrmon; "
    code += "print(json.dumps(['xarray' in sys.modules, snrmon.predict.__module__]))"
    out = subprocess.run(
        [sys.executable, "-c", "import json; " + code],
        capture_output=True,
        text=True,
        check=True,
        cwd=REPO,
    ).stdout
    assert json.loads(out) == [False, "snrmon.api"]  # the CLI's import snrmon stays cheap


def test_predict_labels_the_models_own_arrays():
    from snrmon.model.presets import load_sensor, load_target
    from snrmon.model.snr import predict

    ranges = np.array([37.0, 199.0, 508.0])
    ds = snrmon.predict("lwir", "uav1", ranges, background_temp_k=280.0, band=False)
    p = predict(
        load_sensor("lwir"), load_target("uav1"), ranges, background_temp_k=280.0, band=False
    )
    np.testing.assert_array_equal(ds["range_m"].values, ranges)
    assert ds["range_m"].attrs["units"] == "m"
    for name in ("small", "large", "small_corrected", "large_corrected"):
        np.testing.assert_array_equal(ds[name].values, getattr(p, f"snr_{name}"))
    for name, snr in p.paper.items():
        np.testing.assert_array_equal(ds[f"paper_{name}"].values, snr)
    assert ds.attrs["background_temp_k"] == 280.0
    assert json.loads(ds.attrs["conditions_json"]) == {"background_temp_k": 280.0, "band": False}
    with pytest.raises(ValueError, match="unknown"):
        snrmon.predict("swir", "uav1", ranges)


def test_every_curve_of_the_prediction_is_named_with_its_units():
    ds = snrmon.predict("mwir", "uav1", [37.0, 199.0, 508.0])
    assert {"small_corrected_lower", "small_corrected_upper"} <= set(ds.data_vars)
    for name, var in ds.data_vars.items():
        assert var.attrs.get("long_name"), name
        assert var.dtype == bool or var.attrs.get("units") == "1", name
    lower = ds["small_corrected_lower"].attrs["long_name"]
    assert lower.startswith("lower edge") and "real PSF and finite target" in lower
    assert bool((ds["small_corrected_lower"] <= ds["small_corrected_upper"]).all())


@pytest.mark.slow
def test_a_live_recording_reads_as_labelled_tables(hil_sessions):
    path = hil_sessions[0]
    with snrmon.open_session(path) as s:
        assert s.cameras == ("lwir",)
        m = s.measurements("lwir")
        frames = s.frames("lwir")
        frame_dims, frame_shape, frame0 = frames.dims, frames.shape, frames[0].values
        stops = s.stops()
    with h5py.File(path, "r") as f:  # h5py's defaults: the session released the file
        columns = f["cameras/lwir/measurements"]
        rows = {name: columns[name][()] for name in ("snr", "track_state", "flags")}
        shape = f["cameras/lwir/frames"].shape
        first = f["cameras/lwir/frames"][0]
        events = [
            (e["kind"].decode(), json.loads(e["payload"]))
            for e in f["events"][()]
            if e["kind"] == b"stop_summary"
        ]
    # per frame: the file's own rows, with real strings and timestamps
    assert len(m) == len(rows["snr"])
    np.testing.assert_array_equal(m["snr"].to_numpy(), rows["snr"])
    assert m["track_state"].tolist() == [v.decode() for v in rows["track_state"]]
    assert set(m["track_state"]) <= {"tracking", "lost", "reacquiring", "gps_cued", "occluded"}
    assert m["background"].map(type).eq(str).all()
    assert m.attrs["units"]["peak"] == "DN" and m.attrs["units"]["snr"] == "1"
    assert isinstance(m["utc"].dtype, pd.DatetimeTZDtype)
    assert m["utc"].dt.year.unique().tolist() == [2019]  # the simulated receiver's date
    flagged = m["flag_lost"].to_numpy()
    np.testing.assert_array_equal(flagged, (rows["flags"] >> 4) & 1 == 1)
    # frames: lazy, named, the file's pixels
    assert frame_dims == ("time", "row", "col") and frame_shape == shape
    np.testing.assert_array_equal(frame0, first)
    # stops: the live session's own final rows, as it recorded them
    final = {(p["camera"], p["stop"]): p for _, p in events if p.get("final")}
    assert len(stops) == len(final) >= 2
    for row in stops.itertuples():
        rec = final[(row.camera, row.stop)]
        assert row.n_frames == rec["n_frames"]
        assert row.snr_mean == pytest.approx(rec["snr_mean"], rel=1e-12)
    assert (stops["model_small_corrected"] > 0).all()


def test_the_recorded_stop_table_is_the_one_a_replay_builds(hil_sessions, tmp_path):
    """stops() reads the table the console recorded; the same file without its clean-stop
    summary (as a crash leaves it) is replayed through the engine with the model: the same
    table, model columns included."""
    import shutil

    path = tmp_path / "copy.h5"
    shutil.copy(hil_sessions[0], path)
    with snrmon.open_session(path) as s:
        recorded = s.stops()
    with h5py.File(path, "r+") as f:
        del f.attrs["summary_json"]
    with snrmon.open_session(path) as s:
        replayed = s.stops()
        assert s._replay  # it was replayed, not read
    assert len(recorded) >= 2 and list(recorded.columns) == list(replayed.columns)
    pd.testing.assert_frame_equal(recorded, replayed, rtol=1e-9)


def test_measure_and_track_a_stack_from_a_file(shared_data):
    clip = shared_data / "ir_small_targets" / "videos" / "IR_DRONE_151.mp4"
    stack = snrmon.load_stack(clip)
    assert stack.dims == ("frame", "row", "col") and stack.sizes["frame"] > 100
    labels = pd.read_csv(shared_data / "ir_small_targets" / "labels_csv" / "IR_DRONE_151.csv")
    x0, y0, w, h = labels.iloc[0][["x", "y", "w", "h"]]
    at = (round(x0 + w / 2), round(y0 + h / 2))
    fixed = snrmon.measure_stack(stack[:20], at=at)
    tracked = snrmon.track_stack(stack[:20], at=at)
    assert list(fixed.index) == list(range(20)) and fixed.index.name == "frame"
    assert {"flag_saturated", "flag_lost"} <= set(fixed.columns)
    assert set(tracked["track_state"]) <= {"tracking", "lost", "reacquiring"}
    # the tracked peak stays on the labelled drone (2 px margin)
    inside = [
        x0 - 2 <= px <= x0 + w + 2 and y0 - 2 <= py <= y0 + h + 2
        for px, py, (x0, y0, w, h) in zip(
            tracked["peak_x"],
            tracked["peak_y"],
            labels[["x", "y", "w", "h"]].to_numpy()[:20],
            strict=True,
        )
    ]
    assert all(inside)


def test_a_radiometric_recording_loads_with_its_header(shared_data):
    mwir = snrmon.load_stack(shared_data / "pyradi" / "PyradiSampleMWIR.ptw")
    assert mwir.sizes == {"frame": 100, "row": 64, "col": 69}
    assert mwir.attrs["camera"] == "Jade"
    assert (int(mwir.min()), int(mwir.max())) == (6106, 6462)  # as its provenance states


def test_the_file_opens_again_in_h5py_and_xarray_alongside_and_after(hil_sessions, tmp_path):
    """In one process: the session's own reads, then the file in h5py and xarray with their
    defaults, while the session is open and after ``close()``, with no locking clash."""
    path = hil_sessions[0]
    s = snrmon.open_session(path)
    frames = s.frames("lwir")
    with h5py.File(path, "r") as f:  # while the session's Dataset holds the file
        np.testing.assert_array_equal(frames[3].values, f["cameras/lwir/frames"][3])
    with_model = s.stops()
    without = s.stops(model=False)  # its own table, not the cached one with the model
    assert [c for c in with_model.columns if c.startswith("model_")]
    assert not [c for c in without.columns if c.startswith("model_")]
    assert list(without.columns) == [c for c in with_model.columns if not c.startswith("model_")]
    pd.testing.assert_frame_equal(s.stops(), with_model)  # cached per argument
    assert with_model.attrs["units"]["range_m"] == "m" and without.attrs["units"]["snr_mean"] == "1"
    s.close()
    with h5py.File(path, "r") as f:
        n = f["cameras/lwir/frames"].shape[0]
    ds = xr.open_dataset(path, group="cameras/lwir", engine="h5netcdf")
    try:
        assert ds.sizes["time"] == n
    finally:
        ds.close()
    with h5py.File(path, "r+") as f:  # nothing of the session's is left open
        assert f.attrs["format"] == "snrmon-session"


def test_what_is_not_a_session_is_named(tmp_path):
    text = tmp_path / "notes.h5"
    text.write_text("not HDF5")
    with pytest.raises(ValueError, match="not a snrmon session file"):
        snrmon.open_session(text)
    with pytest.raises(IsADirectoryError, match="is a folder"):
        snrmon.open_session(tmp_path)
    with pytest.raises(FileNotFoundError):
        snrmon.open_session(tmp_path / "missing.h5")


def test_the_old_name_of_a_recorded_session_still_works_with_a_warning():
    with pytest.warns(DeprecationWarning, match="snrmon.RecordedSession"):
        old = snrmon.Session
    assert old is snrmon.RecordedSession is api.RecordedSession
    assert "Session" not in snrmon.__all__ and "RecordedSession" in snrmon.__all__
