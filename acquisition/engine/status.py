"""Snapshots of a running session that any thread (the GUI's timer, the CLI) may read.

They are plain frozen dataclasses, built by the processing threads and handed out whole, so a
viewer never computes a statistic itself (the lesson of PyMoDAQ #79) and never holds a lock.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from snrmon.acquisition.engine.inputs import Measurement
from snrmon.acquisition.measure.model_agreement import ModelAgreement
from snrmon.acquisition.measure.track_noise import RegionNoise3d
from snrmon.acquisition.stops.table import StopProgress
from snrmon.acquisition.track.config import TrackState
from snrmon.drivers.device import LOST_STATES, DeviceStatus
from snrmon.drivers.gps.fix import GpsFix


@dataclass(frozen=True, slots=True)
class FrameAccounting:
    """What became of every frame one camera delivered, for one recording: the one set of names
    the console's status, the recording's ``summary_json`` and a replay's report use.

    ``received``: frames the camera delivered to the console (of any shape). Each of them is in
    exactly one of: ``written`` (in the file), ``dropped`` (lost while recording, by reason:
    ``ring_overrun``, the measurement fell a whole ring behind; ``recorder_backlog`` and
    ``recording_stopped``, the recorder's), ``before_recording`` (received and done with
    before the recording began: measured, or lost to the ring), ``after_recording`` (measured
    after it ended, a session that went on), ``queued`` (still waiting for the measurement) or
    ``wrong_shape`` (not of the camera's frame size: never measured nor recorded)::

        received = written + sum(dropped) + before_recording + after_recording + queued
                   + wrong_shape

    With no recording, every frame measured is ``before_recording`` and ``dropped`` holds the
    ring's overruns. ``camera_gap``: frames the camera never delivered (gaps in its own frame
    counter), so not received and outside the identity. ``wrong_shape`` is None in the
    accounting of a file recorded before such frames were counted (they were not received then
    either).
    """

    received: int = 0
    written: int = 0
    dropped: Mapping[str, int] = field(default_factory=dict)
    before_recording: int = 0
    after_recording: int = 0
    queued: int = 0
    wrong_shape: int | None = 0
    camera_gap: int = 0

    @property
    def unaccounted(self) -> int:
        """Frames received that the identity does not place (0 when it holds)."""
        placed = self.written + sum(self.dropped.values()) + self.before_recording
        others = self.after_recording + self.queued + (self.wrong_shape or 0)
        return self.received - placed - others

    @property
    def lost(self) -> int:
        """Frames lost, whatever the reason: dropped, of the wrong shape, or never delivered."""
        return sum(self.dropped.values()) + (self.wrong_shape or 0) + self.camera_gap

    def as_record(self) -> dict[str, Any]:
        """As the recording's ``summary_json`` keeps it and every JSON shows it (JSON-able;
        the keys are :data:`ACCOUNTING_FIELDS`)."""
        record = dataclasses.asdict(self)
        record["dropped"] = dict(self.dropped)
        return record

    @staticmethod
    def not_kept(written: int, dropped: Mapping[str, int]) -> dict[str, Any]:
        """The record of a file written before the accounting was kept: its frames and the
        recorder's drops; every count nobody kept null."""
        return {**dict.fromkeys(ACCOUNTING_FIELDS), "written": written, "dropped": dict(dropped)}

    @classmethod
    def from_record(cls, record: Mapping[str, Any]) -> FrameAccounting:
        """From :meth:`as_record` (a file written before ``wrong_shape`` was kept: None)."""
        wrong = record.get("wrong_shape")
        return cls(
            received=int(record["received"]),
            written=int(record["written"]),
            dropped={str(k): int(v) for k, v in dict(record.get("dropped") or {}).items()},
            before_recording=int(record.get("before_recording", 0)),
            after_recording=int(record.get("after_recording", 0)),
            queued=int(record.get("queued", 0)),
            wrong_shape=None if wrong is None else int(wrong),
            camera_gap=int(record.get("camera_gap", 0)),
        )


ACCOUNTING_FIELDS = tuple(f.name for f in dataclasses.fields(FrameAccounting))
"""The frame accounting's names, in every JSON that holds one (live, in the file, in replay)."""


@dataclass(frozen=True, slots=True)
class AnalysisFigures:
    """A camera's slowly changing figures (units in the names): the background reference, the
    apparent sky temperature (with a calibration, the mean over the last 100 frames) and the
    section 6 noise of the background around the track
    (:mod:`snrmon.acquisition.measure.track_noise`: temporal = std(frame - previous) / sqrt(2),
    spatial = sqrt(total^2 - temporal^2)). NaN: not measured (yet)."""

    reference_frames: int = 0  # frames in the background reference (0: none)
    fixed_pattern_dn: float = math.nan  # spatial std of the reference
    sky_temp_k: float = math.nan
    noise_total_dn: float = math.nan
    noise_temporal_dn: float = math.nan
    noise_spatial_dn: float = math.nan
    # 3D noise (D'Agostino and Webb, bias-corrected) of the background clear of the track over
    # the last complete block of 100 frames, and its region (acquisition.measure.track_noise);
    # None until a block is complete.
    noise_3d: RegionNoise3d | None = None


@dataclass(frozen=True, slots=True)
class LostDevice:
    """A device one camera's numbers depend on (the camera itself, or a range source: the
    rangefinder, the GPS) that has stopped delivering: ``kind`` ("camera", "LRF", "GPS"),
    the device's ``name`` and ``state``, and ``for_s``: seconds since its last reading (None:
    it never gave one)."""

    kind: str
    name: str
    state: str
    for_s: float | None
    error: str = ""

    def words(self) -> str:
        """``"LRF disconnected 15 s"``: what is lost and for how long."""
        age = "" if self.for_s is None else f" {self.for_s:.0f} s"
        return f"{self.kind} {self.state}{age}"


def lost_device(kind: str, status: DeviceStatus | None) -> LostDevice | None:
    """``status`` as a loss, or None while the device delivers (or was never configured): a
    device is lost when its watchdog calls it stale, when it is disconnected or failed, or when
    it is connecting again after it had given readings (unplugged: the driver reconnects). A
    hand-held rangefinder that is simply not fired stays streaming (it has no watchdog)."""
    if status is None:
        return None
    state = str(status.state)
    if state in LOST_STATES or (state == "connecting" and status.readings > 0):
        return LostDevice(kind, status.name, state, status.last_reading_age_s, status.last_error)
    return None


@dataclass(frozen=True, slots=True)
class Latency:
    """The receipt-to-SNR latency of the recent frames (ms): its median and 99th percentile
    (:meth:`snrmon.acquisition.stage_clock.StageClock.latency_ms`); NaN: none measured yet."""

    p50_ms: float = math.nan
    p99_ms: float = math.nan


@dataclass(frozen=True, slots=True)
class ModelAtRange:
    """The model at the last measured frame's range, as the console shows it beside the
    measurement (empty without a model or a range)."""

    # :class:`snrmon.acquisition.prediction.Predictor`'s values: the four curves, the expected
    # Eq. (4) readings
    curves: Mapping[str, float] = field(default_factory=dict)
    # Which PSF the corrected curves and expected readings were computed with, in words (the
    # predictor's ``curves_psf_source``: "preset: PVF 0.082 (sensor mwir)", "fitted: sigma
    # 0.57 px from this flight's stops"); None without a model.
    psf_source: str | None = None
    # The frame's running mean against the expected Eq. (4) reading (the rule the predictor
    # names, its band, the ratio and the verdict); None without a measurement or a model.
    agreement: ModelAgreement | None = None


@dataclass(frozen=True, slots=True)
class RunningStatistics:
    """The parts of a camera's status that are statistics over many frames: the error of the
    running mean, the slowly changing figures, the latest stop's progress and the frames'
    latency. Taken on the thread that measures the frames (a live camera's measurement thread,
    :data:`snrmon.acquisition.runtime.measurement_thread.STATISTICS_EVERY_S` apart and when
    its frames pause), so a console asking for a status five times a second computes none of
    them on its own thread."""

    snr_sem: float
    figures: AnalysisFigures
    stop: StopProgress | None
    latency: Latency = field(default_factory=Latency)


@dataclass(frozen=True, slots=True)
class CameraStatus:
    """One camera's live state: device health, frame accounting, the track and its last
    measured frame (the engine's own :class:`Measurement`, not a copy of its numbers), the
    model's prediction at that frame's range, and the slowly changing figures."""

    name: str
    device: DeviceStatus
    frames: FrameAccounting
    # frames the camera delivered per second, as they were processed (the last 2 s:
    # :mod:`snrmon.acquisition.streams.delivered_rate`), not the rate it was asked for
    fps: float = 0.0
    roi_xy: tuple[int, int] | None = None
    gps_xy: tuple[float, float] | None = None  # the drone's GPS position projected (px)
    track_state: TrackState = TrackState.IDLE
    last: Measurement | None = None
    # The model at ``last.range_m``, and ``last``'s running mean against it.
    model: ModelAtRange = field(default_factory=ModelAtRange)
    figures: AnalysisFigures = field(default_factory=AnalysisFigures)
    latency: Latency = field(default_factory=Latency)
    # The error of the mean of ``last``'s running window (its frames' autocorrelation counted,
    # :func:`snrmon.acquisition.stops.detector.mean_error`); NaN when not known.
    snr_sem: float = math.nan
    # The latest stop's progress for this camera (n of 100 frames); None before the first stop.
    stop: StopProgress | None = None
    # The devices this camera's numbers depend on that are lost now (itself, the LRF, the
    # GPS): the header says which and for how long, and shows none of their values as live.
    lost: tuple[LostDevice, ...] = ()

    def with_frames(
        self, device: DeviceStatus, frames: FrameAccounting, fps: float
    ) -> CameraStatus:
        """This status with what the frames' mover knows and the engine does not: the
        device's health, the frame accounting and the frame rate (fps)."""
        return dataclasses.replace(self, device=device, frames=frames, fps=float(fps))

    def lost_kind(self, kind: str) -> LostDevice | None:
        """The loss of ``kind`` ("camera", "LRF", "GPS") now, or None."""
        return next((d for d in self.lost if d.kind == kind), None)

    @property
    def agreement(self) -> ModelAgreement | None:
        """``last``'s running mean against the model's expected Eq. (4) reading at its range."""
        return self.model.agreement

    @property
    def track_reason(self) -> str:
        """Why the track missed its last frame (docs/tracking.md); "" when it did not."""
        if self.last is None or self.track_state is TrackState.IDLE:
            return ""
        return self.last.track_reason


@dataclass(frozen=True, slots=True)
class RecordingStatus:
    """The recording as the operator sees it: a disk that cannot keep up shows as a growing
    backlog and then as dropped frames, never silently."""

    state: str = "off"  # off | recording | stopped | failed | replay
    path: str = ""
    bytes_written: int = 0
    free_bytes: int | None = None
    message: str = ""
    backlog_bytes: int = 0  # frames queued for the disk
    dropped_frames: int = 0  # frames the recording lost (all cameras, all reasons)
    compression_ratio: float | None = None  # frames' raw / stored bytes so far (RecorderStatus)
    elapsed_s: float | None = None  # since the recording began
    rate_bytes_s: float = math.nan  # written over the last seconds
    time_left_s: float | None = None  # until the disk is full at that rate (inf: not writing)


@dataclass(frozen=True)
class SessionStatus:
    """Everything the console shows, as one snapshot."""

    cameras: dict[str, CameraStatus]
    lrf: DeviceStatus | None
    lrf_range_m: float | None
    lrf_age_s: float | None
    gps: DeviceStatus | None
    gps_fix: GpsFix | None
    gps_range_m: float | None
    recording: RecordingStatus
    alarms: tuple[str, ...] = ()
    extra: dict[str, Any] = field(default_factory=dict)
