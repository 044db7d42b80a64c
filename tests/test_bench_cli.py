"""``snrmon bench`` reports figures in the documented JSON shape (never asserts a speed)."""

from __future__ import annotations

import itertools

import pytest

from snrmon.cli import main
from tests.helpers import strict_json


@pytest.mark.slow
def test_bench_json_has_the_sections_asked_for(capsys):
    assert main(["bench", "--only", "measurement,model", "--duration", "0.2", "--json"]) == 0
    out = strict_json(capsys.readouterr().out)
    assert set(out) == {"machine", "measurement", "model", "goals", "failed"}
    assert out["failed"] == []
    assert out["measurement"]["per_frame_us_1280x720"] > 0
    assert out["model"]["mwir_four_curves_500_ranges_ms"] > 0
    # the goals of the two sections run, each with its figure read and a verdict
    goals = {g["goal"]: g for g in out["goals"]}
    assert len(goals) == 6 and all(g["met"] in (True, False) for g in goals.values())
    assert (
        goals["Eq. (4) per frame, 1280x720"]["value"] == out["measurement"]["per_frame_us_1280x720"]
    )


def test_bench_duration_must_be_positive(capsys):
    assert main(["bench", "--duration", "0"]) == 2
    assert "--duration must be positive" in capsys.readouterr().err


@pytest.mark.slow
def test_acquisition_soak_rolls_its_recording_and_samples_memory(monkeypatch):
    """A run longer than a segment records in segments (an hour raw would fill the disk) and
    samples the resident memory along the way; the last segment replays."""
    from snrmon.benchmarks import bench_acquisition

    monkeypatch.setattr(bench_acquisition, "SEGMENT_S", 1.0)
    monkeypatch.setattr(bench_acquisition, "RSS_EVERY_S", 0.5)
    out = bench_acquisition.run(2.6)
    acq = out["acquisition"]
    # rolled at 1 s, and at 2 s unless the first roll (a recording closed and fsynced, a new one
    # begun) took the machine past 2.5 s, the last moment a roll is still worth it
    rolls = acq["segment_rolls_s"]
    assert acq["recording_segments"] == 1 + len(rolls) and 1 <= len(rolls) <= 2
    assert all(t >= k + 1 for k, t in enumerate(rolls)) and all(t < 2.5 for t in rolls)
    # sampled along the way, each at least RSS_EVERY_S after the one before (about five on an
    # idle machine; fewer where a roll held the loop up), and on after the first roll
    times = [t for t, _ in acq["rss_mb_samples"]]
    assert len(times) >= 2 and times[-1] > rolls[0]
    assert all(b - a >= 0.5 - 0.1 for a, b in itertools.pairwise(times))  # times to 0.1 s
    assert all(rss > 50 for _, rss in acq["rss_mb_samples"])
    assert acq["recording_mb"] > 0
    assert out["replay"]["fps"] > 0  # the last segment is a complete, readable session
    # The stage table: each camera's frames of this run, every stage named, the text table too.
    from snrmon.acquisition.stage_clock import COLUMNS

    for cam in ("mwir", "lwir"):
        stages = acq["stages"][cam]
        assert stages["frames"] > 0 and set(COLUMNS) <= set(stages)
        assert stages["latency"]["p99_ms"] >= stages["latency"]["p50_ms"] > 0
    text = bench_acquisition.format_text(out)
    assert all(f"\n  {name:12s}" in text for name in COLUMNS)
    assert len(out["replay"]["fast_realtime_factor_runs"]) == bench_acquisition.REPEATS
    assert out["replay"]["identical_every_run"] is True
    # Each fast replay in the order run: its factor among the sorted ones, the processes that
    # played it (two cameras: one or two), what it read from the disk.
    runs = out["replay"]["fast_runs_in_order"]
    assert sorted(r["realtime_factor"] for r in runs) == out["replay"]["fast_realtime_factor_runs"]
    assert all(r["processes"] in (1, 2) and r["read_mb"] >= 0 for r in runs)
    assert {r["processes"] for r in out["replay"]["fast_runs_in_order_mwir"]} == {1}


def test_tracking_real_summary_and_table_from_scored_runs():
    """The tracking-real benchmark's figures and table (the runs themselves take minutes on all
    33 clips: tests/acquisition/track/test_tracker_real.py scores a subset)."""
    from snrmon.benchmarks.bench_tracking_real import _summary, format_text
    from snrmon.benchmarks.real_clips import RunScore

    runs = [
        RunScore("IR_DRONE_048", "right", (250, 160), 320, 0, 0.988, 0.191, 2, 0, 1, 4),
        RunScore("IR_DRONE_151", "right", (165, 162), 301, 0, 1.0, 0.0, 0, 0, 0, 0),
        RunScore("IR_DRONE_020", "right", (170, 45), 302, 0, 0.94, 0.99, 20, 3, 1, 18),
    ]
    s = _summary(runs)
    assert (s["clips"], s["clips_at_95pct"], s["worst_clip"]) == (3, 2, "IR_DRONE_020")
    assert s["median_fraction"] == 0.988
    assert round(s["worst_vs_baseline_points"], 6) == -5.0  # 020: 94 % against 99 %
    assert s["longest_miss_frames"] == 18
    figures = {
        "runs": 3,
        "frames_tracked": 923,
        "seconds": 1.0,
        "every_click": {"right": s},
        "all_clicks": s,
        "per_clip": {
            r.clip: {
                "frames": r.frames,
                "inseparable": 0,
                "worst": r.fraction,
                "median": r.fraction,
                "baseline_worst": r.baseline,
                "worst_vs_baseline_points": 100 * (r.fraction - r.baseline),
                "lost_frames_max": r.lost,
                "occluded_frames_max": r.occluded,
                "reacquisitions_max": r.reacquisitions,
                "longest_miss_frames": r.longest_miss,
            }
            for r in runs
        },
    }
    lines = format_text(figures).splitlines()
    assert lines[0].split()[:4] == ["clip", "frames", "insep", "worst"]
    assert lines[1].split()[:4] == ["IR_DRONE_048", "320", "0", "98.8%"]
    assert any(line.startswith("all ") and " 2/3 " in line for line in lines)


def test_goals_read_the_bench_figures_and_say_which_are_met():
    """Each goal reads its own section's figure; a section not run gives no row, a figure not
    measured gives a row with no value and no verdict."""
    from snrmon.benchmarks.goals import GOALS, format_goals, goal_rows

    result = {
        "acquisition": {"mwir": {"latency_ms_p99": 6.5}, "lwir": {"latency_ms_p99": 12.0}},
        "gui": {"mwir_shown_fps": 60.0, "mwir_delivered_fps": 60.0, "lwir_delivered_fps": 30.0},
        "console": {"dropped_per_run": [0, 0, 3], "stops_short_per_run": [0, 0, 0]},
    }
    rows = {r["goal"]: r for r in goal_rows(result)}
    sections = {g.name: g.section for g in GOALS}
    assert set(rows) == {name for name, sec in sections.items() if sec in result}
    assert rows["MWIR receipt -> SNR latency p99"] == {
        "goal": "MWIR receipt -> SNR latency p99",
        "target": "<= 10 ms",
        "value": 6.5,
        "met": True,
    }
    assert rows["LWIR receipt -> SNR latency p99"]["met"] is False
    assert rows["MWIR frames shown / delivered"]["value"] == 1.0
    lwir = rows["LWIR frames shown / delivered"]  # the shown count is missing
    assert lwir["value"] is None and lwir["met"] is None
    worst = rows["console demo beside a busy core, frames dropped (worst run)"]
    assert worst["value"] == 3 and worst["met"] is False
    text = format_goals(list(rows.values()))
    assert "NOT MET" in text and "not measured" in text


def test_each_benchmark_runs_in_a_fresh_interpreter_and_its_figures_come_back():
    import math
    import os

    from snrmon.benchmarks.fresh_process import figures_in_fresh_process
    from tests import bench_stub

    figures = figures_in_fresh_process(bench_stub, 0.25)
    assert figures["pid"] != os.getpid()  # another process
    assert figures["frames"] == 3 and figures["fps"] == 0.5 and figures["per_run"] == [0, 1]
    assert math.isnan(figures["not_measured"]) and figures["pair"] == [1, 2]
    assert figures["seconds"] == 0.25


def test_a_benchmark_that_fails_is_named_and_its_error_shown(capsys):
    import pytest

    from snrmon.benchmarks.fresh_process import BenchmarkError, figures_in_fresh_process
    from tests import bench_stub

    with pytest.raises(BenchmarkError, match=r"benchmark bench_stub failed \(exited with 1\)"):
        figures_in_fresh_process(bench_stub, -1.0)
    assert "ValueError: a negative duration: -1.0" in capsys.readouterr().err


def test_cli_benchmark_runs_every_command_help_and_holds_the_slowest_to_its_goal(monkeypatch):
    from snrmon.benchmarks import bench_cli
    from snrmon.benchmarks.goals import goal_rows
    from snrmon.cli import build_parser, iter_parsers

    lines = bench_cli.command_lines()
    progs = {p.prog for p in iter_parsers(build_parser())}
    assert {"snrmon " + " ".join(a[:-1]) for a in lines[2:]} | {"snrmon"} == progs
    assert lines[:2] == [["--version"], ["--help"]]
    # Two of them, once each (the whole list is `snrmon bench --only cli`).
    monkeypatch.setattr(bench_cli, "command_lines", lambda: [["--version"], ["noise", "--help"]])
    monkeypatch.setattr(bench_cli, "REPEATS", 1)
    figures = bench_cli.run(0.0)
    assert set(figures["cpu_s"]) == {"snrmon --version", "snrmon noise --help"}
    assert all(0 < v < 30 for v in figures["cpu_s"].values())
    assert figures["max_cpu_s"] == max(figures["cpu_s"].values())
    (row,) = goal_rows({"cli": figures})
    assert row["value"] == figures["max_cpu_s"] and row["target"] == "<= 0.3 s"
    assert "slowest: snrmon" in bench_cli.format_text(figures)


def test_the_compression_figures_are_the_files_own_and_the_rule_picks_the_default(tmp_path):
    """Bytes per frame through the recorder's writer are what h5py says the filter stored, on
    the real Cedip frames; the rule picks the fastest filter within the size and CPU bounds."""
    import h5py
    import hdf5plugin
    import numpy as np

    from snrmon.benchmarks.bench_compression import chosen_filter, filter_figures, real_frames

    frames = real_frames()["lwir"]
    figures = filter_figures(frames, "bitshuffle-lz4", tmp_path)
    with h5py.File(tmp_path / "ref.h5", "w") as f:  # the plugin's filter, written directly
        for i, px in enumerate(frames):
            f.create_dataset(f"f{i}", data=px, chunks=px.shape, **hdf5plugin.Bitshuffle(65536))
        stored = sum(f[f"f{i}"].id.get_storage_size() for i in range(len(frames)))
    assert figures["bytes_per_frame"] == stored / len(frames)
    assert figures["ratio"] == frames.nbytes / stored > 2  # 14 of 16 bits, a quiet sky
    assert figures["cpu_ms_per_frame"] > 0 and not list(tmp_path.glob("bitshuffle*"))
    assert filter_figures(frames, "none", tmp_path)["ratio"] == np.float64(1.0)
    measured = {
        "none_twin_size": 1.0,
        "none_both_cameras_core": 0.06,
        "bitshuffle_lz4_twin_size": 0.44,
        "bitshuffle_lz4_both_cameras_core": 0.16,
        "zstd_twin_size": 0.44,
        "zstd_both_cameras_core": 0.49,
        "gzip_twin_size": 0.40,
        "gzip_both_cameras_core": 1.77,
    }
    assert chosen_filter(measured) == "bitshuffle-lz4"
    assert chosen_filter({**measured, "bitshuffle_lz4_twin_size": 0.46}) == "zstd"
    assert chosen_filter({"gzip_twin_size": 0.4, "gzip_both_cameras_core": 1.8}) is None
