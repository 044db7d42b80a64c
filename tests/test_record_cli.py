"""``snrmon record`` on simulated devices: a session config naming a shared-memory camera and
pty rangefinder/GPS, a fixed duration, and a file that opens with the recorded streams."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from snrmon.acquisition.record.reader import open_session
from snrmon.acquisition.replay.batch import replay_session
from snrmon.cli import main
from tests.helpers import H, W, field_config, field_devices


@pytest.fixture
def devices(tmp_path):
    """A simulated shared-memory camera, LDM rangefinder and NMEA GPS, and the session config
    that names them."""
    ring = f"snrmon-rec-{time.monotonic_ns() % 10**9}"
    with field_devices(ring) as (_, lrf, gps):
        yield field_config(
            tmp_path / "session.toml", ring, gps.path, lrf.path, f"width_px = {W}\nheight_px = {H}"
        )


def test_record_writes_a_session_from_a_config(devices, tmp_path, capsys):
    out = tmp_path / "rec.h5"
    code = main(
        [
            "record",
            "--config",
            str(devices),
            "--out",
            str(out),
            "--duration",
            "2",
            "--click",
            "cam:64,41",
        ]
    )
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "MB written" in captured.err
    # every line on stderr (progress, info) carries the command's prefix
    assert all(line.startswith("snrmon record: ") for line in captured.err.splitlines())
    with open_session(out) as f:
        n = f.cameras["cam"].n_frames
        assert 60 <= n <= 200  # about two seconds at 60 fps
        assert f.attrs["frames_compression"] == "bitshuffle-lz4"  # the default
        assert f.cameras["cam"].frames.id.get_create_plist().get_filter(0)[0] == 32008
        assert len(f.rangefinder) >= 10 and len(f.gps) >= 10
        meas = f.cameras["cam"].measurements
        assert (meas["peak_x"] == 64).mean() > 0.95
    assert f"cam {n} frames" in captured.out
    # The session's log beside its recording: what wrote it, the devices' story, its end.
    lines = out.with_suffix(".log").read_text().splitlines()
    assert "recording rec.h5; snrmon " in lines[0] and "command: " in lines[0]
    assert any("snrmon.progress: recording: " in line and "cam " in line for line in lines[1:-1])
    assert lines[-1].endswith("recording log closed")


def test_record_refuses_to_overwrite(tmp_path, capsys):
    out = tmp_path / "x.h5"
    out.write_bytes(b"")
    cfg = tmp_path / "c.toml"
    cfg.write_text('[cameras.a]\nsource = "shm"\n')
    assert main(["record", "--config", str(cfg), "--out", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err


def test_record_bad_config_is_one_line(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[cameras.a]\nsource = "firewire"\n')
    assert main(["record", "--config", str(cfg), "--out", str(tmp_path / "o.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "firewire" in err


@pytest.mark.parametrize("duration", ["0", "-1"])
def test_record_duration_must_be_positive(tmp_path, capsys, duration):
    cfg = tmp_path / "c.toml"
    cfg.write_text('[cameras.a]\nsource = "shm"\n')
    args = ["record", "--config", str(cfg), "--out", str(tmp_path / "o.h5"), "--duration"]
    with pytest.raises(SystemExit) as refused:  # by the parser, before the config is read
        main([*args, duration])
    assert refused.value.code == 2
    assert (
        f"argument --duration: must be a number above 0 and up to 2678400 s, got '{duration}'"
        in (capsys.readouterr().err)
    )


@pytest.mark.slow
def test_sigterm_closes_the_recording_whole(devices, tmp_path):
    """``kill`` (SIGTERM) stops ``snrmon record`` like Ctrl-C: the file is closed cleanly (no
    recovery needed) with every frame the progress line had counted."""
    out = tmp_path / "rec.h5"
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    cmd = [sys.executable, "-m", "snrmon", "record", "--config", str(devices), "--out", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    seen, counted = b"", 0
    try:
        while counted < 60:  # the progress line, refreshed every 0.5 s, reads >= 60 frames
            chunk = os.read(proc.stderr.fileno(), 4096)
            assert chunk, f"snrmon record ended early: {seen.decode(errors='replace')}"
            seen += chunk
            counts = re.findall(rb"cam (\d+) frames", seen)
            counted = int(counts[-1]) if counts else 0
        proc.send_signal(signal.SIGTERM)
        stdout, stderr = proc.communicate(timeout=30)
    finally:
        proc.kill()
        proc.wait(10)
    assert proc.returncode == 0, (seen + stderr).decode(errors="replace")
    assert b"recorded " in stdout
    with open_session(out) as f:
        assert f.recovered == "" and f.complete
        assert f.cameras["cam"].n_frames >= counted


@pytest.mark.slow
def test_kill_9_loses_at_most_a_second_and_the_file_replays(devices, tmp_path):
    """SIGKILL (power loss, OOM killer): no handler runs. The file opens without repair, holds
    every frame up to the last flush (at most ~1 s lost at 60 fps), and replays: every frame it
    holds measures as it did live."""
    out = tmp_path / "killed.h5"
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    cmd = [
        sys.executable,
        "-m",
        "snrmon",
        "record",
        "--config",
        str(devices),
        "--out",
        str(out),
        "--click",
        "cam:66,39",
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    seen, counted = b"", 0
    try:
        while counted < 150:
            chunk = os.read(proc.stderr.fileno(), 4096)
            assert chunk, f"snrmon record ended early: {seen.decode(errors='replace')}"
            seen += chunk
            counts = re.findall(rb"cam (\d+) frames", seen)
            counted = int(counts[-1]) if counts else 0
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
    finally:
        proc.kill()
        proc.wait(10)
    with open_session(out) as f:
        assert f.recovered == "swmr_read" and not f.complete
        n = f.cameras["cam"].n_frames
        rows = len(f.cameras["cam"].measurements)
    assert counted - 60 - 30 <= n  # the progress line lags by up to 0.5 s; 1 s lost at most
    assert rows > 0
    replay = replay_session(out, fast=True)
    t = replay.cameras["cam"].tally
    assert t.compared > 0 and t.identical == t.compared


@pytest.mark.slow
def test_a_dropped_frame_is_never_silent(tmp_path, capsys):
    """A camera that loses five frames (a gap in its counter) while recording: a warning line on
    stderr and in the session's log, an alarm in the console's status, a ``frames_dropped``
    event in the file, and the accounting of every frame in its summary."""
    from snrmon.sim.devices.ldm_sim import LdmSimulator
    from snrmon.sim.devices.nmea_sim import NmeaSimulator
    from snrmon.sim.devices.shm_camera import ShmProducer
    from tests.helpers import SpotOnNoise

    ring = f"snrmon-drop-{time.monotonic_ns() % 10**9}"
    lost = frozenset(range(200, 205))  # about 3.3 s after the camera starts
    producer = ShmProducer(ring, W, H, SpotOnNoise(3), fps=60.0, slots=16, drop_counters=lost)
    lrf = LdmSimulator(lambda t: 200.0, rate_hz=10.0, tracking=True)
    gps = NmeaSimulator(lambda t: (32.3810, -106.4790, 1250.0), rate_hz=10.0)
    producer.start()
    lrf.start()
    gps.start()
    try:
        config = field_config(
            tmp_path / "session.toml", ring, gps.path, lrf.path, f"width_px = {W}\nheight_px = {H}"
        )
        out = tmp_path / "drop.h5"
        argv = ["record", "--config", str(config), "--out", str(out), "--duration", "6"]
        code = main(argv)
    finally:
        producer.stop()
        lrf.stop()
        gps.stop()
    err = capsys.readouterr().err
    assert code == 0, err
    warning = "warning: cam: 5 frames dropped (camera_gap 5)"
    assert any(line.startswith("snrmon record: " + warning) for line in err.splitlines()), err
    assert "cam: 5 frames dropped (camera_gap 5)" in out.with_suffix(".log").read_text()
    assert "ALARM cam frames: 5 dropped (camera 5, ring overrun 0)" in err  # the status line
    with open_session(out) as f:
        # The five this camera lost come first; a busy machine may make the simulated camera
        # lose more of its own later (each its own event), and every one is counted.
        events = [e for e in f.event_list() if e["kind"] == "frames_dropped"]
        acc = f.summary["extra"]["accounting"]["cam"]
        n = f.cameras["cam"].n_frames
    assert events[0]["camera"] == "cam" and events[0]["payload"]["new"] == {"camera_gap": 5}
    gaps = [e["payload"]["new"].get("camera_gap", 0) for e in events]
    assert acc["camera_gap"] == sum(gaps) and acc["written"] == n
    assert acc["received"] == (
        acc["written"]
        + sum(acc["dropped"].values())
        + acc["before_recording"]
        + acc["after_recording"]
        + acc["queued"]
    )


@pytest.mark.parametrize("missing", ["camera", "gps", "lrf"])
def test_a_device_that_does_not_exist_stops_record(tmp_path, capsys, missing):
    """A camera ring, GPS port or rangefinder port the config names that does not exist: the
    device delivers nothing within its start-up timeout, and ``record`` stops with exit 1 and
    one error line naming the device and what it could not open."""
    ring = f"snrmon-miss-{time.monotonic_ns() % 10**9}"
    with field_devices(ring) as (_, lrf, gps):
        ports = {"camera": ring, "gps": gps.path, "lrf": lrf.path}
        ports[missing] = {
            "camera": f"{ring}-absent",
            "gps": str(tmp_path / "no-gps-pty"),
            "lrf": str(tmp_path / "no-lrf-pty"),
        }[missing]
        config = field_config(
            tmp_path / "session.toml",
            ports["camera"],
            ports["gps"],
            ports["lrf"],
            f"width_px = {W}\nheight_px = {H}",
            start_timeout_s=1.5,
        )
        out = tmp_path / "rec.h5"
        code = main(["record", "--config", str(config), "--out", str(out), "--duration", "5"])
    err = capsys.readouterr().err
    assert code == 1, err
    errors = [line for line in err.splitlines() if ": error: " in line]
    assert len(errors) == 1, err
    name = {"camera": "cam", "gps": "gps", "lrf": "lrf"}[missing]
    line = errors[0]
    assert line.startswith(f"snrmon record: error: {name}: no reading within 1.5 s of the start")
    assert ports[missing] in line  # the ring or port it could not open
    with open_session(out) as f:  # created before the devices, closed whole, nothing lost
        assert f.complete
        n = f.cameras["cam"].n_frames
    assert n == 0 if missing == "camera" else n > 0  # what the others gave while it waited


@pytest.mark.slow
def test_a_camera_killed_mid_recording_ends_record_with_exit_1(tmp_path):
    """The camera's process is killed (SIGKILL) while ``record`` runs: the loss is logged with
    its time, the file's summary lists it, the command ends with exit 1 and one error line,
    and the file is closed whole with every frame the camera published before it died."""
    from snrmon.sim.devices.ldm_sim import LdmSimulator
    from snrmon.sim.devices.nmea_sim import NmeaSimulator
    from snrmon.sim.devices.shm_camera import ShmProducer
    from tests.helpers import SpotOnNoise

    ring = f"snrmon-kill-{time.monotonic_ns() % 10**9}"
    producer = ShmProducer(ring, W, H, SpotOnNoise(5), fps=60.0, slots=16)
    lrf = LdmSimulator(lambda t: 200.0, rate_hz=10.0, tracking=True)
    gps = NmeaSimulator(lambda t: (32.3810, -106.4790, 1250.0), rate_hz=10.0)
    producer.start()
    lrf.start()
    gps.start()
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    out = tmp_path / "killed-camera.h5"
    config = field_config(
        tmp_path / "session.toml", ring, gps.path, lrf.path, f"width_px = {W}\nheight_px = {H}"
    )
    cmd = [sys.executable, "-m", "snrmon", "record", "--config", str(config), "--out", str(out)]
    proc = subprocess.Popen(
        [*cmd, "--duration", "8"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env
    )
    seen, counted = b"", 0
    try:
        while counted < 60:  # a second of frames recorded, then the camera dies
            chunk = os.read(proc.stderr.fileno(), 4096)
            assert chunk, f"snrmon record ended early: {seen.decode(errors='replace')}"
            seen += chunk
            counts = re.findall(rb"cam (\d+) frames", seen)
            counted = int(counts[-1]) if counts else 0
        producer.kill()
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        proc.kill()
        proc.wait(10)
        producer.close()
        lrf.stop()
        gps.stop()
    err = (seen + stderr).decode(errors="replace")
    assert proc.returncode == 1, err
    assert re.search(r"snrmon record: warning: cam lost at \d{4}-\d\d-\d\dT[\d:.]+\+00:00", err)
    errors = [line for line in err.splitlines() if ": error: " in line]
    assert len(errors) == 1 and errors[0].startswith("snrmon record: error: cam lost at "), err
    assert "died" in errors[0]  # why: the camera's writer process is gone
    assert b"recorded " in stdout
    with open_session(out) as f:
        assert f.recovered == "" and f.complete
        counters = np.asarray(f.cameras["cam"].counter)
        n = len(counters)
        lost = f.summary["extra"]["devices_lost"]
        acc = f.summary["extra"]["accounting"]["cam"]
        events = [e for e in f.event_list() if e["kind"] == "device_lost"]
    assert n >= counted
    assert [x["device"] for x in lost] == ["cam"] and lost[0]["back_utc"] is None
    assert [e["payload"]["device"] for e in events] == ["cam"]
    # Every frame the camera gave while recording, up to its death, is in the file, no gap.
    assert np.array_equal(counters, np.arange(counters[0], counters[0] + n))
    assert acc["written"] == n and not any(acc["dropped"].values()) and acc["queued"] == 0


def test_a_refused_second_writer_opens_no_device(devices, tmp_path, capsys, monkeypatch):
    """A second ``record`` onto a file another writer creates between the second's input check
    and its start (two operators starting at once): refused (exit 2, the file named) before it
    opened any device, so the first recording's GPS and camera lose nothing to it."""
    import h5py

    from snrmon.commands import record
    from snrmon.drivers.device import Device

    out = tmp_path / "rec.h5"
    checked = record.output_file

    def first_writer_wins(*args, **kwargs):
        path = checked(*args, **kwargs)
        h5py.File(path, "w-").close()  # the first writer's file, made just after the check
        return path

    opened = []
    monkeypatch.setattr(record, "output_file", first_writer_wins)
    monkeypatch.setattr(Device, "open", lambda self: opened.append(self.name))
    code = main(["record", "--config", str(devices), "--out", str(out), "--duration", "2"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err == f"snrmon record: error: session file {out} already exists"
    assert opened == []  # no port, no camera ring


def test_compression_option_overrides_the_config(devices, tmp_path, capsys):
    """``--compression`` wins over the config's key; the frames read back the same through h5py
    and hdf5plugin, independently of snrmon's reader."""
    import h5py
    import hdf5plugin  # noqa: F401

    config = tmp_path / "zstd.toml"
    config.write_text('compression = "lz4"\n' + devices.read_text())
    out = tmp_path / "z.h5"
    argv = ["record", "--config", str(config), "--out", str(out), "--duration", "1"]
    assert main([*argv, "--compression", "zstd"]) == 0, capsys.readouterr().err
    with h5py.File(out, "r") as f:
        frames = f["cameras/cam/frames"]
        assert f.attrs["frames_compression"] == "zstd"
        assert frames.id.get_create_plist().get_filter(0)[0] == 32015  # Zstandard's id
        assert frames.shape[0] > 10 and frames[()].std() > 0
    out2 = tmp_path / "l.h5"
    assert main(["record", "--config", str(config), "--out", str(out2), "--duration", "1"]) == 0
    with h5py.File(out2, "r") as f:
        assert f.attrs["frames_compression"] == "lz4"  # the config's key
    capsys.readouterr()
    with pytest.raises(SystemExit) as exit_:
        main([*argv[:4], str(tmp_path / "x.h5"), "--compression", "snappy"])
    assert exit_.value.code == 2 and "--compression: invalid choice: 'snappy'" in (
        capsys.readouterr().err
    )
