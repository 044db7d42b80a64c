"""A session file describes itself: every dataset has ``units`` and ``long_name``, and the
axes are dimension scales, so a netCDF reader (xarray with h5netcdf) that knows nothing of
snrmon sees named dimensions and coordinates."""

from __future__ import annotations

import json
import re
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

from snrmon.acquisition.measure.peak_snr import PeakSnr
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
            result = PeakSnr(3, 4, 1200.0 + i, 1000.0, 10.0, 20.0 + i, frozenset())
            rec.add_measurement(camera, i, result, counter=fr.counter, t_host_ns=fr.t_host_ns)
    rec.add_reference("mwir", np.full(CAMS["mwir"], 1.5, np.float32), {}, t_host_ns=1_000_000)
    rec.add_range(RangeReading(1_000_100, 199.0, RangeStatus.OK, raw="199.0"))
    rec.add_gps(GpsFix(1_000_200, None, 34.5, -117.2, raw="$GPGGA"))
    rec.add_event("note", payload={"text": "hello"})
    assert rec.stop().state == "stopped"
    return path


# A CF check of our own: the units UDUNITS parses that the file may use (a DN count is "1"),
# and CF's "UNIT since DATE" time units.
UDUNITS = {"1", "ns", "m", "m2 s sr"}
TIME_UNITS = re.compile(r"^(nanoseconds|seconds) since \d{4}-\d{2}-\d{2}( \d{2}:\d{2}:\d{2})?$")


def cf_problems(f: h5py.File) -> list[str]:
    """What breaks the CF conventions in an open session file: a missing Conventions, a
    variable without long_name, a numeric variable without units or with units UDUNITS does
    not know, a time variable without standard_name time."""
    problems = [] if str(f.attrs.get("Conventions", "")).startswith("CF-") else ["Conventions"]

    def visit(name, obj):
        if not isinstance(obj, h5py.Dataset):
            return
        attrs = obj.attrs
        if not attrs.get("long_name"):
            problems.append(f"{name}: no long_name")
        if obj.dtype.names is not None:  # a compound table: its fields' units in units_json
            if "units" in attrs or not json.loads(attrs["units_json"]):
                problems.append(f"{name}: compound with units, or without units_json")
            return
        if obj.dtype.kind == "S" or "flag_meanings" in attrs:
            return  # text and flags: CF gives them no units
        units = str(attrs.get("units", ""))
        if units not in UDUNITS and not TIME_UNITS.match(units):
            problems.append(f"{name}: units {units!r}")
        if TIME_UNITS.match(units) and attrs.get("standard_name") != "time":
            problems.append(f"{name}: a time without standard_name time")

    f.visititems(visit)
    return problems


def test_every_variable_follows_the_cf_conventions(recording):
    with h5py.File(recording, "r") as f:
        assert f.attrs["format_version"] == "2.4" and f.attrs["Conventions"] == "CF-1.10"
        assert cf_problems(f) == []
        frames = f["cameras/mwir/frames"].attrs
        assert frames["units"] == "1" and "digital numbers (DN)" in frames["long_name"]
        assert f["cameras/mwir/t_host_ns"].attrs["units"] == "ns"
        assert f["cameras/mwir/utc_ns"].attrs["standard_name"] == "time"
        # the check can fail: the units of before
        f2 = h5py.File("mem.h5", "w", driver="core", backing_store=False)
        f2.attrs["Conventions"] = "CF-1.10"
        f2.create_dataset("frames", data=np.zeros(3, np.uint16)).attrs.update(
            units="DN", long_name="raw"
        )
        assert cf_problems(f2) == ["frames: units 'DN'"]
        f2.close()
    # xarray decodes the CF times of a compound-free group's variables
    with xr.open_dataset(recording, group="cameras/mwir", engine="h5netcdf") as ds:
        assert ds["utc_ns"].dtype == np.dtype("datetime64[ns]")
        assert ds["frames"].attrs["units"] == "1"


def test_xarray_opens_a_camera_with_named_dimensions_and_coordinates(recording):
    with xr.open_dataset(recording, group="cameras/mwir", engine="h5netcdf") as ds:
        assert ds["frames"].dims == ("time", "row", "col")
        assert ds.sizes == {
            "time": 12,
            "row": CAMS["mwir"][0],
            "col": CAMS["mwir"][1],
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
        assert ds["frames"].attrs["long_name"].startswith("raw pixel values")
        assert not [d for d in ds.dims if str(d).startswith("phony_dim")]
    # the measurements: a table of named columns, each with its CF units
    group = "cameras/mwir/measurements"
    with xr.open_dataset(recording, group=group, engine="h5netcdf") as m:
        assert m.sizes == {"measurement": 12}
        assert m["snr"].dims == ("measurement",) and m["snr"].attrs["units"] == "1"
        assert m["range_m"].attrs["units"] == "m" and m["t_host_ns"].attrs["units"] == "ns"
        assert m["flags"].attrs["flag_meanings"].split()[0] == "saturated"
        with h5py.File(recording, "r") as f:
            rows = f[group]
            np.testing.assert_array_equal(m["snr"].values, rows["snr"][()])
        np.testing.assert_array_equal(m["snr"].values, 20.0 + np.arange(12))
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
