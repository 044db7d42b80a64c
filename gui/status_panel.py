"""The always-visible status: rangefinder, GPS, each camera, recording (from one snapshot).

Every value is a field of :class:`snrmon.acquisition.runtime.session.SessionStatus`; the panel only
formats it,
with units in the text and in each row's tooltip.
"""

from __future__ import annotations

import math

from PySide6.QtWidgets import QFormLayout, QGroupBox, QLabel, QVBoxLayout, QWidget

from snrmon.acquisition.engine.status import SessionStatus
from snrmon.acquisition.streams.ring import RING_OVERRUN


def _fmt(value: float | None, fmt: str, unit: str) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "--"
    return f"{value:{fmt}} {unit}".rstrip()


def _bytes(n: int | None) -> str:
    if n is None:
        return "--"
    for unit, size in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.1f} {unit}"
    return f"{n} B"


class StatusPanel(QWidget):
    """Labels for every device; :meth:`show_status` refreshes them from one snapshot."""

    def __init__(self, cameras: list[str], parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.labels: dict[str, QLabel] = {}
        lay = QVBoxLayout(self)
        lay.setContentsMargins(4, 4, 4, 4)
        lay.addWidget(
            self._group(
                "Rangefinder",
                [
                    ("lrf_state", "state", "Rangefinder link state"),
                    ("lrf_range", "range", "Last rangefinder range (m) and its age (s)"),
                ],
            )
        )
        lay.addWidget(
            self._group(
                "GPS",
                [
                    ("gps_state", "state", "GPS link state"),
                    ("gps_fix", "fix", "Fix quality and satellites used"),
                    ("gps_range", "slant range", "Slant range from the camera site (m)"),
                ],
            )
        )
        for cam in cameras:
            lay.addWidget(
                self._group(
                    cam.upper(),
                    [
                        (f"{cam}_state", "state", f"{cam} link state"),
                        (f"{cam}_fps", "rate", f"{cam} measured frame rate (frames/s)"),
                        (
                            f"{cam}_frames",
                            "frames",
                            f"{cam} frames received: in the recording, received while not "
                            "recording, waiting for the measurement or the disk",
                        ),
                        (
                            f"{cam}_dropped",
                            "dropped",
                            f"{cam} frames dropped: by the camera (counter gaps), by the console "
                            "(ring overrun, wrong frame size), by the recorder (backlog)",
                        ),
                        (f"{cam}_track", "track", f"{cam} track state and ROI (column, row)"),
                        (f"{cam}_snr", "SNR", f"{cam} 100-frame mean +/- std (n frames)"),
                        (f"{cam}_range", "range", f"{cam} range of the last frame (m) and source"),
                    ],
                )
            )
        lay.addWidget(
            self._group(
                "Recording",
                [
                    ("rec_state", "state", "Recording state"),
                    ("rec_path", "file", "Session file being written"),
                    ("rec_size", "size", "Bytes written to the session file"),
                    (
                        "rec_backlog",
                        "backlog",
                        "Frames queued for the disk (grows when the disk "
                        "cannot keep up), and frames the recording dropped",
                    ),
                    ("rec_free", "free disk", "Free space on the recording disk"),
                ],
            )
        )
        lay.addStretch(1)

    def _group(self, title: str, rows: list[tuple[str, str, str]]) -> QGroupBox:
        box = QGroupBox(title)
        form = QFormLayout(box)
        form.setContentsMargins(6, 2, 6, 2)
        for key, label, tip in rows:
            value = QLabel("--")
            value.setToolTip(tip)
            name = QLabel(label)
            name.setToolTip(tip)
            form.addRow(name, value)
            self.labels[key] = value
        return box

    def _set(self, key: str, text: str) -> None:
        label = self.labels.get(key)
        if label is not None and label.text() != text:
            label.setText(text)

    def show_status(self, st: SessionStatus) -> None:
        self._set("lrf_state", st.lrf.state.value if st.lrf else "not configured")
        rng = _fmt(st.lrf_range_m, ".1f", "m")
        age = _fmt(st.lrf_age_s, ".1f", "s ago")
        self._set("lrf_range", f"{rng}  ({age})")
        self._set("gps_state", st.gps.state.value if st.gps else "not configured")
        fix = st.gps_fix
        if fix is None:
            self._set("gps_fix", "--")
        else:
            sats = "--" if fix.sats is None else str(fix.sats)
            self._set(
                "gps_fix",
                f"{'fix' if fix.has_fix else 'no fix'} (q {fix.fix_quality}), {sats} sats",
            )
        self._set("gps_range", _fmt(st.gps_range_m, ".1f", "m"))
        for cam, cs in st.cameras.items():
            f = cs.frames
            self._set(f"{cam}_state", cs.device.state.value)
            self._set(f"{cam}_fps", _fmt(cs.fps, ".1f", "fps"))
            self._set(
                f"{cam}_frames",
                f"{f.received} ({f.written} recorded, "
                f"{f.before_recording + f.after_recording} while not recording, "
                f"{f.queued} queued)",
            )
            ring = f.dropped.get(RING_OVERRUN, 0)
            by_recorder = sum(f.dropped.values()) - ring
            self._set(
                f"{cam}_dropped",
                ("DROPPED " if f.lost else "")
                + f"cam {f.camera_gap}, ring {ring}, shape {f.wrong_shape}, rec {by_recorder}",
            )
            roi = "--" if cs.roi_xy is None else f"({cs.roi_xy[0]}, {cs.roi_xy[1]})"
            why = f" ({cs.track_reason})" if cs.track_reason else ""
            self._set(f"{cam}_track", f"{cs.track_state.value}{why}  ROI {roi}")
            m = cs.last
            if m is not None and m.snr_n:
                self._set(f"{cam}_snr", f"{m.snr_mean:.2f} +/- {m.snr_std:.2f} (n {m.snr_n})")
            else:
                self._set(f"{cam}_snr", "--")
            src = f" ({m.range_source})" if m is not None and m.range_source else ""
            self._set(f"{cam}_range", _fmt(m.range_m if m else None, ".1f", "m") + src)
        rec = st.recording
        self._set("rec_state", rec.state + (f": {rec.message}" if rec.message else ""))
        self._set("rec_path", rec.path or "--")
        self._set("rec_size", _bytes(rec.bytes_written) if rec.state != "off" else "--")
        if rec.state in ("recording", "stopped", "failed"):
            self._set("rec_backlog", f"{_bytes(rec.backlog_bytes)}, {rec.dropped_frames} dropped")
        else:
            self._set("rec_backlog", "--")
        self._set("rec_free", _bytes(rec.free_bytes))
