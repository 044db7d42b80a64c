"""What a recording is doing and what it kept: the recorder's live status, its final summary (per
camera: frames received, written, dropped and why) and the one message a write failure becomes."""

from __future__ import annotations

import errno
import math
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path


@dataclass(frozen=True, slots=True)
class RecorderStatus:
    """Live state: ``state`` is recording | stopping | stopped | failed."""

    state: str
    path: str
    frames_written: dict[str, int]
    frames_flushed: dict[str, int]
    bytes_written: int
    backlog_frames: int
    backlog_bytes: int
    dropped: dict[str, dict[str, int]]
    free_bytes: int | None
    error: str | None
    compression_ratio: float | None = None
    """The frames' raw bytes over what the filter stored, of the frames flushed so far (1 with
    ``none``; None before the first frame is flushed): the measured ratio, not a guess."""


@dataclass(frozen=True, slots=True)
class RecorderSummary:
    """What a finished recording holds and what it lost, per camera and reason."""

    path: str
    state: str
    frames_received: dict[str, int]
    frames_written: dict[str, int]
    dropped: dict[str, dict[str, int]]
    measurements_written: dict[str, int]
    ranges_written: int
    gps_written: int
    events_written: int
    bytes_written: int
    duration_s: float
    error: str | None = None
    extra: dict = field(default_factory=dict)

    def frames_report(self) -> dict:
        """What the recording holds and lost, for a JSON report: frames received, written and
        dropped (with reasons) per camera, and each camera's accounting (received = written +
        sum(dropped) + before_recording, + after_recording and queued)."""
        return {
            "path": self.path,
            "state": self.state,
            "frames_received": dict(self.frames_received),
            "frames_written": dict(self.frames_written),
            "dropped": {cam: dict(reasons) for cam, reasons in self.dropped.items()},
            "error": self.error,
            "accounting": self.extra.get("accounting"),
            "devices_lost": self.extra.get("devices_lost"),  # null: not watched
        }


def describe_failure(exc: BaseException, path: Path, frames: int) -> str:
    """One line for the operator: disk full, or the first line of the write error."""
    text = str(exc)
    if getattr(exc, "errno", None) == errno.ENOSPC or "No space left" in text:
        return f"recording stopped: disk full writing {path} after {frames} frames"
    first = text.splitlines()[0] if text else type(exc).__name__
    return f"recording stopped: write error on {path} after {frames} frames: {first}"


RATE_WINDOW_S = 5.0  # the write rate is the bytes written over the last few seconds
RATE_WARM_UP_S = 2.0  # the file's creation and first chunks: not the recording's rate


class WriteRate:
    """A recording's elapsed time and write rate from its growing byte count (sampled at the
    status refresh): the rate over the last :data:`RATE_WINDOW_S` seconds, so a change of what
    is recorded shows within seconds; and the disk's time left at that rate."""

    def __init__(self, t0_s: float) -> None:
        self.t0_s = t0_s
        self._points: deque[tuple[float, int]] = deque()

    def add(self, t_s: float, bytes_written: int) -> float:
        """Take a sample; returns the rate in bytes per second (NaN until two samples half a
        second apart). Samples of the first :data:`RATE_WARM_UP_S` are left out: the file's
        layout and first chunks, written at once, read 4x the steady rate of a slow recording
        (and its time left amber) for its first seconds."""
        if t_s - self.t0_s < RATE_WARM_UP_S:
            return math.nan
        self._points.append((t_s, bytes_written))
        while len(self._points) > 2 and t_s - self._points[1][0] >= RATE_WINDOW_S:
            self._points.popleft()
        (t_a, b_a), (t_b, b_b) = self._points[0], self._points[-1]
        return (b_b - b_a) / (t_b - t_a) if t_b - t_a >= 0.5 else math.nan


def disk_time_left_s(free_bytes: int | None, rate_bytes_s: float) -> float | None:
    """Seconds until ``free_bytes`` fill at ``rate_bytes_s``; None when either is unknown,
    infinity while nothing is being written."""
    if free_bytes is None or not math.isfinite(rate_bytes_s):
        return None
    return math.inf if rate_bytes_s <= 0 else free_bytes / rate_bytes_s
