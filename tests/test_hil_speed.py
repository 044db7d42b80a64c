"""A simulated day never drops a frame: its clock runs as fast as asked but never ahead of what
the console takes (snrmon/rig/flight_clock.py), the pipelines and the recorder wait instead of
dropping, and every frame received is accounted for in the live JSON, the file and the replay,
on a machine with another program busy beside it."""

from __future__ import annotations

import subprocess
import sys

import pytest

from snrmon.acquisition.record.reader import open_session
from snrmon.acquisition.stops.detector import StopConfig
from snrmon.cli import main
from snrmon.rig.flight_clock import FlightClock
from tests.helpers import strict_json, wait_until


def test_the_clock_runs_free_until_the_console_holds_it():
    newest = {"cam": None}
    clock = FlightClock(1000.0, {"cam": (10.0, lambda: newest["cam"])})
    clock.start()
    try:
        # No frame received yet: the clock runs at its speed.
        wait_until(lambda: clock.now() > 5.0, 5.0, "the clock to run")
        # The console's newest frame is counter 9 (0.9-1.0 s of the camera): the clock stops
        # LEAD_S past it, whatever the wall clock does ...
        newest["cam"] = 9
        clock.tick()
        start = clock.now()
        points = len(clock.table_since(0)[0])
        wait_until(lambda: len(clock.table_since(0)[0]) > points + 5, 5.0, "10 ms of ticks")
        assert clock.now() == start
        # ... and goes on as frames arrive, never backwards.
        newest["cam"] = 10_000
        wait_until(lambda: clock.now() > 2 * start + 1.0, 5.0, "the clock released")
    finally:
        clock.stop()
    a = clock.achieved()
    assert a["speed"] == 1000.0 and a["achieved"] < 1000.0 and a["held_back_s"] > 0
    # The host -> clock table is monotonic and interpolates within its points.
    host, taus = clock.table_since(0)
    assert host == sorted(host) and taus == sorted(taus)
    mid = (host[1] + host[2]) // 2
    assert taus[1] <= clock.at(mid) <= taus[2]


def test_stop_detection_runs_on_flight_time():
    assert StopConfig().at_speed(1.0).steady_s == 3.0
    assert StopConfig().at_speed(2.5).steady_s == pytest.approx(1.2)


@pytest.fixture
def busy_machine():
    """Another program spinning on a core while the day runs."""
    proc = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        yield proc
    finally:
        proc.kill()
        proc.wait(10)


@pytest.mark.slow
def test_speed_max_on_a_busy_machine_keeps_and_accounts_for_every_frame(
    busy_machine, capsys, tmp_path
):
    folder = tmp_path / "day"
    folder.mkdir()
    path = folder / "s.h5"
    argv = ["hil", "--speed", "max", "--seed", "4", "--cameras", "lwir", "--stops", "393"]
    argv += ["--transit-mps", "40", "--out", str(path), "--json"]
    assert main(argv) == 0
    out, err = capsys.readouterr()
    assert busy_machine.poll() is None  # it was busy all along
    result = strict_json(out)
    (stop,) = result["stops"]
    assert stop["planned_range_m"] == 393.0 and stop["n_frames"] == 100
    assert stop["measured_snr_mean"] == pytest.approx(stop["truth_snr"], rel=0.10)
    assert result["speed"]["asked"] == "max" and 0 < result["speed"]["achieved"] <= 8.0
    # Every frame received is in the file or was received before the recording began.
    acc = result["frames"]["lwir"]
    assert acc == result["recording"]["accounting"]["lwir"]
    assert set(acc["dropped"].values()) <= {0} and acc["camera_gap"] == 0
    assert acc["received"] == acc["written"] + acc["before_recording"]
    assert acc["after_recording"] == acc["queued"] == 0
    assert "dropped" not in err  # no drop, so no warning
    # No probe, calibration or other file left beside the recording: the recording and its
    # log; the day's blackbody calibration is inside the recording, where the replay finds it.
    assert sorted(p.name for p in folder.iterdir()) == ["s.h5", "s.log"]
    with open_session(path) as f:
        meta, maps = f.calibration_record("lwir")
        shape = f.cameras["lwir"].frames.shape[1:]
    assert meta["blackbody_temps_c"] == [0.0, 45.0] and maps["responsivity"].shape == shape
    # The recording replays to the live run's numbers, frame for frame and stop for stop, and
    # carries the same accounting.
    assert main(["replay", str(path), "--fast", "--json"]) == 0
    replay = strict_json(capsys.readouterr().out)
    frames = replay["frames"]["lwir"]
    assert frames["in_file"] == acc["written"]
    assert frames["identical"] == frames["compared"] > 0
    assert {k: frames[k] for k in acc} == acc  # the file's accounting, by the same names
    assert replay["stops_identical"] == replay["stops_recorded"] == 1
    (again,) = replay["stops"]
    assert again["measured_snr_mean"] == stop["measured_snr_mean"]


def test_a_speed_the_console_cannot_hold_slows_the_day_and_says_so(tmp_path, caplog):
    """A console that takes 20 ms a frame (a slow machine) asked for 8x of a 30 fps camera
    (240 frames a second): the day slows down to what it takes, every frame kept, and the run
    says so on stderr (a warning), in the session's log, in the file and in its JSON."""
    import logging
    import time

    from snrmon.acquisition.record.reader import open_session
    from snrmon.rig.rig import HilOptions, HilRig

    out = tmp_path / "s.h5"
    opts = HilOptions(
        seed=3,
        speed=8.0,
        stops_m=(37.0,),
        cameras=("lwir",),
        hover_s=2.0,
        calibrate=False,
        out=str(out),
    )
    rig = HilRig(opts)
    rig.session.add_measurement_listener(lambda m, px: time.sleep(0.02))  # the slow console
    with caplog.at_level(logging.WARNING), rig:
        result = rig.run()
    speed = result["speed"]
    assert speed["asked"] == 8.0 and speed["achieved"] < 0.95 * 8.0
    (line,) = [r.getMessage() for r in caplog.records if "cannot hold speed 8" in r.getMessage()]
    assert "the simulated day runs at" in line and "rather than drop frames" in line
    assert "cannot hold speed 8" in out.with_suffix(".log").read_text()
    with open_session(out) as f:
        (event,) = [e for e in f.event_list() if e["kind"] == "hil_speed"]
        assert event["payload"]["asked"] == 8.0
    acc = result["frames"]["lwir"]
    assert not any(acc["dropped"].values())
    assert acc["received"] == acc["written"] + acc["before_recording"]
