"""The recording indicator in the status bar, made not to be missed: a red mark and ``REC``,
the time since the recording began, the write rate (MB/s), the time left on the disk at that
rate, the size and the frames dropped. The time left turns the indicator amber under
:data:`AMBER_S` and red under :data:`RED_S`. Every number is the session's
(:class:`snrmon.acquisition.engine.status.RecordingStatus`: the rate over the last seconds and
the time left are computed there); this only words and colours them.
"""

from __future__ import annotations

import math
from pathlib import Path

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QLabel, QWidget

from snrmon.acquisition.engine.status import RecordingStatus
from snrmon.gui import theme as th

AMBER_S = 600.0  # under 10 minutes of disk left at the current rate
RED_S = 120.0  # under 2 minutes
MARK = "\u25cf"  # the red mark


def clock_text(seconds: float) -> str:
    """``1:02:03`` or ``2:03`` (elapsed time, to the second)."""
    s = int(seconds)
    h, m = divmod(s // 60, 60)
    return f"{h}:{m:02d}:{s % 60:02d}" if h else f"{m}:{s % 60:02d}"


def time_left_text(seconds: float | None) -> str:
    """The disk's time left in words: ``45 s``, ``7 min``, ``2 h 05 min``; ``--`` unknown."""
    if seconds is None:
        return "--"
    if math.isinf(seconds):
        return "no data written"
    if seconds < 60:
        return f"{seconds:.0f} s"
    minutes = int(seconds // 60)
    return f"{minutes} min" if minutes < 60 else f"{minutes // 60} h {minutes % 60:02d} min"


def recording_level(rec: RecordingStatus) -> str:
    """``"red"``, ``"amber"`` or ``""`` by the disk's time left while recording."""
    left = rec.time_left_s
    if rec.state != "recording" or left is None:
        return ""
    if left < RED_S:
        return "red"
    return "amber" if left < AMBER_S else ""


def recording_text(rec: RecordingStatus) -> str:
    """The indicator's words (the mark included while recording)."""
    if rec.state == "recording":
        rate = rec.rate_bytes_s
        parts = [
            f"{MARK} REC",
            clock_text(rec.elapsed_s or 0.0),
            f"{rate / 1e6:.1f} MB/s" if math.isfinite(rate) else "-- MB/s",
            f"disk {time_left_text(rec.time_left_s)} left",
            f"{rec.bytes_written / 1e6:.0f} MB",
            f"{rec.dropped_frames} frames dropped",
            Path(rec.path).name,
        ]
        return "  ".join(parts)
    if rec.state == "replay":
        return f"replay of {Path(rec.path).name}"
    return f"recording {rec.state}" + (f": {rec.message}" if rec.message else "")


class RecordingIndicator(QLabel):
    """The status bar's recording indicator (module docstring); ``level`` is its colour now."""

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__("not recording", parent)
        self.setTextFormat(Qt.TextFormat.PlainText)
        self.setToolTip(
            "The recording: elapsed time, write rate, the disk's time left at that rate (amber "
            "under 10 min, red under 2), size written, frames dropped"
        )
        self.level = ""
        self.recording = False
        self._restyle()

    def show_recording(self, rec: RecordingStatus) -> None:
        text = recording_text(rec)
        if text != self.text():
            self.setText(text)
        level, recording = recording_level(rec), rec.state == "recording"
        if (level, recording) != (self.level, self.recording):
            self.level, self.recording = level, recording
            self._restyle()

    def colours(self) -> tuple[str, str]:
        """(background, text) now: red on white under 2 min, amber under 10, else the red
        mark's colour on the panel while recording."""
        t = th.current()
        if self.level == "red":
            return th.ALARM, "#ffffff"
        if self.level == "amber":
            return t.verdicts["near"][0], "#000000"
        return ("", th.ALARM) if self.recording else ("", t.text)

    def _restyle(self) -> None:
        fill, ink = self.colours()
        bold = "font-weight: bold;" if self.recording else ""
        back = f"background: {fill};" if fill else ""
        self.setStyleSheet(f"QLabel {{ {back} color: {ink}; {bold} padding: 0px 6px; }}")
