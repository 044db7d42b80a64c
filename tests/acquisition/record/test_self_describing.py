"""A session file describes itself: every dataset has ``units`` and ``long_name``, and the
axes are dimension scales, so a netCDF reader (xarray with h5netcdf) that knows nothing of
snrmon sees named dimensions and coordinates."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

from snrmon.acquisition.record.recorder import SessionRecorder
from snrmon.acquisition.streams.timebase import ClockMap
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.rangefinder.reading import RangeReading, RangeStatus
from tests.acquisition.record.test_recorder import CAMS, CONFIG, make_frames


@pytest.fixture(scope="module")
def recording(module_tmp) -> Path:
    path = module_tmp("described") / "s.h5"
    clock = ClockMap()
    rec = SessionRecorder(path, config=CONFIG, cameras=CAMS, flush_interval_s=0.1, clock=clock)
    for camera, n, seed in (("mwir", 12, 3), ("lwir", 5, 4)):
        for i, fr in enumerate(make_frames(camera, n, seed)):
            rec.add_frame(camera, fr)
            rec.add_measurement(
                camera,
                i,
                counter=fr.counter,
                t_host_ns=fr.t_host_ns,
                peak_x=3,
                peak_y=4,
                peak=1200.0 + i,
                bg_mean=1000.0,
                bg_std=10.0,
                snr=20.0 + i,
            )
    rec.add_reference("mwir", np.full(CAMS["mwir"], 1.5, np.float32), {}, t_host_ns=1_000_000)
    rec.add_range(RangeReading(1_000_100, 199.0, RangeStatus.OK, raw="199.0"))
    rec.add_gps(GpsFix(1_000_200, None, 34.5, -117.2, raw="$GPGGA"))
    rec.add_event("note", payload={"text": "hello"})
    assert rec.stop().state == "stopped"
    return path


def test_every_dataset_has_units_and_a_long_name(recording):
    missing = []

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and not {"units", "long_name"} <= set(obj.attrs):
            missing.append(name)

    with h5py.File(recording, "r") as f:
        f.visititems(visit)
        assert f.attrs["format_version"] == "2.4"
        assert f["cameras/mwir/frames"].attrs["units"] == "DN"
        assert f["cameras/mwir/t_host_ns"].attrs["units"] == "ns"
    assert missing == []


def test_xarray_opens_a_camera_with_named_dimensions_and_coordinates(recording):
    with xr.open_dataset(recording, group="cameras/mwir", engine="h5netcdf") as ds:
        assert ds["frames"].dims == ("time", "row", "col")
        assert ds.sizes == {
            "time": 12,
            "row": CAMS["mwir"][0],
            "col": CAMS["mwir"][1],
            "measurement": 12,
            "state": 0,
            "reference": 1,
        }
        assert ds["time"].dtype == np.dtype("datetime64[ns]")  # decoded from CF time units
        with h5py.File(recording, "r") as f:
            utc = f["cameras/mwir/utc_ns"][()]
            pixels = f["cameras/mwir/frames"][()]
        np.testing.assert_array_equal(ds["time"].values.astype(np.int64), utc)
        np.testing.assert_array_equal(ds["frames"].values, pixels)
        np.testing.assert_array_equal(ds["row"].values, np.arange(CAMS["mwir"][0]))
        assert ds["counter"].dims == ("time",)
        assert ds["references"].dims == ("reference", "row", "col")
        assert ds["measurements"].dims == ("measurement",)
        assert ds["frames"].attrs["long_name"].startswith("raw pixel values")
        assert not [d for d in ds.dims if str(d).startswith("phony_dim")]
    with xr.open_dataset(recording, engine="h5netcdf") as root:
        assert root["rangefinder"].dims == ("rangefinder_reading",)
        assert root.sizes["event"] >= 3  # recording_started, the note, recording_stopped
        assert not [d for d in root.dims if str(d).startswith("phony_dim")]


def test_an_event_added_after_the_session_keeps_the_file_readable(recording, tmp_path):
    import shutil

    from snrmon.acquisition.record.reader import append_event

    copy = tmp_path / "copy.h5"
    shutil.copy(recording, copy)
    with xr.open_dataset(copy, engine="h5netcdf") as root:
        before = root.sizes["event"]
    append_event(copy, "target_characterized", payload={"small_m": 0.157})
    with xr.open_dataset(copy, engine="h5netcdf") as root:
        assert root.sizes["event"] == before + 1
        assert root["events"].values[-1]["kind"] == b"target_characterized"
