"""The tracker's numbers, states and per-frame outcome (:mod:`snrmon.acquisition.track.tracker`).

Every number is a field of :class:`TrackerConfig` or of one of its parts (grouped by what they
decide); docs/tracking.md says what each one does and why it has its default.
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


def _check_integers(group: str, config: object, names: tuple[str, ...], minimum: int) -> None:
    """Each of ``names`` an integer >= ``minimum``: else one ValueError naming ``group.name``."""
    for name in names:
        v = getattr(config, name)
        if int(v) != v or v < minimum:
            raise ValueError(f"tracker {group}{name} must be an integer >= {minimum}, got {v}")


@dataclass(frozen=True)
class AppearanceConfig:
    """What the drone looks like and how far an object may differ from it and still be the
    drone: its recent history is the median prominence and core area of its last ``frames``
    accepted frames (counted from ``min_frames`` on); an object is refused as ``bright`` or
    ``faint`` beyond ``brightness_factor`` of that prominence, as ``size`` beyond
    ``size_factor`` of that area (either way)."""

    brightness_factor: float = 3.0
    size_factor: float = 6.0
    frames: int = 25
    min_frames: int = 5

    def __post_init__(self) -> None:
        _check_integers("appearance.", self, ("frames",), 1)
        if not 1 <= self.min_frames <= self.frames:
            raise ValueError(
                f"tracker appearance.min_frames must be in 1..{self.frames}, got {self.min_frames}"
            )
        for name in ("brightness_factor", "size_factor"):
            v = getattr(self, name)
            if math.isnan(v) or v <= 1:
                raise ValueError(f"tracker appearance.{name} must be a number > 1, got {v}")


@dataclass(frozen=True)
class SearchConfig:
    """The square a missed drone is looked for in, around its predicted position: from
    ``after_misses`` misses of a drone that vanished (at once once lost), of half-size
    ``start_px`` growing by ``growth_px`` per missed frame up to ``max_px``."""

    after_misses: int = 1
    start_px: int = 8
    growth_px: int = 16
    max_px: int = 96

    def __post_init__(self) -> None:
        _check_integers("search.", self, ("after_misses", "start_px", "max_px"), 1)
        _check_integers("search.", self, ("growth_px",), 0)


@dataclass(frozen=True)
class ReacquireConfig:
    """What an object must be to be taken as the drone when there is no track to follow (at
    the click, in the search square): prominence >= ``snr`` sigma and isolation >=
    ``isolation``; a candidate is accepted after ``frames`` consecutive frames in which it is
    found again where its own motion puts it, no farther than ``max_speed_px`` a frame."""

    snr: float = 5.0
    isolation: float = 0.5
    frames: int = 3
    max_speed_px: float = 4.0

    def __post_init__(self) -> None:
        _check_integers("reacquire.", self, ("frames",), 1)
        if math.isnan(self.snr):
            raise ValueError(f"tracker reacquire.snr must be a number, got {self.snr}")
        if not 0.0 <= self.isolation <= 1.0:
            raise ValueError(f"tracker reacquire.isolation must be in 0..1, got {self.isolation}")
        if not self.max_speed_px > 0:
            raise ValueError(f"tracker reacquire.max_speed_px must be > 0, got {self.max_speed_px}")


@dataclass(frozen=True)
class CueConfig:
    """The GPS cue while lost: no older than ``max_age_frames``, the ``2 radius_px + 1`` square
    around it searched; a drone found there is ``gps_cued`` until ``confirm_frames`` accepted
    frames (the cued one included)."""

    radius_px: int = 15
    max_age_frames: int = 60
    confirm_frames: int = 5

    def __post_init__(self) -> None:
        _check_integers("cue.", self, ("radius_px", "max_age_frames", "confirm_frames"), 1)


@dataclass(frozen=True)
class TrackerConfig:
    """Every number of the tracker (module docstring; docs/tracking.md): following the drone
    (the gate, what still counts as an object, the misses before lost) and, by concept, what
    it looks like, where a missed drone is searched for, what is taken for it again, the GPS
    cue, what an object is and the motion model. The Eq. (4) settings it measures with (search
    window, box, background, contamination test) are a :class:`PeakSnrConfig`, given to
    :class:`Tracker` beside this, so that tracking and fixed-point measurement share them."""

    gate_px: int = 3
    guard_px: int = 2
    click_radius_px: int = 8
    lost_snr: float = 3.0
    min_isolation: float = 0.5
    lost_frames: int = 10
    appearance: AppearanceConfig = field(default_factory=AppearanceConfig)
    search: SearchConfig = field(default_factory=SearchConfig)
    reacquire: ReacquireConfig = field(default_factory=ReacquireConfig)
    cue: CueConfig = field(default_factory=CueConfig)
    blob: BlobConfig = field(default_factory=BlobConfig)
    motion: MotionConfig = field(default_factory=MotionConfig)

    def __post_init__(self) -> None:
        _check_integers("", self, ("gate_px", "click_radius_px", "lost_frames"), 1)
        _check_integers("", self, ("guard_px",), 0)
        if math.isnan(self.lost_snr):
            raise ValueError(f"tracker lost_snr must be a number, got {self.lost_snr}")
        if not 0.0 <= self.min_isolation <= 1.0:
            raise ValueError(f"tracker min_isolation must be in 0..1, got {self.min_isolation}")


def reach_px(config: TrackerConfig, measurement: PeakSnrConfig) -> int:
    """How far from :attr:`Tracker.read_centre` a frame's reads can go (pixels, Chebyshev)."""
    search = max(config.search.max_px, config.cue.radius_px, config.click_radius_px + 2)
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
