"""Sustained acquisition and replay (the targets in the README), measured on this machine.

Both simulated cameras at their real rates (MWIR 1280x720 at 60 fps, LWIR 640x480 at 30 fps,
each rendered by its own process into a shared-memory ring), the GPS and the rangefinder on
pseudo-terminals, the tracker measuring every frame and the recorder writing everything to a
session file: frames per second achieved, frames dropped, latency from receipt to SNR, the
console process's CPU and resident memory at start and end (an hour's ``--duration`` is the soak
test). Then the recording is replayed, full frames and ``--fast``.

Recording both cameras raw is 129 MB/s, 465 GB an hour, more than the disks this runs on hold.
A run longer than ``SEGMENT_S`` therefore records in segments: every ``SEGMENT_S`` the session
stops recording, the finished file is deleted and a new one starts (the operator's record
button, pressed twice); the last segment is replayed. The resident memory is sampled every
``RSS_EVERY_S`` so a soak shows its curve, not only its ends.

Targets: 0 dropped frames over 60 s; p99 latency under 10 ms on both cameras; ``--fast``
replay of both cameras at least 100x real time, the median of five replays, every recorded frame
reproduced in each. The stage table (``acquisition.stages``, docs/engine.md) says where each
camera's frames spend their time. Each fast replay also says, in the order run, how many
processes played it (a second camera gets its own only when a core is idle) and what it read
from the disk rather than the page cache, which tell a slow run on a busy machine or a dropped
page cache from a slow replay.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import psutil

KEY = "acquisition"
TOP_LEVEL = True  # reports {"acquisition": ..., "replay": ...}


SEGMENT_S = 120.0  # 15.5 GB of raw frames
REPEATS = 5  # fast replays of the recording, both cameras and MWIR alone
RSS_EVERY_S = 60.0


def _rss_mb(proc: psutil.Process) -> float:
    return proc.memory_info().rss / 2**20


def run(duration_s: float) -> dict:
    with tempfile.TemporaryDirectory(prefix="snrmon-bench-") as tmp:
        path = Path(tmp) / "bench.h5"
        acquisition = _sustained_acquisition(path, duration_s)
        replay = _replay_figures(path)
    return {"acquisition": acquisition, "replay": replay}


@dataclass
class _Recording:
    """What the acquisition loop leaves: the frames each camera had received at its start, how
    long it ran, the segments it recorded and the resident memory it sampled."""

    received0: dict[str, int]
    elapsed_s: float = 0.0
    segments: int = 1
    rolls_s: list[float] = field(default_factory=list)  # when (s after the start) one began
    rss_samples: list[tuple[float, float]] = field(default_factory=list)


def _sustained_acquisition(path: Path, duration_s: float) -> dict:
    """The HIL rig acquiring and recording to ``path`` for ``duration_s``: per camera its rate,
    drops and latency, then the console process's figures and the stage table."""
    from snrmon.rig.rig import HilOptions, HilRig

    proc = psutil.Process()
    opts = HilOptions(
        seed=0,
        speed=1.0,
        stops_m=(393.0,),
        start_range_m=392.0,
        hover_s=float(duration_s) + 2.0,
        out=str(path),
    )
    with HilRig(opts) as rig:
        rss_start = _rss_mb(proc)
        proc.cpu_percent(None)
        recording = _acquire_for(rig, path, duration_s, proc)
        cpu = proc.cpu_percent(None)
        pipelines = rig.session.pipelines
        status = {n: p.status() for n, p in pipelines.items()}
        drops = {n: p.drops() for n, p in pipelines.items()}
        stages = {n: p.stage_times() for n, p in pipelines.items()}
        rss_end = _rss_mb(proc)
    acquisition = _camera_figures(status, drops, recording)
    acquisition.update(
        stages=stages,
        latency_ms_p50=max(st.latency.p50_ms for st in status.values()),
        latency_ms_p99=max(st.latency.p99_ms for st in status.values()),
        cpu_percent=cpu,
        rss_mb_start=rss_start,
        rss_mb_end=rss_end,
        duration_s=recording.elapsed_s,
        rss_mb_samples=recording.rss_samples,
        recording_segments=recording.segments,
        segment_rolls_s=recording.rolls_s,
        recording_mb=path.stat().st_size / 2**20,
    )
    return acquisition


def _acquire_for(rig, path: Path, duration_s: float, proc: psutil.Process) -> _Recording:
    """Step ``rig`` for ``duration_s``, sampling the resident memory every ``RSS_EVERY_S`` and
    starting a new recording segment every ``SEGMENT_S`` (the finished one deleted)."""
    t0 = time.monotonic()
    pipelines = rig.session.pipelines
    recording = _Recording({n: p.accounting().received for n, p in pipelines.items()})
    for p in pipelines.values():
        p.stages.reset()  # the stage table covers this run, not the start-up
    deadline = t0 + duration_s
    next_segment, next_rss = t0 + SEGMENT_S, t0 + RSS_EVERY_S
    while time.monotonic() < deadline and rig.step():
        time.sleep(0.1)  # sampling pace of this benchmark, not synchronisation
        now = time.monotonic()
        if now >= next_rss:
            recording.rss_samples.append((round(now - t0, 1), round(_rss_mb(proc), 1)))
            # the next one RSS_EVERY_S after this one: a step the machine held up (a segment's
            # roll on a busy disk) delays the curve, it does not add samples of one moment
            next_rss = now + RSS_EVERY_S
        if now >= next_segment and deadline - now > SEGMENT_S / 10:
            recording.rolls_s.append(round(now - t0, 2))
            rig.session.stop_recording()
            path.unlink()
            rig.session.start_recording(path)
            recording.segments += 1
            next_segment += SEGMENT_S
    recording.elapsed_s = time.monotonic() - t0
    return recording


def _camera_figures(status: dict, drops: dict, recording: _Recording) -> dict:
    """Per camera: frames per second over the run, frames dropped before the measurement and
    by the recorder, and the latency from receipt to SNR."""
    from snrmon.acquisition.runtime.camera_pipeline import CAMERA_GAP, WRONG_SHAPE
    from snrmon.acquisition.streams.ring import RING_OVERRUN

    figures: dict = {}
    for name, st in status.items():
        d = drops[name]
        before_measurement = d[CAMERA_GAP] + d[RING_OVERRUN] + d[WRONG_SHAPE]
        figures[name] = {
            "fps": (st.frames.received - recording.received0[name]) / recording.elapsed_s,
            "dropped": before_measurement,
            "dropped_by_recorder": sum(d.values()) - before_measurement,
            "latency_ms_p50": st.latency.p50_ms,
            "latency_ms_p99": st.latency.p99_ms,
        }
    return figures


def _replay_figures(path: Path) -> dict:
    """The recording at ``path`` replayed: full frames once, then ``--fast`` ``REPEATS`` times
    with both cameras and with MWIR alone (medians and runs), and ``Session.stops()``'s time."""
    from snrmon.acquisition.replay.batch import replay_session

    full = replay_session(path)
    # From the page cache (the file was just written and read): the target is >= 100x
    # real time, both cameras. A shared machine's speed swings by up to 2x within seconds
    # (the same replay's CPU time with it), so one replay is not a measurement: the median
    # of REPEATS, with the runs; both cameras, then MWIR alone. Each run says what it read
    # from the disk: a file the page cache dropped meanwhile is read whole again (the
    # kernel reads ahead 8 MB around each page the memory map touches) and the run is slow
    # for that reason, not the replay's.
    both_runs = [_fast_replay(path) for _ in range(REPEATS)]
    both = [r for r, _ in both_runs]
    fast = both[0]
    fast_factors = sorted(r.realtime_factor for r in both)
    mwir_runs = [_fast_replay(path, cameras=["mwir"]) for _ in range(REPEATS)]
    mwir = [r for r, _ in mwir_runs]
    mwir_factors = sorted(r.realtime_factor for r in mwir)
    stops_s = _api_stops_seconds(path)
    return {
        "fps": _replay_fps(full),
        "realtime_factor": full.realtime_factor,
        "fast_fps": statistics.median(_replay_fps(r) for r in both),
        "fast_realtime_factor": statistics.median(fast_factors),
        "fast_realtime_factor_runs": fast_factors,
        "fast_realtime_factor_mwir": statistics.median(mwir_factors),
        "fast_realtime_factor_mwir_runs": mwir_factors,
        "identical": sum(c.identical for c in fast.cameras.values()),
        "compared": sum(c.compared for c in fast.cameras.values()),
        "identical_every_run": all(
            c.identical == c.compared for r in both + mwir for c in r.cameras.values()
        ),
        # in the order run: the factor, the processes the cameras were played in, and the
        # MB read from the disk (not the page cache) and major page faults of the replay
        "fast_runs_in_order": [_run_figures(r, io) for r, io in both_runs],
        "fast_runs_in_order_mwir": [_run_figures(r, io) for r, io in mwir_runs],
        "api_stops_s": stops_s,
    }


def _replay_fps(result) -> float:
    """Frames replayed per second, both cameras together."""
    if not result.seconds:
        return 0.0
    return sum(c.n_frames for c in result.cameras.values()) / result.seconds


def _api_stops_seconds(path: Path) -> float:
    """Seconds of ``snrmon.open_session(path).stops()`` in a fresh Session, the model's columns
    included (what a notebook waits for; the slowest of two runs)."""
    from snrmon.api import open_session

    times = []
    for _ in range(2):
        t0 = time.perf_counter()
        with open_session(path) as s:
            s.stops()
        times.append(time.perf_counter() - t0)
    return max(times)


def _fast_replay(path: Path, **kwargs):
    """``replay_session(path, fast=True)`` and what it read from the disk: (MB, major page
    faults) of this process and the children it forked."""
    import resource

    from snrmon.acquisition.replay.batch import replay_session

    who = (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)
    before = [resource.getrusage(w) for w in who]
    result = replay_session(path, fast=True, **kwargs)
    after = [resource.getrusage(w) for w in who]
    blocks = sum(a.ru_inblock - b.ru_inblock for a, b in zip(after, before, strict=True))
    faults = sum(a.ru_majflt - b.ru_majflt for a, b in zip(after, before, strict=True))
    return result, (blocks * 512 / 2**20, faults)


def _run_figures(result, io: tuple[float, int]) -> dict:
    return {
        "realtime_factor": result.realtime_factor,
        "processes": result.processes,
        "read_mb": round(io[0], 1),
        "major_faults": io[1],
    }


def format_text(figures: dict) -> str:
    """The acquisition section as text: per camera its rate and drops, then the table of where
    a frame's time goes (p50, p99 and the mean over the slowest 1 % of frames, per stage)."""
    from snrmon.acquisition.stage_clock import COLUMNS

    acq = figures["acquisition"]
    cams = list(acq["stages"])
    lines = []
    for name, value in acq.items():
        if name in cams or name in ("stages", "rss_mb_samples"):
            continue
        lines.append(
            f"  {name:32s} {value:.4g}" if isinstance(value, float) else f"  {name:32s} {value}"
        )
    for cam in cams:
        a = acq[cam]
        lines.append(
            f"  {cam}: {a['fps']:.2f} fps, {a['dropped']} dropped "
            f"({a['dropped_by_recorder']} by the recorder), latency p50 "
            f"{a['latency_ms_p50']:.2f} ms, p99 {a['latency_ms_p99']:.2f} ms"
        )
    header = f"  {'stage (ms)':12s}" + "".join(
        f"{c + ' p50':>11s}{c + ' p99':>11s}{c + ' slow':>11s}" for c in cams
    )
    lines += ["", header]

    def cell(v) -> str:
        return f"{v:11.3f}" if v is not None else f"{'-':>11s}"

    for col in COLUMNS:
        row = f"  {col:12s}"
        for cam in cams:
            st = acq["stages"][cam].get(col, {})
            row += cell(st.get("p50_ms")) + cell(st.get("p99_ms")) + cell(st.get("slowest_ms"))
        lines.append(row)
    lines.append(
        "  (slow: the mean over the slowest 1 % of frames by latency; backlog, cpu, runq and "
        "blocked split the measurement thread's wait: docs/engine.md)"
    )
    return "\n".join(lines)
