"""One recorded camera inside the console's replay: the pipeline surface the window reads, and
the worker's analysis state.

:class:`ReplayCamera` offers what a live :class:`acquisition.runtime.camera_pipeline.CameraPipeline`
offers a display (``shape``, ``latest_frame()``, ``series()``, ``status()``);
:class:`ReplayCameraState` runs the live per-frame analysis
(:class:`acquisition.engine.camera_analysis.CameraAnalysis`: Eq. 4 with the track, the raw-frame
track,
the section 6 noise, the sky temperature) on the recorded frames with the recorded clicks,
references and calibration, and publishes each frame's status to the :class:`ReplayCamera`.
"""

from __future__ import annotations

import threading
from collections import deque

import numpy as np

from acquisition.config import SessionConfig
from acquisition.engine.camera_analysis import CameraAnalysis
from acquisition.engine.status import CameraStatus, FrameAccounting
from acquisition.record.reader import CameraRecord, SessionFile
from acquisition.replay.batch import RecordedEvents, frames_between, recorded_calibration
from acquisition.runtime.ring import RingFrame
from drivers.device import DeviceState, DeviceStatus

NAN = float("nan")


class ReplayCamera:
    """One recorded camera as the console sees a live pipeline (state set by the worker)."""

    def __init__(self, name: str, record: CameraRecord, fps: float, series_length: int) -> None:
        self.name = name
        self.record = record
        self.shape = tuple(int(v) for v in record.frames.shape[1:])
        self.fps = fps
        self._lock = threading.Lock()
        self._latest: RingFrame | None = None
        self._series: deque[tuple[int, float, float, float, float]] = deque(maxlen=series_length)
        self._status = CameraStatus(
            name, DeviceStatus(name, DeviceState.STREAMING), FrameAccounting()
        )

    def latest_frame(self) -> RingFrame | None:
        with self._lock:
            return self._latest

    def series(self) -> np.ndarray:
        """Rows of (t_host_ns, snr, running mean, running std, range_m or NaN), as live."""
        with self._lock:
            rows = list(self._series)
        return np.array(rows, dtype=float) if rows else np.empty((0, 5))

    def status(self) -> CameraStatus:
        with self._lock:
            return self._status

    def show(self, frame: RingFrame) -> None:
        with self._lock:
            self._latest = frame

    def publish(self, status: CameraStatus, row: tuple | None) -> None:
        with self._lock:
            self._status = status
            if row is not None:
                self._series.append(row)

    def clear(self) -> None:
        with self._lock:
            self._series.clear()
            self._latest = None


class ReplayCameraState:
    """The worker's analysis of one recorded camera (rebuilt on a seek)."""

    def __init__(
        self, f: SessionFile, name: str, config: SessionConfig, track: bool, events: RecordedEvents
    ) -> None:
        self.name = name
        self.record = f.cameras[name]
        self.analysis = CameraAnalysis(
            name, self.record.frames.shape[1:], config.measurement, window=config.window,
            track=track,
        )  # fmt: skip
        calibration = recorded_calibration(f, name, events)
        if calibration is not None:
            self.analysis.set_calibration(calibration)
        self.rois = list(events.rois.get(name, []))
        self.refs = list(events.references.get(name, []))
        self.read = 0
        self.measured = 0
        self.gps_xy: tuple[float, float] | None = None

    def apply_events(self, t_ns: int, *, before: bool = False) -> tuple[int, int, int] | None:
        """Apply the recorded references up to ``t_ns`` (a reference at ``t_ns`` too, unless
        ``before``); return the last recorded click up to then, (t_ns, x, y), or None."""
        click = None
        while self.refs and (self.refs[0][0] < t_ns or (not before and self.refs[0][0] == t_ns)):
            _, first, last = self.refs.pop(0)
            self.analysis.set_reference(*frames_between(self.record, first, last))
        while self.rois and (self.rois[0][0] < t_ns or (not before and self.rois[0][0] == t_ns)):
            click = self.rois.pop(0)
        return click

    def cue(self, xy: tuple[float, float] | None) -> None:
        """The drone's GPS position in this camera (None: not in view): cues the tracker."""
        self.gps_xy = xy
        if xy is not None:
            self.analysis.cue(*xy)

    def measure(
        self, frame: RingFrame, range_m: float | None, source: str, fps: float
    ) -> tuple[CameraStatus, tuple | None, object]:
        """Analyse one shown frame; returns its status, its chart row (None without an ROI)
        and the Eq. (4) result (None without an ROI)."""
        out = self.analysis.analyze(frame.pixels, frame.counter, frame.t_host_ns)
        fr = out.result
        self.measured += 1
        fig = self.analysis.figures()
        name = self.name
        status = CameraStatus(
            name=name,
            device=DeviceStatus(name, DeviceState.STREAMING, readings=self.read),
            frames=FrameAccounting(received=self.read, measured=self.measured),
            fps=fps,
            roi_xy=fr.window_xy if fr else None,
            gps_xy=self.gps_xy,
            track_state=fr.state if fr else "idle",
            track_reason=fr.reason if fr else "",
            last=fr.result if fr else None,
            snr_mean=fr.snr_mean if fr else NAN,
            snr_std=fr.snr_std if fr else NAN,
            snr_n=fr.snr_n if fr else 0,
            snr_mean_raw=out.snr_mean_raw,
            snr_std_raw=out.snr_std_raw,
            reference_frames=fig.reference_frames,
            sky_temp_k=fig.sky_temp_k,
            fixed_pattern_dn=fig.fixed_pattern_dn,
            range_m=range_m,
            range_source=source,
            noise_total_dn=fig.noise_total_dn,
            noise_temporal_dn=fig.noise_temporal_dn,
            noise_spatial_dn=fig.noise_spatial_dn,
        )
        row = None
        if fr is not None:
            rng = NAN if range_m is None else range_m
            row = (frame.t_host_ns, fr.result.snr, fr.snr_mean, fr.snr_std, rng)
        return status, row, (fr.result if fr else None)
