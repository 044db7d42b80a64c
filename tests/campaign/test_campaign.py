"""``snrmon campaign`` against ``snrmon replay`` on the same sessions."""

from __future__ import annotations

import contextlib
import io
import json
import math
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import pytest

from snrmon.campaign.tables import STOP_SCHEMA, read_metadata
from snrmon.cli import main

# What `snrmon replay --json` prints for a stop -> the campaign table's column.
SAME = {
    "camera": "camera",
    "lrf_range_m": "lrf_range_m",
    "gps_range_m": "gps_range_m",
    "n_frames": "n_frames",
    "measured_snr_mean": "snr_mean",
    "measured_snr_std": "snr_std",
    "measured_snr_sem": "snr_sem",
    "background": "background",
}


def _none(v):
    return None if isinstance(v, float) and math.isnan(v) else v


def campaign(argv: list[str], capsys) -> tuple[int, dict]:
    code = main(["campaign", *argv, "--json", "--quiet"])
    return code, json.loads(capsys.readouterr().out)


def table_rows(out: Path, session: str) -> list[dict]:
    rows = pq.read_table(out / "stops.parquet").to_pylist()
    return [{c: r[c] for c in SAME.values()} for r in rows if r["session"] == session]


def unreplayable_copy(session: Path, folder: Path) -> Path:
    """A copy of ``session`` that passes the input checks but cannot be replayed: its camera's
    sensor file (``gone.toml``) does not exist."""
    import shutil

    import h5py

    broken = folder / "broken.h5"
    shutil.copyfile(session, broken)
    with h5py.File(broken, "r+") as f:
        config = json.loads(f.attrs["config_json"])
        config["session"]["cameras"]["lwir"]["sensor"] = str(folder / "gone.toml")
        f.attrs["config_json"] = json.dumps(config)
    return broken


@pytest.fixture(scope="module")
def reference(hil_sessions) -> dict[str, list[dict]]:
    """Each session's stop rows from `snrmon replay --json`, one after the other."""
    out = {}
    for p in hil_sessions:
        text = io.StringIO()
        with contextlib.redirect_stdout(text):
            assert main(["replay", str(p), "--json"]) == 0
        stops = json.loads(text.getvalue())["stops"]
        out[p.stem] = [{col: _none(s[key]) for key, col in SAME.items()} for s in stops]
    return out


@pytest.mark.slow
def test_local_cluster_table_equals_serial_replay(hil_sessions, reference, tmp_path, capsys):
    out = tmp_path / "out"
    code, result = campaign(
        [*map(str, hil_sessions), "--out", str(out), "--workers", "2", "--frame-table"], capsys
    )
    assert code == 0, result["failures"]
    assert result["executor"] == "LocalCluster(2)" and result["failures"] == []
    assert sum(len(v) for v in reference.values()) >= 3  # every flight found stops
    for p in hil_sessions:
        assert table_rows(out, p.stem) == reference[p.stem], p.stem
    table = pq.read_table(out / "stops.parquet")
    assert table.schema.remove_metadata() == STOP_SCHEMA
    meta = read_metadata(out / "stops.parquet")
    assert meta["settings"]["fast"] is True and meta["settings"]["source"] is None
    assert meta["campaign"]["sessions"] == [str(p) for p in hil_sessions]
    assert meta["units"]["snr_sem"].startswith("snr_std / sqrt")
    rows = table.to_pylist()
    for r in rows:
        assert r["gps_source"] == "live" and r["background_method"] == "rim"
        assert r["day"].isoformat() == "2019-05-14"  # the simulated receiver's date
        if r["range_m"] is not None:
            assert r["model_small_corrected"] > 0
            # the twin calibrated itself: the model's sky is the measured one (rendered 280 K)
            assert r["model_sky_temp_k"] == pytest.approx(280.0, abs=0.5)
    # Per-frame tables: one per session, every measured frame, stops marked.
    for t in result["tasks"]:
        frames = pq.read_table(out / "frames" / f"{t['session']}.parquet")
        assert frames.num_rows == t["measured"] > 0
        assert set(frames.column("camera").to_pylist()) == {"lwir"}
        assert frames.column("stop").null_count < frames.num_rows
        df = pd.read_parquet(out / "frames" / f"{t['session']}.parquet")
        assert str(df["stop"].dtype) == "Int32"  # nulls outside stops, integers inside
        assert str(df["utc"].dtype) == "datetime64[ns, UTC]"
        assert df["utc"].dt.year.unique().tolist() == [2019]
    stops_df = pd.read_parquet(out / "stops.parquet")
    assert str(stops_df["t_start_utc"].dtype) == "datetime64[ns, UTC]"
    ended = stops_df["t_end_utc"].notna()  # NaT: a stop still open when the file ended
    assert (stops_df["t_end_utc"][ended] > stops_df["t_start_utc"][ended]).all()
    assert (out / "campaign-report.pdf").stat().st_size > 10_000
    assert json.loads((out / "campaign.json").read_text())["frames_per_s"] > 0


def test_bad_sessions_refuse_the_campaign_before_it_starts(hil_sessions, tmp_path, capsys):
    """A damaged or missing session is one line and exit 2 before any worker starts, and
    nothing is written (a campaign half made from the good ones is not what was asked)."""
    corrupt = tmp_path / "corrupt.h5"
    corrupt.write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(range(256)) * 64)
    missing = tmp_path / "missing.h5"
    for bad, says in ((corrupt, "damaged HDF5 file"), (missing, "does not exist")):
        out = tmp_path / f"out-{bad.stem}"
        argv = ["campaign", str(hil_sessions[0]), str(bad), "--out", str(out)]
        code = main([*argv, "--workers", "2"])
        err = capsys.readouterr().err.strip()
        assert code == 2 and len(err.splitlines()) == 1, err
        assert str(bad) in err and says in err
        assert not out.exists()


@pytest.mark.slow
def test_a_session_that_fails_in_its_replay_fails_its_own_task(hil_sessions, tmp_path, capsys):
    """A session that passes the input checks but cannot be replayed (its camera's sensor file
    is gone) fails its own task; the others go into the table."""
    broken = unreplayable_copy(hil_sessions[1], tmp_path)
    out = tmp_path / "out"
    code, result = campaign(
        [str(hil_sessions[0]), str(broken), "--out", str(out), "--workers", "2"], capsys
    )
    assert code == 1
    errors = {f["session"]: f["error"] for f in result["failures"]}
    assert set(errors) == {str(broken)}
    assert "gone.toml" in errors[str(broken)]
    sessions = {r["session"] for r in pq.read_table(out / "stops.parquet").to_pylist()}
    assert sessions == {hil_sessions[0].stem}
    assert len(json.loads((out / "campaign.json").read_text())["failures"]) == 1


@pytest.mark.slow
def test_existing_scheduler_and_worker_processes(hil_sessions, reference, tmp_path, capsys):
    from distributed import Client

    dask = str(Path(sys.executable).parent / "dask")
    info = tmp_path / "scheduler.json"
    procs = [
        subprocess.Popen(
            [
                dask,
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--no-dashboard",
                "--scheduler-file",
                str(info),
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    ]
    try:
        worker = [
            dask,
            "worker",
            "--scheduler-file",
            str(info),
            "--nworkers",
            "2",
            "--nthreads",
            "1",
            "--no-dashboard",
        ]
        procs.append(subprocess.Popen(worker, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        # The scheduler file appears once the scheduler listens; the client waits for workers.
        with Client(scheduler_file=str(info), timeout=60) as client:
            client.wait_for_workers(2, timeout=60)
            address = client.scheduler.address
        assert address.startswith("tcp://127.0.0.1:")
        out = tmp_path / "out"
        code, result = campaign(
            [*map(str, hil_sessions), "--out", str(out), "--scheduler", address], capsys
        )
        assert code == 0 and result["executor"] == address
        for p in hil_sessions:
            assert table_rows(out, p.stem) == reference[p.stem], p.stem
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            p.wait(30)


def test_no_stop_ends_before_it_starts_in_a_file_that_stepped_its_clock(hil_sessions, tmp_path):
    """A session recorded before format 2.4 whose clock stepped from the host's date to the
    receiver's (2019) in the middle of a stop: both ends of every stop come from the session's
    one clock, so none ends before it starts and each is dated by the receiver."""
    import shutil

    import h5py
    import numpy as np

    from snrmon.acquisition.record.reader import open_session
    from snrmon.campaign.settings import AnalysisSettings
    from snrmon.campaign.tasks import analyse_camera

    path = tmp_path / "stepped.h5"
    shutil.copy(hil_sessions[0], path)
    with open_session(path) as f:
        stop = next(e["payload"] for e in f.event_list() if e["payload"].get("t_end_ns"))
        first = int(f.cameras["lwir"].t_host_ns[0])
        gps = f.clock[-1]
    t_step = (stop["t_start_ns"] + stop["t_end_ns"]) // 2  # inside the stop
    host_utc = int(pd.Timestamp("2026-12-01", tz="UTC").value)
    old = np.array(
        [(first - 10**9, host_utc, b"host"), (t_step, int(gps["utc_ns"]), b"gps")],
        [("monotonic_ns", "<i8"), ("utc_ns", "<i8"), ("source", "S32")],
    )
    with h5py.File(path, "r+") as h:
        del h["clock"]
        h.create_dataset("clock", data=old, maxshape=(None,))
        h.attrs["format_version"] = "2.3"
    rows = analyse_camera(str(path), "lwir", AnalysisSettings()).stops
    assert rows
    for r in rows:
        assert r["day"].isoformat() == "2019-05-14", r
        if r["t_end_utc"] is not None:
            assert r["t_end_utc"] > r["t_start_utc"], r


def test_every_line_on_stderr_has_the_command_prefix(hil_sessions, tmp_path, capsys):
    """The text output of a campaign with a failing task: every stderr line starts with
    ``snrmon campaign:``, the failure a warning naming the session and why."""
    broken = unreplayable_copy(hil_sessions[1], tmp_path)
    argv = [str(hil_sessions[0]), str(broken), "--out", str(tmp_path / "o"), "--workers", "0"]
    code = main(["campaign", *argv])
    err = capsys.readouterr().err
    assert code == 1
    lines = [line for line in err.splitlines() if line.strip()]
    assert lines and all(line.startswith("snrmon campaign: ") for line in lines), err
    failed = [line for line in lines if "FAILED" in line]
    assert len(failed) == 1 and failed[0].startswith(f"snrmon campaign: warning: FAILED {broken}")
    assert "gone.toml" in failed[0]
