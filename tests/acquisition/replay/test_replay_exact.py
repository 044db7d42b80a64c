"""Replay reproduces the live session exactly, across recording gaps.

A live Session on simulated devices (a camera process writing a shared-memory ring, an LDM
rangefinder and an NMEA GPS on pseudo-terminals) is recorded through a disk that stalls now and
then, with the recorder's backlog limit lowered to a few frames, so the recorder drops frames
while the engine measures every one. The replay must reproduce every recorded frame's Eq. (4)
result, running statistics and track window exactly, take the dropped frames' measurements from
their rows, restore the engine's state at each gap, report the file's own drop counts, and build
the live stop table.
"""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.measure.noise3d import noise_3d
from snrmon.acquisition.record.reader import open_session
from snrmon.acquisition.record.recorder import BACKLOG
from snrmon.acquisition.record.writer import SessionWriter
from snrmon.acquisition.replay.batch import replay_session
from snrmon.acquisition.replay.stop_noise import stop_noise, summary_run
from snrmon.acquisition.runtime.session import Session
from snrmon.acquisition.stops.detector import StopConfig
from snrmon.acquisition.stops.table import row_values_equal
from snrmon.cli import main
from snrmon.sim.devices.ldm_sim import LdmSimulator
from snrmon.sim.devices.nmea_sim import NmeaSimulator
from snrmon.sim.devices.shm_camera import ShmProducer
from tests.helpers import H, SpotOnNoise, W, running_n, wait_until


@pytest.fixture
def stalling_disk(monkeypatch):
    """Every 25th frame write takes 60 ms: a disk that stalls (the recorder's queue, limited to
    a few frames, overflows and drops frames; the writer itself never fails)."""
    real = SessionWriter.write_frame
    calls = {"n": 0}

    def slow(self, *args):
        calls["n"] += 1
        if calls["n"] % 25 == 0:
            time.sleep(0.06)  # the stall being simulated, not a synchronisation
        return real(self, *args)

    monkeypatch.setattr(SessionWriter, "write_frame", slow)


@pytest.fixture
def live(tmp_path, stalling_disk):
    name = f"snrmon-exact-{time.monotonic_ns() % 10**9}"
    producer = ShmProducer(name, W, H, SpotOnNoise(5), fps=60.0, slots=32)
    producer.start()
    lrf = LdmSimulator(lambda t: 150.0, rate_hz=20.0, tracking=True).start()
    gps = NmeaSimulator(lambda t: (32.3810, -106.4790, 1250.0), rate_hz=10.0).start()
    config = session_config_from_dict(
        {
            "site": {"lat_deg": 32.38, "lon_deg": -106.48, "alt_m": 1200.0},
            "cameras": {"cam": {"source": "shm", "address": name, "width_px": W, "height_px": H}},
            "lrf": {"protocol": "ldm", "port": lrf.path, "baud": 9600},
            "gps": {"protocol": "nmea", "port": gps.path, "baud": 38400},
        }
    )
    session = Session(config, stop_config=StopConfig(steady_s=1.0, min_readings=3))
    try:
        yield session, tmp_path
    finally:
        session.stop()
        producer.stop()
        lrf.stop()
        gps.stop()


def test_replay_after_forced_recorder_drops_reproduces_every_recorded_frame(live, capsys):
    session, tmp_path = live
    session.start()
    session.set_roi("cam", 66, 39)
    path = tmp_path / "gappy.h5"
    # A backlog of three frames: every stall of the disk costs frames.
    session.start_recording(path, max_backlog_bytes=3 * H * W * 2)
    wait_until(lambda: any(r.reading.complete for r in session.stops()), 20.0, "a complete stop")
    measured = session.pipelines["cam"].stages.frames
    wait_until(
        lambda: session.pipelines["cam"].stages.frames >= measured + 120,
        10.0,
        "two more seconds",
    )
    session.stop()  # the session ends: its rows are final, the recording closes
    live_rows = session.stops()
    summary = session.last_recording
    dropped = summary.dropped["cam"].get(BACKLOG, 0)
    assert dropped > 0, "the stalling disk must have cost frames"
    assert summary.frames_written["cam"] + dropped == summary.frames_received["cam"]

    replay = replay_session(path, fast=True)
    cam = replay.cameras["cam"]
    t = cam.tally
    assert cam.dropped == {BACKLOG: dropped}  # the file's own accounting, with its reason
    assert t.not_in_file == dropped  # measured live, pixels dropped: the recorded rows used
    assert t.compared == summary.frames_written["cam"] > 0
    assert t.identical == t.compared, f"first difference at counter {t.first_difference}"
    assert t.states_restored >= 1  # the engine's state was restored after the gaps
    assert [r.final for r in live_rows] == [True] * len(live_rows)
    assert len(replay.stops) == len(live_rows) >= 1
    for a, b in zip(replay.stops, live_rows, strict=True):
        assert row_values_equal(a, b), (a, b)
    assert replay.stops_identical == len(live_rows)

    # The same through the command: strict JSON, the drops with their reason, nothing made up.
    slow = replay_session(path)  # whole frames through h5py: the same numbers
    assert slow.cameras["cam"].tally.identical == t.identical
    assert [r.reading.snr_mean for r in slow.stops] == [r.reading.snr_mean for r in replay.stops]

    # The stop's background 3D noise from the recorded measurements (snrmon noise --stop) is
    # the one the report takes from the replay's, and it is of the file's own frames there.
    row = replay.stops[0]
    ms = [m for m in t.measurements if m.t_host_ns >= row.place.t_start_ns]
    ms = [m for m in ms if row.place.t_end_ns is None or m.t_host_ns < row.place.t_end_ns]
    with open_session(path) as f:
        rec = f.cameras["cam"]
        got = stop_noise(
            rec, row.stop, row.range_m, [m.result for m in ms], [m.t_host_ns for m in ms]
        )
        index, _run = summary_run(rec, [m.result for m in ms], [m.t_host_ns for m in ms])
        x0, y0, x1, y1 = got.region
        cube = np.stack([rec.frames[i][y0 : y1 + 1, x0 : x1 + 1] for i in index])
    # the run's frames the file holds (the recorder dropped some of the 100 measured)
    assert got.frames == (index[0], index[-1]) and 2 <= index.size <= 100
    assert got.noise.sigma == noise_3d(cube).sigma
    peaks = {(m.result.peak_x, m.result.peak_y) for m in ms}
    assert not any(x0 - 20 <= x <= x1 + 20 and y0 - 20 <= y <= y1 + 20 for x, y in peaks)
    assert main(["noise", str(path), "--stop", str(row.stop), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["sigma_corrected_dn"] == dict(got.noise.sigma_corrected)
    assert out["frames"] == got.noise.frames == index.size


def test_replay_json_reports_the_files_drops(live, capsys):
    session, tmp_path = live
    session.start()
    session.set_roi("cam", 66, 39)
    path = tmp_path / "gappy.h5"
    session.start_recording(path, max_backlog_bytes=3 * H * W * 2)
    measured = session.pipelines["cam"].stages.frames
    wait_until(
        lambda: session.pipelines["cam"].stages.frames >= measured + 90,
        10.0,
        "1.5 s recorded",
    )
    session.stop()
    dropped = session.last_recording.dropped["cam"].get(BACKLOG, 0)
    capsys.readouterr()
    assert main(["replay", str(path), "--fast", "--json"]) == 0
    out = json.loads(capsys.readouterr().out, parse_constant=_refuse)
    frames = out["frames"]["cam"]
    assert frames["dropped"].get(BACKLOG, 0) == dropped
    assert frames["identical"] == frames["compared"] == frames["in_file"]
    assert out["format_version"] == "2.4"


def _refuse(token: str):
    raise AssertionError(f"{token} in JSON output")


@pytest.fixture
def tiny_disk(tmp_path):
    mnt = tmp_path / "tiny"
    mnt.mkdir()
    import os
    import subprocess

    if os.geteuid() != 0:
        pytest.skip("mounting a 2 MB tmpfs needs root")
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(mnt)]).returncode:
        pytest.skip("mount -t tmpfs is not permitted here")
    yield mnt
    subprocess.run(["umount", "-l", str(mnt)], check=False)


def test_disk_full_stops_the_recording_not_the_session_and_the_file_replays(tmp_path, tiny_disk):
    name = f"snrmon-full-{time.monotonic_ns() % 10**9}"
    producer = ShmProducer(name, W, H, SpotOnNoise(9), fps=60.0, slots=32)
    producer.start()
    config = session_config_from_dict(
        {"cameras": {"cam": {"source": "shm", "address": name, "width_px": W, "height_px": H}}}
    )
    session = Session(config)
    try:
        session.start()
        session.set_roi("cam", 66, 39)
        path = tiny_disk / "full.h5"
        session.start_recording(path)  # 24 kB frames: the 2 MB disk is full in about a second
        wait_until(lambda: session.status().recording.state == "failed", 20.0, "a full disk")
        st = session.status()
        (alarm,) = [a for a in st.alarms if a.startswith("recording:")]
        assert "disk full" in alarm and str(path) in alarm
        measured = session.pipelines["cam"].stages.frames
        wait_until(
            lambda: session.pipelines["cam"].stages.frames >= measured + 60,
            10.0,
            "measurement to go on",
        )
        assert running_n(session.status(), "cam") > 0
    finally:
        session.stop()
        producer.stop()
    replay = replay_session(path, fast=True)  # up to the last flushed frame
    t = replay.cameras["cam"].tally
    assert t.compared > 0 and t.identical == t.compared
