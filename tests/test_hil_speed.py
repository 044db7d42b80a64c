"""``snrmon hil --speed max``: the speed is chosen from the loads measured on this machine, and
the flight at that speed keeps every frame and still finds its stops with 100 frames each."""

from __future__ import annotations

import math
import re

import pytest

from snrmon.cli import main
from snrmon.rig.rig import stop_config_at
from snrmon.rig.speed import (
    CONSOLE_SHARE,
    MAX_SPEED,
    RECORD_SHARE,
    RENDER_SHARE,
    TOTAL_SHARE,
    speed_from_loads,
)
from tests.helpers import strict_json


def test_speed_is_the_tightest_share_rounded_down():
    # The console at 40% of a core allows 0.6 / 0.4 = 1.5x; the cameras allow more.
    assert speed_from_loads(0.4, {"mwir": 0.15, "lwir": 0.05}, 2) == pytest.approx(
        math.floor(CONSOLE_SHARE / 0.4 * 10) / 10
    )
    # A slow renderer limits its own process.
    assert speed_from_loads(0.05, {"mwir": 0.5}, 8) == pytest.approx(
        math.floor(RENDER_SHARE / 0.5 * 10) / 10
    )
    # One core for everything: the machine's total limits.
    assert speed_from_loads(0.2, {"mwir": 0.2, "lwir": 0.2}, 1) == pytest.approx(
        math.floor(TOTAL_SHARE / 0.6 * 10) / 10
    )
    assert speed_from_loads(0.001, {"lwir": 0.001}, 4) == MAX_SPEED
    assert speed_from_loads(50.0, {"lwir": 1.0}, 1) == 0.1  # never zero


def test_a_recording_is_limited_by_what_the_disk_sustains():
    # 129 MB/s of frames at speed 1 onto a disk that sustains 340 MB/s past its cache: the CPU
    # would allow 8x, the disk allows 0.7 x 340 / 129 = 1.8x.
    speed = speed_from_loads(0.01, {"mwir": 0.01}, 8, disk_mb_per_s=340.0, data_mb_per_s=129.0)
    assert speed == pytest.approx(math.floor(RECORD_SHARE * 340.0 / 129.0 * 10) / 10)
    assert speed_from_loads(0.01, {"mwir": 0.01}, 8) == MAX_SPEED  # no recording: no limit


def test_stop_detection_runs_on_flight_time():
    assert stop_config_at(1.0).steady_s == 3.0
    assert stop_config_at(2.5).steady_s == pytest.approx(1.2)


@pytest.mark.slow
def test_hil_speed_max_keeps_every_frame_and_replays_exactly(capsys, tmp_path):
    path = tmp_path / "s.h5"
    rc = main(
        [
            "hil",
            "--speed",
            "max",
            "--seed",
            "4",
            "--camera",
            "lwir",
            "--stops",
            "393",
            "--transit-mps",
            "40",
            "--out",
            str(path),
            "--json",
        ]
    )
    out, err = capsys.readouterr()
    assert rc == 0
    m = re.search(r"speed max = ([0-9.]+) x real time on (\d+) cores", err)
    assert m, err
    assert 0.1 <= float(m.group(1)) <= MAX_SPEED
    assert "the disk sustains" in err  # with --out the disk was measured too
    result = strict_json(out)
    (stop,) = result["stops"]
    assert stop["planned_range_m"] == 393.0 and stop["n_frames"] == 100
    assert stop["measured_snr_mean"] == pytest.approx(stop["truth_snr"], rel=0.10)
    assert result["frames"]["lwir"]["dropped"] == 0
    rec = result["recording"]
    assert rec["dropped"] == {"lwir": {}}
    assert rec["frames_written"] == rec["frames_received"]
    # The recording replays to the live run's numbers, frame for frame and stop for stop.
    assert main(["replay", str(path), "--fast", "--json"]) == 0
    replay = strict_json(capsys.readouterr().out)
    frames = replay["frames"]["lwir"]
    assert frames["dropped"] == 0 and frames["in_file"] == rec["frames_written"]["lwir"]
    assert frames["identical"] == frames["compared"] > 0
    assert replay["stops_identical"] == replay["stops_recorded"] == 1
    (again,) = replay["stops"]
    assert again["measured_snr_mean"] == stop["measured_snr_mean"]
