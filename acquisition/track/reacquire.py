"""What the tracker keeps for finding the drone again (docs/tracking.md, "Reacquisition" and
"Frame gaps"): the GPS cue, what dropped frames did to the search, and the search itself (where
it runs this frame, the candidate being confirmed).

The tracker (:mod:`snrmon.acquisition.track.tracker`) decides; these hold the state its rules 5
and 6 read, each with the one rule of its own.
"""

from __future__ import annotations

import math

from snrmon.acquisition.measure.peak_snr import pixel_of
from snrmon.acquisition.track.candidate import Candidate
from snrmon.acquisition.track.config import CueConfig, SearchConfig
from snrmon.acquisition.track.motion import MotionModel


class GpsCue:
    """The drone's GPS position projected into this camera (pixels, None: none given) and how
    many camera frames old it is."""

    def __init__(self) -> None:
        self.xy: tuple[float, float] | None = None
        self.age_frames = 0

    def give(self, x: float, y: float) -> None:
        """A new cue (a non-finite position is a ValueError)."""
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError(f"GPS cue must be a finite pixel position, got ({x}, {y})")
        self.xy = (float(x), float(y))
        self.age_frames = 0

    def age(self, frames: int) -> None:
        """``frames`` camera frames went by (a cue not given does not age)."""
        if self.xy is not None:
            self.age_frames += frames

    def fresh(
        self, config: CueConfig, shape: tuple[int, int] | None, ahead: int = 0
    ) -> tuple[float, float] | None:
        """The cue if it is no older than ``max_age_frames`` (``ahead`` frames from now) and in
        the image (rows, columns; None: not known yet)."""
        if self.xy is None or self.age_frames + ahead > config.max_age_frames:
            return None
        rows, cols = shape or (1 << 30, 1 << 30)
        x, y = pixel_of(self.xy)
        return self.xy if (0 <= x < cols and 0 <= y < rows) else None

    def use(self) -> None:
        """The drone was found at the cue: a later loss needs a fresh position."""
        self.xy = None


class FrameGaps:
    """What dropped frames leave the track: the camera frames from the last update to the next
    (``frames``, > 1 after drops) and the pixels the search square is widened by until the
    drone is found again (``widen_px``: ``max_speed_px`` per dropped frame)."""

    def __init__(self) -> None:
        self.frames = 1
        self.widen_px = 0

    def dropped(self, frames: int) -> None:
        """``frames`` camera frames were dropped before the next update."""
        self.frames += frames

    def widen(self, frames: int, max_speed_px: float, max_px: int) -> None:
        """The drone may have moved ``max_speed_px`` a frame over ``frames`` unseen ones (the
        square no larger than ``max_px``)."""
        self.widen_px = min(self.widen_px + math.ceil(max_speed_px * frames), max_px)

    def measured(self) -> None:
        """A frame was measured: the next follows it directly, unless told otherwise."""
        self.frames = 1


class LostSearch:
    """The search for a missed or lost drone: the candidate being confirmed (``pending``), the
    reason a frame that found nothing gives (``reason``: ``searching``, or ``faint`` when a
    fresh cue showed nothing) and the reacquisitions so far."""

    def __init__(self) -> None:
        self.pending: Candidate | None = None
        self.reason = "searching"
        self.reacquisitions = 0

    def plan(
        self,
        misses: int,
        cue_xy: tuple[float, float] | None,
        cue_age_frames: int,
        motion: MotionModel,
        ahead: int = 0,
    ) -> tuple[str, tuple[int, int]]:
        """Where this frame's search runs: ("candidate", its predicted position) while one is
        being confirmed; ("cue", the cue) while lost with a fresh cue (``cue_xy``, None: none or
        not looked for), on the frame it arrives and then every other frame; ("grow", the
        predicted position) otherwise. One place a frame: the engine corrects only the square
        around it (:attr:`Tracker.read_centre` asks the same with ``ahead`` = 1)."""
        if self.pending is not None:
            return "candidate", pixel_of(self.pending.predict())
        if cue_xy is not None and (misses % 2 == 1 or cue_age_frames + ahead <= 1):
            return "cue", pixel_of(cue_xy)
        return "grow", pixel_of(motion.predict())

    @staticmethod
    def half_px(kind: str, misses: int, widen_px: int, search: SearchConfig, cue: CueConfig) -> int:
        """The half-size of the square searched: the cue's, or the growing square's after
        ``misses`` missed frames, widened by ``widen_px`` after dropped frames."""
        if kind == "cue":
            return cue.radius_px
        grow = search.start_px + search.growth_px * (misses - 1) + widen_px
        return min(grow, search.max_px)
