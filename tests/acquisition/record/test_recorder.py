"""SessionRecorder, open_session: exact round trip, plain-h5py reads, crash and disk full."""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import threading
import time
from datetime import UTC, datetime
from pathlib import Path

import h5py
import numpy as np
import pytest

from snrmon.acquisition.measure.peak_snr import FLAG_NAMES, PeakSnr
from snrmon.acquisition.record.reader import clear_status_flags, open_session
from snrmon.acquisition.record.recorder import BACKLOG, STOPPED, SessionRecorder
from snrmon.acquisition.record.schema import MEASUREMENT_FIELDS_V1
from snrmon.acquisition.record.writer import SessionWriter
from snrmon.acquisition.streams.ring import FrameRing
from snrmon.acquisition.streams.timebase import ClockMap, utc_of_rows
from snrmon.drivers.camera.frame import Frame
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.rangefinder.reading import RangeReading, RangeStatus

REPO = Path(__file__).resolve().parents[3]
H, W = 64, 80
CAMS = {"mwir": (H, W), "lwir": (48, 40)}
CONFIG = {"operator": "ops", "site": {"lat_deg": 34.5, "lon_deg": -117.2}, "sensor": "mwir-f4"}


def make_frames(camera: str, n: int, seed: int, t0: int = 1_000_000) -> list[Frame]:
    rng = np.random.default_rng(seed)
    h, w = CAMS[camera]
    return [
        Frame(
            rng.integers(0, 65536, (h, w), dtype=np.uint16),
            camera,
            counter=500 + i + (i >= 7),  # a gap: the camera dropped one
            t_host_ns=t0 + i * 16_666_667,
            t_device_ns=None if i % 3 == 0 else 9_000 + i,
        )
        for i in range(n)
    ]


def wait_for(predicate, timeout: float = 10.0) -> bool:
    """Poll a state that has no event to wait on (the recorder's thread owns it)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        threading.Event().wait(0.01)
    return predicate()


def test_round_trip_is_exact_and_readable_with_plain_h5py(tmp_path: Path) -> None:
    path = tmp_path / "s.h5"
    clock = ClockMap()
    rec = SessionRecorder(path, config=CONFIG, cameras=CAMS, flush_interval_s=0.1, clock=clock)
    mw, lw = make_frames("mwir", 20, 1), make_frames("lwir", 9, 2, t0=1_000_500)
    rows = []
    for i, fr in enumerate(mw):
        assert rec.add_frame("mwir", fr) == i
        snr = float("nan") if i == 4 else 5.0 + i / 8
        row = dict(counter=fr.counter, t_host_ns=fr.t_host_ns, peak_x=3 + i, peak_y=40 - i)
        row |= dict(peak=1234.5 + i, bg_mean=1000.25, bg_std=12.125 + i, snr=snr)
        flags = frozenset({"edge", "gps_cued"} if i == 4 else ())
        # The background a frame was measured against, and the target's extent.
        bg = dict(background="extent_rim", extent_w_px=12, extent_h_px=9) if i == 5 else {}
        values = {k: v for k, v in row.items() if k not in ("counter", "t_host_ns")}
        result = PeakSnr(**values, flags=flags, **bg)
        rec.add_measurement("mwir", i, result, counter=fr.counter, t_host_ns=fr.t_host_ns)
        extra = (b"extent_rim", 12, 9) if i == 5 else (b"rim", 0, 0)
        rows.append((i, *row.values(), 0b100010 if i == 4 else 0, *extra))
    for fr in lw:
        rec.add_frame("lwir", fr)
    ranges = [
        RangeReading(2_000_000, 336.5, RangeStatus.OK, 335.0, 12.5, 3.25, 0, "$PLTIT,HV,336.5,M"),
        RangeReading(2_500_000, None, RangeStatus.NO_TARGET, raw="E01"),
    ]
    for r in ranges:
        rec.add_range(r)
    utc = datetime(2018, 6, 5, 17, 3, 4, 250_000, tzinfo=UTC)
    fixes = [
        GpsFix(3_000_000, utc, 34.51, -117.21, 812.5, 780.1, 1, 9, 0.9, "$GPGGA,170304.25,..."),
        GpsFix(3_100_000, None, None, None, raw="$GPGGA,,,,"),
    ]
    for g in fixes:
        rec.add_gps(g)
    rec.add_event("roi_set", camera="mwir", payload={"x": 640, "y": 360}, t_host_ns=1_200_000)
    rec.add_event("note", payload={"text": "bird at left – ignore"}, t_host_ns=1_300_000)
    summary = rec.stop()
    assert summary.state == "stopped" and summary.error is None
    assert summary.frames_written == {"mwir": 20, "lwir": 9}
    assert summary.dropped == {"mwir": {}, "lwir": {}}

    with h5py.File(path, "r") as f:  # plain h5py, no snrmon reader
        assert f.attrs["format_version"] == "2.4"
        assert f["cameras/mwir/frames"].dtype == np.uint16
        assert f["cameras/mwir/frames"].chunks == (1, H, W)
        np.testing.assert_array_equal(f["cameras/mwir/frames"][()], [x.pixels for x in mw])
        np.testing.assert_array_equal(f["cameras/lwir/frames"][()], [x.pixels for x in lw])
        assert json.loads(f["config"].attrs["site"]) == CONFIG["site"]
        assert f["config"].attrs["operator"] == "ops"
        names = [n.decode() for n in f["cameras/mwir/measurements"].attrs["flag_names"]]
        assert names == list(FLAG_NAMES)

    with open_session(path) as s:
        assert s.recovered == "" and s.complete and s.config == CONFIG
        m = s.cameras["mwir"]
        assert m.n_frames == 20
        np.testing.assert_array_equal(m.counter, [x.counter for x in mw])
        np.testing.assert_array_equal(m.t_host_ns, [x.t_host_ns for x in mw])
        np.testing.assert_array_equal(m.t_device_ns, [x.t_device_ns or -1 for x in mw])
        ref = clock.reference
        np.testing.assert_array_equal(m.utc_ns, m.t_host_ns - ref.monotonic_ns + ref.utc_ns)
        assert (np.diff(m.t_host_ns) > 0).all() and (np.diff(m.utc_ns) > 0).all()
        names = (*MEASUREMENT_FIELDS_V1, "background", "extent_w_px", "extent_h_px")
        v1 = np.dtype([(n, m.measurements.dtype[n]) for n in names])
        expected = np.array(rows, v1)
        for name in expected.dtype.names:  # per field: NaN equals NaN
            np.testing.assert_array_equal(m.measurements[name], expected[name], err_msg=name)
        np.testing.assert_array_equal(m.frame(7), mw[7].pixels)
        rf = s.rangefinder
        assert rf["range_m"][0] == 336.5 and np.isnan(rf["range_m"][1])
        assert rf["status"].tolist() == [b"ok", b"no_target"]
        assert rf["azimuth_deg"][0] == 12.5 and rf["quality"].tolist() == [0, -1]
        assert rf["raw"][0] == b"$PLTIT,HV,336.5,M"
        g = s.gps
        assert g["fix_utc_ns"][0] == 1_528_218_184_250_000_000 and g["fix_utc_ns"][1] == -1
        assert g["lat_deg"][0] == 34.51 and np.isnan(g["lat_deg"][1])
        assert g["sats"].tolist() == [9, -1] and g["fix_quality"].tolist() == [1, 0]
        events = s.event_list()
        kinds = [e["kind"] for e in events]
        assert kinds[:2] == ["roi_set", "note"]
        assert "recording_started" in kinds and kinds[-1] == "recording_stopped"
        assert events[0]["payload"] == {"x": 640, "y": 360} and events[0]["camera"] == "mwir"
        assert events[1]["payload"]["text"] == "bird at left – ignore"


def test_measurement_index_lookup_peak_snr_and_clock_update(tmp_path: Path) -> None:
    clock = ClockMap()
    rec = SessionRecorder(tmp_path / "s.h5", config={}, cameras=CAMS, clock=clock)
    frames = make_frames("mwir", 3, 3)
    for fr in frames:
        rec.add_frame("mwir", fr)
    r = PeakSnr(5, 6, 900.0, 100.0, 10.0, 80.0, frozenset({"saturated", "lost"}))
    rec.add_measurement("mwir", None, r, counter=frames[2].counter, t_host_ns=frames[2].t_host_ns)
    rec.add_measurement("mwir", None, r, counter=1, t_host_ns=123)  # no such frame recorded
    clock.update_from_gps(frames[1].t_host_ns, datetime(2020, 1, 1, tzinfo=UTC))
    rec.stop()
    with open_session(tmp_path / "s.h5") as s:
        meas = s.cameras["mwir"].measurements
        assert meas["frame_index"].tolist() == [2, -1]
        assert meas["flags"].tolist() == [0b10001] * 2  # bit 0 saturated, bit 4 lost
        assert s.clock["source"].tolist() == [b"host", b"gps"]
        # the fix's receipt maps to the receiver's time through the recorded map
        assert utc_of_rows(s.clock, [frames[1].t_host_ns])[0] == 1_577_836_800 * 10**9


def test_ring_reader_feeds_the_recorder(tmp_path: Path) -> None:
    ring = FrameRing(64, H, W, name="mwir")
    rec = SessionRecorder(tmp_path / "s.h5", config={}, cameras={"mwir": (H, W)})
    rec.attach_reader("mwir", ring.reader("recorder"))
    frames = make_frames("mwir", 40, 4)
    for fr in frames:
        ring.push(fr)
    assert wait_for(lambda: rec.status().frames_written["mwir"] == 40)
    keep_pushing = threading.Event()
    keep_pushing.set()

    def camera() -> None:  # acquisition goes on while the recording stops
        i = 40
        while keep_pushing.is_set():
            ring.push(Frame(frames[0].pixels, "mwir", 600 + i, 10**9 + i))
            i += 1

    t = threading.Thread(target=camera)
    t.start()
    summary = rec.stop(timeout=10)
    keep_pushing.clear()
    t.join(5)
    assert summary.state == "stopped" and summary.frames_written["mwir"] >= 40
    assert ring.stats().readers == []  # the pump closed its reader
    with open_session(tmp_path / "s.h5") as s:
        np.testing.assert_array_equal(s.cameras["mwir"].frames[:40], [f.pixels for f in frames])
        assert (np.diff(s.cameras["mwir"].counter) > 0).all()


def test_backlog_overflow_drops_with_reason_and_accounting_sums(
    tmp_path: Path, monkeypatch
) -> None:
    gate = threading.Event()
    real = SessionWriter.write_frame

    def slow(self, *args):
        gate.wait(10)  # the disk "stalls" until released
        return real(self, *args)

    monkeypatch.setattr(SessionWriter, "write_frame", slow)
    frame_bytes = H * W * 2
    rec = SessionRecorder(
        tmp_path / "s.h5", config={}, cameras={"mwir": (H, W)}, max_backlog_bytes=5 * frame_bytes
    )
    results = [rec.add_frame("mwir", f) for f in make_frames("mwir", 12, 5)]
    assert results[:5] == [0, 1, 2, 3, 4]
    assert None in results
    st = rec.status()
    assert st.backlog_bytes <= 5 * frame_bytes and st.dropped["mwir"][BACKLOG] >= 6
    gate.set()
    summary = rec.stop()
    written, dropped = summary.frames_written["mwir"], summary.dropped["mwir"][BACKLOG]
    assert written + dropped == summary.frames_received["mwir"] == 12
    assert written == sum(r is not None for r in results)


def test_injected_write_error_stops_recording_and_acquisition_goes_on(
    tmp_path: Path, monkeypatch
) -> None:
    real = SessionWriter.write_frame
    calls = {"n": 0}
    flushed_before = threading.Event()

    def failing(self, *args):
        calls["n"] += 1
        if calls["n"] > 30:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(self, *args)

    monkeypatch.setattr(SessionWriter, "write_frame", failing)
    path = tmp_path / "s.h5"
    rec = SessionRecorder(path, config={}, cameras={"mwir": (H, W)}, flush_interval_s=0.05)
    frames = make_frames("mwir", 60, 6)
    for f in frames[:20]:
        rec.add_frame("mwir", f)
    assert wait_for(lambda: rec.status().frames_flushed["mwir"] == 20)
    flushed_before.set()
    for f in frames[20:]:
        rec.add_frame("mwir", f)  # never raises, whatever the writer thread does
    assert wait_for(lambda: rec.status().state == "failed")
    st = rec.status()
    assert st.error.startswith("recording stopped: disk full writing") and str(path) in st.error
    assert rec.add_frame("mwir", frames[0]) is None  # keeps returning after the failure
    rec.add_event("note", payload={"text": "after failure"})  # ignored, no raise
    summary = rec.stop()
    assert summary.state == "failed" and summary.error == st.error
    assert summary.frames_written["mwir"] >= 20
    assert summary.frames_written["mwir"] + summary.dropped["mwir"][STOPPED] == 61
    with open_session(path) as s:
        n = s.cameras["mwir"].n_frames
        assert n >= 20
        np.testing.assert_array_equal(s.cameras["mwir"].frames[:n], [f.pixels for f in frames[:n]])


@pytest.fixture
def tiny_fs(tmp_path: Path):
    mnt = tmp_path / "tiny"
    mnt.mkdir()
    if os.geteuid() != 0:
        pytest.skip("mounting a 4 MB tmpfs needs root")
    res = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=4m", "tmpfs", str(mnt)], check=False)
    if res.returncode != 0:
        pytest.skip("mount -t tmpfs is not permitted here")
    yield mnt
    subprocess.run(["umount", "-l", str(mnt)], check=False)


def test_real_full_filesystem_stops_with_message_and_file_stays_readable(tiny_fs: Path) -> None:
    path = tiny_fs / "s.h5"
    rec = SessionRecorder(path, config={}, cameras={"mwir": (H, W)}, flush_interval_s=0.05)
    frames = make_frames("mwir", 16, 7)  # 10 kB each; 4 MB fills after ~400
    i = 0
    while rec.status().state == "recording" and i < 2000:
        rec.add_frame("mwir", frames[i % 16])
        i += 1
        if i % 50 == 0:
            wait_for(lambda: rec.status().backlog_frames == 0 or rec.status().state != "recording")
    assert wait_for(lambda: rec.status().state == "failed"), rec.status()
    st = rec.status()
    assert "disk full" in st.error
    assert rec.add_frame("mwir", frames[0]) is None
    summary = rec.stop()
    assert summary.state == "failed"
    with open_session(path) as s:
        n = s.cameras["mwir"].n_frames
        assert n >= summary.frames_written["mwir"] > 100
        for k in (0, n // 2, n - 1):
            np.testing.assert_array_equal(s.cameras["mwir"].frame(k), frames[k % 16].pixels)


WRITER = """
import sys, time, numpy as np
from snrmon.acquisition.record.recorder import SessionRecorder
from snrmon.drivers.camera.frame import Frame
cams = {"mwir": (64, 80)}
rec = SessionRecorder(sys.argv[1], config={"k": 1}, cameras=cams, flush_interval_s=0.2)
t0 = time.monotonic()
i = 0
while True:
    px = np.full((64, 80), i % 65536, np.uint16)
    rec.add_frame("mwir", Frame(px, "mwir", i, time.monotonic_ns()))
    i += 1
    if i % 10 == 0:
        print(i, flush=True)
    time.sleep(max(0.0, t0 + i / 100 - time.monotonic()))  # paces the fake camera at 100 fps
"""


@pytest.mark.slow
def test_sigkill_mid_run_loses_at_most_the_last_second(tmp_path: Path) -> None:
    path = tmp_path / "killed.h5"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen(
        [sys.executable, "-c", WRITER, str(path)], stdout=subprocess.PIPE, text=True, env=env
    )
    added = 0
    try:
        for line in proc.stdout:
            added = int(line)
            if added >= 150:
                break
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.kill()
        proc.wait(10)
    assert added >= 150
    with pytest.raises(OSError, match="h5clear"):
        h5py.File(path, "r")  # what a plain reader meets after a crash
    with open_session(path) as s:
        assert s.recovered == "swmr_read" and not s.complete
        m = s.cameras["mwir"]
        assert added - 100 <= m.n_frames <= added + 10  # 100 fps: at most ~1 s lost
        np.testing.assert_array_equal(m.counter, np.arange(m.n_frames))
        assert (np.diff(m.t_host_ns) > 0).all()
        assert [int(m.frame(k)[0, 0]) for k in (0, m.n_frames - 1)] == [0, m.n_frames - 1]
        n = m.n_frames
    with open_session(path, repair=True) as s:
        assert s.recovered == "flags_cleared" and s.cameras["mwir"].n_frames == n
    assert clear_status_flags(path) is False
    with h5py.File(path, "r") as f:  # any HDF5 reader (MATLAB too) now opens it as is
        assert f["cameras/mwir/frames"].shape[0] >= n


def test_bad_input_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="compression 'snappy'"):
        SessionRecorder(tmp_path / "a.h5", config={}, cameras=CAMS, compression="snappy")
    with pytest.raises(ValueError, match="flush_interval_s"):
        SessionRecorder(tmp_path / "a.h5", config={}, cameras=CAMS, flush_interval_s=5)
    rec = SessionRecorder(tmp_path / "a.h5", config={}, cameras=CAMS)
    with pytest.raises(ValueError, match="'swir'"):
        rec.add_frame("swir", make_frames("mwir", 1, 0)[0])
    with pytest.raises(ValueError, match=r"\(64, 80\).*'lwir'"):
        rec.add_frame("lwir", make_frames("mwir", 1, 0)[0])
    with pytest.raises(ValueError, match="payload"):
        rec.add_event("note", payload={"text": "x" * 5000})
    with pytest.raises(ValueError, match="unknown flag 'hot'"):
        rec.add_measurement(
            "mwir", 0, PeakSnr(0, 0, 0.0, 0.0, 1.0, 0.0, frozenset({"hot"})), t_host_ns=0
        )
    rec.stop()
    with pytest.raises(FileExistsError):
        SessionRecorder(tmp_path / "a.h5", config={}, cameras=CAMS)
    with pytest.raises(FileNotFoundError):
        open_session(tmp_path / "missing.h5")
    with h5py.File(tmp_path / "other.h5", "w") as f:
        f["x"] = 1
    with pytest.raises(ValueError, match="not a snrmon session file"):
        open_session(tmp_path / "other.h5")


@pytest.mark.parametrize("compression", ["gzip", "bitshuffle-lz4"])
def test_lossless_compression_round_trip(tmp_path: Path, compression: str) -> None:
    if compression != "gzip":
        pytest.importorskip("hdf5plugin", reason="hdf5plugin not installed")
    rec = SessionRecorder(tmp_path / "c.h5", config={}, cameras=CAMS, compression=compression)
    frames = make_frames("mwir", 5, 8)
    for f in frames:
        rec.add_frame("mwir", f)
    assert rec.stop().frames_written["mwir"] == 5
    with open_session(tmp_path / "c.h5") as s:
        np.testing.assert_array_equal(s.cameras["mwir"].frames[()], [f.pixels for f in frames])
        assert s.attrs["frames_compression"] == compression


def test_status_gives_the_measured_compression_ratio(tmp_path: Path) -> None:
    """The live status's ratio is the frames' raw bytes over what the filter stored, as the
    file's own storage size says once closed; ``none`` is 1."""
    for compression in ("bitshuffle-lz4", None):
        path = tmp_path / f"{compression}.h5"
        rec = SessionRecorder(
            path, config={}, cameras=CAMS, flush_interval_s=0.05, compression=compression
        )
        rng = np.random.default_rng(3)  # a sky: 14-bit values, a few DN of noise
        for i in range(12):
            sky = rng.normal(2000.0, 8.0, (H, W)).astype(np.uint16)
            rec.add_frame("mwir", Frame(sky, "mwir", counter=i, t_host_ns=1_000 + i))
        deadline = time.monotonic() + 10
        while rec.status().frames_flushed["mwir"] < 12 and time.monotonic() < deadline:
            time.sleep(0.01)
        live = rec.status().compression_ratio
        rec.stop()
        with h5py.File(path, "r") as f:
            stored = f["cameras/mwir/frames"].id.get_storage_size()
        expected = 12 * H * W * 2 / stored
        assert live == pytest.approx(expected)
        assert (live > 1.2) if compression else live == pytest.approx(1.0, abs=1e-3)
