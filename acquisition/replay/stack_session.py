"""Another tool's recording (a FLIR ``.seq``, a ``.ptw``, a TIFF stack, ...) written as a snrmon
session, so that the console replays it as it replays its own: one camera, every frame at its
own time, the file's camera and calibration constants in the session's config.

The frames' times are the file's own where it stores them (a FLIR sequence's per-frame times,
on their UTC); a file without times is paced at the frame rate it states, else at the sensor
model's. The session holds no rangefinder, GPS or measurement rows: the console measures the
frames as it plays them, from the operator's click.
"""

from __future__ import annotations

from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from snrmon.acquisition.record.recorder import SessionRecorder
from snrmon.acquisition.replay.stack_io import StackFile, read_stack
from snrmon.acquisition.streams.timebase import ClockMap
from snrmon.drivers.camera.frame import Frame
from snrmon.model.presets import load_sensor

FRAME_WAIT_S = 60.0  # the writer's backlog is waited for, never dropped: a file has no hurry


def frame_times_ns(stack: StackFile, fps: float) -> tuple[np.ndarray, datetime | None]:
    """Each frame's time from the first (ns) and the first frame's UTC (None where the file
    stores none): the file's own times where every frame has one and they increase, else the
    frames at ``fps``."""
    n = stack.frames.shape[0]
    utc = stack.utc
    if utc is not None and len(utc) == n and not np.isnat(utc).any():
        ns = utc.astype("datetime64[ns]").astype(np.int64)
        if n == 1 or (np.diff(ns) > 0).all():
            first = datetime.fromtimestamp(int(ns[0]) // 1_000_000_000, UTC)
            first = first.replace(microsecond=(int(ns[0]) % 1_000_000_000) // 1000)
            return ns - ns[0], first
    return np.round(np.arange(n) * (1e9 / fps)).astype(np.int64), None


def _uint16(frames: np.ndarray, path: Path) -> Callable[[int], np.ndarray]:
    """Frame ``k`` as the 16-bit counts a session holds; a stack of other values is refused."""
    if frames.dtype == np.uint16:
        return lambda k: np.ascontiguousarray(frames[k])
    if frames.dtype.kind in "ui" and frames.dtype.itemsize <= 2:
        lo, hi = int(frames.min()), int(frames.max())
        if lo >= 0:
            return lambda k: np.ascontiguousarray(frames[k], dtype=np.uint16)
        raise ValueError(f"{path}: frames hold negative counts (down to {lo}; {hi} at most)")
    raise ValueError(
        f"{path}: frames of {frames.dtype} are not camera counts (a session holds 16-bit counts)"
    )


def session_from_stack(
    stack_path: str | Path, out: str | Path, *, sensor: str, camera: str, target: str = "uav1"
) -> Path:
    """Write the recording ``stack_path`` as the session file ``out`` (which must not exist):
    camera ``camera`` described by the sensor model ``sensor`` (a preset or a sensor TOML)."""
    path = Path(stack_path)
    stack = read_stack(path)
    model = load_sensor(sensor)
    fps = float(stack.attrs.get("frame_rate_hz") or model.fps)
    offsets_ns, first_utc = frame_times_ns(stack, fps)
    pixels = _uint16(stack.frames, path)
    clock = ClockMap(now_ns=lambda: 0)
    if first_utc is not None:
        clock.update_from_gps(0, first_utc)  # the file's own UTC at its first frame
    config = {  # as a live session records its config: the session's TOML under "session"
        "session": {
            "target": target,
            "cameras": {camera: {"source": "shm", "address": path.name[:64], "sensor": sensor}},
        },
        "track": True,
    }
    shape = stack.frames.shape[1:]
    recorder = SessionRecorder(
        out,
        config=config,
        cameras={camera: (int(shape[0]), int(shape[1]))},
        clock=clock,
        backlog_wait_s=FRAME_WAIT_S,
    )
    recorder.add_event(
        "stack_imported",
        payload={
            "file": path.name[:200],
            "frames": int(stack.frames.shape[0]),
            "times": "the file's" if first_utc is not None else f"{fps:g} fps",
            **{k: v for k, v in stack.attrs.items() if isinstance(v, str | int | float)},
        },
    )
    for k, t_ns in enumerate(offsets_ns):
        frame = Frame(pixels(k), camera, counter=k, t_host_ns=int(t_ns), t_device_ns=int(t_ns))
        if recorder.add_frame(camera, frame) is None:
            recorder.stop()
            raise OSError(f"{out}: the writer fell behind writing frame {k} of {path}")
    summary = recorder.stop()
    if summary.error is not None:
        raise OSError(f"{out}: {summary.error}")
    return Path(out)
