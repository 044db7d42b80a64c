"""What a recording is doing and what it kept: the recorder's live status, its final summary (per
camera: frames received, written, dropped and why) and the one message a write failure becomes."""

from __future__ import annotations

import errno
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
    bytes_per_s: float | None = None
    """The file's growth since the recording began (None in its first second)."""

    @property
    def seconds_left(self) -> float | None:
        """Recording time the free space holds at the measured rate (None: not known yet)."""
        return seconds_left(self.free_bytes, self.bytes_per_s)


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


def seconds_left(free_bytes: int | None, bytes_per_s: float | None) -> float | None:
    """Seconds of recording ``free_bytes`` hold at ``bytes_per_s`` (None: either unknown)."""
    if free_bytes is None or not bytes_per_s:
        return None
    return free_bytes / bytes_per_s


def describe_failure(exc: BaseException, path: Path, frames: int) -> str:
    """One line for the operator: disk full, or the first line of the write error."""
    text = str(exc)
    if getattr(exc, "errno", None) == errno.ENOSPC or "No space left" in text:
        return f"recording stopped: disk full writing {path} after {frames} frames"
    first = text.splitlines()[0] if text else type(exc).__name__
    return f"recording stopped: write error on {path} after {frames} frames: {first}"
