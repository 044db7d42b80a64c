"""The tracker's numbers, states and per-frame outcome (:mod:`snrmon.acquisition.track.tracker`).

Every number is a :class:`TrackerConfig` field; docs/tracking.md says what each one does and why
it has its default.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum

from snrmon.acquisition.measure.blob import BlobConfig
from snrmon.acquisition.measure.peak_snr import PeakSnr, PeakSnrConfig
from snrmon.acquisition.track.motion import MotionConfig

WING_PX = 8  # the farthest the background rim moves out past PSF wings (target_snr.wing_growth)


class TrackState(StrEnum):
    """What a camera's measurement is doing: no ROI (``idle``), a fixed window without tracking
    (``fixed``), or the tracker's state; shown to the operator and recorded (its value)."""

    IDLE = "idle"
    FIXED = "fixed"
    TRACKING = "tracking"
    LOST = "lost"
    GPS_CUED = "gps_cued"
    OCCLUDED = "occluded"
    REACQUIRING = "reacquiring"


#: States in which the measurement is the followed drone's.
ON_TARGET = frozenset({TrackState.TRACKING, TrackState.GPS_CUED})


@dataclass(frozen=True)
class TrackerConfig:
    """Every number of the tracker (module docstring). The Eq. (4) settings it measures with
    (search window, box, background, contamination test) are a :class:`PeakSnrConfig`, given
    to :class:`Tracker` beside this, so that tracking and fixed-point measurement share them."""

    gate_px: int = 3
    lost_snr: float = 3.0
    lost_frames: int = 10
    brightness_factor: float = 3.0
    brightness_frames: int = 25
    brightness_min_frames: int = 5
    cue_radius_px: int = 15
    cue_max_age_frames: int = 60
    reacquire_snr: float = 5.0
    confirm_frames: int = 5
    click_radius_px: int = 8
    min_isolation: float = 0.5
    reacquire_isolation: float = 0.5
    size_factor: float = 6.0
    reacquire_frames: int = 3
    search_after_misses: int = 1
    search_start_px: int = 8
    search_growth_px: int = 16
    search_max_px: int = 96
    max_speed_px: float = 4.0
    guard_px: int = 2
    blob: BlobConfig = field(default_factory=BlobConfig)
    motion: MotionConfig = field(default_factory=MotionConfig)

    def __post_init__(self) -> None:
        ints = (
            "gate_px",
            "cue_radius_px",
            "lost_frames",
            "confirm_frames",
            "brightness_frames",
            "cue_max_age_frames",
            "click_radius_px",
            "reacquire_frames",
            "search_after_misses",
            "search_start_px",
            "search_max_px",
        )
        for name in ints:
            v = getattr(self, name)
            if int(v) != v or v < 1:
                raise ValueError(f"tracker {name} must be an integer >= 1, got {v}")
        for name in ("search_growth_px", "guard_px"):
            v = getattr(self, name)
            if int(v) != v or v < 0:
                raise ValueError(f"tracker {name} must be an integer >= 0, got {v}")
        if not 1 <= self.brightness_min_frames <= self.brightness_frames:
            raise ValueError(
                f"tracker brightness_min_frames must be in 1..{self.brightness_frames}, "
                f"got {self.brightness_min_frames}"
            )
        for name in ("lost_snr", "reacquire_snr", "brightness_factor", "size_factor"):
            v = getattr(self, name)
            if math.isnan(v) or (name.endswith("factor") and v <= 1):
                raise ValueError(f"tracker {name} must be a number (factor > 1), got {v}")
        for name in ("min_isolation", "reacquire_isolation"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"tracker {name} must be in 0..1, got {getattr(self, name)}")
        if not self.max_speed_px > 0:
            raise ValueError(f"tracker max_speed_px must be > 0, got {self.max_speed_px}")


def reach_px(config: TrackerConfig, measurement: PeakSnrConfig) -> int:
    """How far from :attr:`Tracker.read_centre` a frame's reads can go (pixels, Chebyshev)."""
    search = max(config.search_max_px, config.cue_radius_px, config.click_radius_px + 2)
    window = max(measurement.search_px // 2, config.gate_px) + measurement.box_px // 2
    around = config.blob.max_half_px + config.guard_px + 2 + WING_PX + 2
    return search + around + window + math.ceil(config.motion.max_speed_px) + 2


@dataclass(frozen=True, slots=True)
class TrackStep:
    """One frame's outcome.

    Attributes:
        peak_snr: the Eq. (4) measurement output for this frame (with ``lost``/``gps_cued``).
        state: the track state after this frame.
        window_x, window_y: centre of the search window the output was measured in.
        search_px: that window's size (the normal window, the gate, the target's own, the cue
            square or the lost-track search square).
        reason: "" when the object was found, else why not: undefined, occluded, faint, gate,
            bright, size, no_object (nothing compact near the click), confirming (a
            reacquisition candidate under confirmation), searching (lost, nothing found).
        misses: consecutive frames without the object.
    """

    peak_snr: PeakSnr
    state: TrackState
    window_x: int
    window_y: int
    search_px: int
    reason: str
    misses: int


#: Miss reasons whose frames are not the drone's measurement (flagged ``lost``).
REFUSED = frozenset({"gate", "bright", "occluded", "size"})
