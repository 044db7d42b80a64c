"""Snapshots of a running session that any thread (the GUI's timer, the CLI) may read.

They are plain frozen dataclasses, built by the processing threads and handed out whole, so a
viewer never computes a statistic itself (the lesson of PyMoDAQ #79) and never holds a lock.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from snrmon.acquisition.measure.peak_snr import PeakSnr
from snrmon.acquisition.measure.track_noise import RegionNoise3d
from snrmon.drivers.device import DeviceStatus
from snrmon.drivers.gps.fix import GpsFix


@dataclass(frozen=True, slots=True)
class FrameAccounting:
    """Every frame of one camera is received, measured and recorded, or dropped with a reason.

    ``dropped_by_camera``: gaps in the camera's own frame counter (camera or link lost them).
    ``dropped_by_ring``: the measurement thread fell a whole ring behind (console lost them).
    ``dropped_by_recorder``: the recorder's backlog overflowed while recording.
    """

    received: int = 0
    measured: int = 0
    recorded: int = 0
    dropped_by_camera: int = 0
    dropped_by_ring: int = 0
    dropped_by_recorder: int = 0


@dataclass(frozen=True, slots=True)
class CameraStatus:
    """One camera's live state: device health, frame accounting, ROI and the latest numbers."""

    name: str
    device: DeviceStatus
    frames: FrameAccounting
    fps: float = 0.0
    roi_xy: tuple[int, int] | None = None
    gps_xy: tuple[float, float] | None = None  # the drone's GPS position projected (px)
    track_state: str = "idle"
    track_reason: str = ""  # why the track missed its last frame (docs/tracking.md), "" if not
    last: PeakSnr | None = None
    snr_mean: float = float("nan")
    snr_std: float = float("nan")
    snr_n: int = 0
    snr_mean_raw: float = float("nan")  # without the background reference, while one is on
    snr_std_raw: float = float("nan")
    reference_frames: int = 0  # frames in the background reference (0: none)
    fixed_pattern_dn: float = float("nan")  # spatial std of the reference
    sky_temp_k: float = float("nan")  # apparent background temperature (with a calibration)
    range_m: float | None = None
    range_source: str = ""
    model_snr: dict[str, float] = field(default_factory=dict)
    latency_ms_p50: float = float("nan")
    latency_ms_p99: float = float("nan")
    # Section 6 noise of the background around the track (acquisition.measure.track_noise), DN:
    # temporal = std(frame - previous) / sqrt(2); spatial = sqrt(total^2 - temporal^2).
    noise_total_dn: float = float("nan")
    noise_temporal_dn: float = float("nan")
    noise_spatial_dn: float = float("nan")
    # 3D noise (D'Agostino and Webb, bias-corrected) of the background clear of the track over
    # the last complete block of 100 frames, and its region (acquisition.measure.track_noise);
    # None until a block is complete.
    noise_3d: RegionNoise3d | None = None


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
