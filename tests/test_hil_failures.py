"""``snrmon hil`` failing in the field: killed without warning, its disk full. Each ends the
way an operator can see (exit code, one line), with no process left behind and the file whole."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _alive(procs: list[psutil.Process]) -> list[psutil.Process]:
    out = []
    for p in procs:
        try:
            if p.status() != psutil.STATUS_ZOMBIE:
                out.append(p)
        except psutil.NoSuchProcess:
            pass
    return out


def _until(predicate, timeout_s: float, what: str):
    deadline = time.monotonic() + timeout_s
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.1)  # polling other processes' state: nothing to wait on


@pytest.mark.slow
def test_no_child_of_hil_outlives_a_sigkill():
    """SIGKILL runs no handler: the camera processes and the model's worker end with the
    console all the same (the parent-death signal), and the resource tracker after them."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    cmd = [sys.executable, "-m", "snrmon", "hil", "--stops", "50", "--hover-s", "60"]
    proc = subprocess.Popen(
        [*cmd, "--no-calibration", "--quiet"],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        parent = psutil.Process(proc.pid)
        # both cameras, the worker and the resource tracker
        children = _until(
            lambda: (k := parent.children(recursive=True)) and len(k) >= 4 and k,
            180,
            "hil's child processes",
        )
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
        _until(lambda: not _alive(children), 30, "no child of the killed hil left")
    finally:
        proc.kill()
        proc.wait(10)
        for child in _alive(locals().get("children") or []):
            child.kill()


def _hil(out: Path, *, seed: int, speed: str, extra: tuple[str, ...] = ()) -> int:
    from snrmon.cli import main

    argv = ["hil", "--seed", str(seed), "--stops", "60", "--hover-s", "4", "--speed", speed]
    return main([*argv, "--cameras", "mwir", "--no-calibration", "--out", str(out), *extra])


@pytest.mark.slow
@pytest.mark.parametrize("speed", ["1", "max"])
@pytest.mark.parametrize("seed", [0, 1])
def test_no_stream_of_a_hil_day_steps_back_in_time(tmp_path, capsys, seed, speed):
    """A simulated day at speed 1 and as fast as it goes, two seeds: in every stream, UTC
    (``utc_ns``, and each frame's ``time``) increases with the host clock, never stepping back;
    the map recorded in ``/clock`` gives every stamp again, and a replay measures the frames at
    the recorded times."""
    import h5py
    import numpy as np

    from snrmon.acquisition.record.reader import open_session
    from snrmon.acquisition.replay.batch import replay_session
    from snrmon.acquisition.streams.timebase import utc_of_rows

    out = tmp_path / f"day-{seed}-{speed}.h5"
    assert _hil(out, seed=seed, speed=speed, extra=("--json", "--quiet")) == 0
    capsys.readouterr()
    with open_session(out) as f:
        cam = f.cameras["mwir"]
        streams = {"mwir": (cam.t_host_ns, cam.utc_ns)}
        for name in ("rangefinder", "gps", "events"):
            rows = getattr(f, name)
            live = rows["utc_ns"] >= 0  # an event added afterwards is never stamped
            streams[name] = (rows["t_host_ns"][live], rows["utc_ns"][live])
        clock = f.clock
        recorded_t = cam.t_host_ns.copy()
    with h5py.File(out, "r") as h:  # the per-frame coordinate, read without snrmon
        time_ns = h["cameras/mwir/time"][()]
    assert len(recorded_t) > 300
    assert np.all(np.diff(cam.utc_ns) > 0) and np.array_equal(time_ns, cam.utc_ns)
    for name, (t, u) in streams.items():
        order = np.argsort(t, kind="stable")
        t, u = t[order], u[order]
        assert np.all(np.diff(u)[np.diff(t) > 0] > 0), name  # strictly, where the host moved
        assert np.all(np.diff(u) >= 0), name
        assert np.array_equal(utc_of_rows(clock, t), u), name  # /clock reproduces each stamp
    # row 0 the host's guess, row 1 the receiver's first time (the simulator's 2019 date: the
    # whole map relabelled by years), then slews of what the receipts showed (well under 1 s)
    assert clock["source"].tolist()[:2] == [b"host", b"gps"]
    assert abs(clock["residual_ns"][1]) > 86400e9 and np.all(np.abs(clock["residual_ns"][2:]) < 1e9)
    replay = replay_session(out, fast=True)
    replayed_t = [m.t_host_ns for m in replay.cameras["mwir"].tally.measurements]
    assert set(replayed_t) <= set(recorded_t.tolist()) and len(replayed_t) > 0
    assert np.array_equal(utc_of_rows(clock, replayed_t), np.sort(utc_of_rows(clock, replayed_t)))


def _mounted_tmpfs(path: Path, size: str) -> bool:
    path.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)])
    return done.returncode == 0


@pytest.mark.skipif(os.geteuid() != 0, reason="mounting a small tmpfs needs root")
def test_hil_on_a_full_disk_ends_like_record(tmp_path, capsys):
    """``snrmon hil --out`` on a disk that fills (a 40 MiB tmpfs: some 400 raw frames of a
    256 x 192 sub-array, stored uncompressed so that the short flight fills it): the day ends
    with exit 1 and one error line naming the file on that disk and the frames written, the
    stop table is still printed, and the file opens (no repair asked) holding every frame it
    says it wrote."""
    from snrmon.acquisition.record.reader import open_session

    disk = tmp_path / "small-disk"
    if not _mounted_tmpfs(disk, "40m"):
        pytest.skip("mount -t tmpfs failed (no CAP_SYS_ADMIN in this container)")
    try:
        out = disk / "full.h5"
        code = _hil(out, seed=0, speed="max", extra=("--size", "256x192", "--compression", "none"))
        captured = capsys.readouterr()
        assert code == 1, captured.err
        errors = [line for line in captured.err.splitlines() if ": error: " in line]
        assert len(errors) == 1, captured.err
        assert errors[0].startswith(
            f"snrmon hil: error: recording stopped: disk full writing {out}"
        )
        written = int(errors[0].rsplit(" after ", 1)[1].split()[0])
        assert "stop" in captured.out and "range" in captured.out  # the stop table, measured
        with open_session(out) as f:
            assert f.cameras["mwir"].n_frames == written > 0
    finally:
        subprocess.run(["umount", "-l", str(disk)])


@pytest.mark.slow
def test_a_camera_lost_mid_day_holds_the_day_no_more_and_fails_it(capsys):
    """The MWIR camera's process is killed after its first frames: the loss is seen at once
    (the ended process, though its parent has not reaped it yet), the day's clock stops waiting
    for that camera, so the LWIR camera, GPS and rangefinder fly the day to its end (before, the
    clock held at the dead camera's last frame, every other device fell silent with it and the
    day never ended); the result lists the loss and the day ends as a failure naming it."""
    from snrmon.acquisition.runtime.session import DeviceError
    from snrmon.rig.rig import HilOptions, HilRig

    opts = HilOptions(seed=2, speed=2.0, stops_m=(60.0,), hover_s=3.0, calibrate=False)
    rig = HilRig(opts)
    never_s = 900.0  # a guard, not a speed: the day that never ends fails here, not hangs
    give_up = time.monotonic() + never_s
    with rig:
        killed = False
        while rig.step():
            assert time.monotonic() < give_up, f"the day did not end in {never_s} s"
            if not killed and rig.session.pipelines["mwir"].status().frames.received >= 30:
                # as the OOM killer would: the process ends, unreaped (a zombie) until asked
                os.kill(rig.cameras["mwir"].producer.pid, signal.SIGKILL)
                killed = True
            time.sleep(0.05)  # the operator's pace, as HilRig.run
        rig.finish()
        result = rig.result()
    assert killed and rig.flight_time() >= rig.plan.duration_s
    assert [x["device"] for x in result["devices_lost"]] == ["mwir"], result["devices_lost"]
    assert "died" in result["devices_lost"][0]["error"]
    lwir = result["frames"]["lwir"]["received"]
    assert lwir > result["frames"]["mwir"]["received"]  # it went on after mwir was gone
    with pytest.raises(DeviceError, match=r"^mwir lost at \S+ \(disconnected: .*died\)$"):
        rig.check_failures()
