"""The track: follows the object the operator clicked, measures it, and finds it again.

The operator clicks the drone once; the tracker follows *the compact bright object nearest the
click* (an :func:`snrmon.acquisition.measure.blob.analyse_blob` object, significant and isolated: a
treeline, a cloud bank or a saturated region is not one) and measures every frame with paper
Eq. (4), the background chosen by the target's extent
(:mod:`snrmon.acquisition.measure.target_snr`). Per frame (rules and numbers in docs/tracking.md and
:class:`TrackerConfig`):

1. **Click**: the nearest object within ``click_radius_px``; none -> LOST, reason ``no_object``.
2. **Follow**: a constant-velocity model (:mod:`snrmon.acquisition.track.motion`) predicts the core
   box; the object there is judged (:func:`snrmon.acquisition.track.candidate.judge`: occluded,
   faint, gate, bright, size) without ever looking at the SNR, which a contaminated background
   can make meaningless.
3. **Measure**: :class:`snrmon.acquisition.measure.target_snr.TargetMeter`; a miss is Eq. (4) at the
   held window, flagged ``lost`` when refused as occluded, gate, bright or size.
4. **States**: tracking, occluded, lost (``lost_frames`` misses), reacquiring, gps_cued.
5. **Reacquisition**: a square growing around the prediction (around a fresh GPS cue while
   lost); a candidate is accepted after ``reacquire.frames`` consistent frames (a GPS-cued one
   at once).
6. **Gaps**: frames dropped before the tracker (:meth:`Tracker.skip`, or ``update(frames=)``)
   move the motion model on without decay; a ``gate`` miss right after them is searched for at
   once, in a square widened by ``reacquire.max_speed_px`` per dropped frame.

Finding a lost drone again (rules 5 and 6 in detail): while misses last, a square around the
predicted position grows by ``search.growth_px`` per missed frame from ``search.start_px`` to
``search.max_px``; once LOST with a fresh GPS cue, the ``2 cue.radius_px + 1`` square around the
cue is searched on the frame the cue arrives and then every other frame (one square a frame: the
engine corrects only around :attr:`read_centre`). Objects in it with prominence >=
``reacquire.snr`` sigma that look like the drone (prominence and core area within
``appearance.brightness_factor`` / ``appearance.size_factor`` of its history) are candidates; the
nearest is followed with its own motion and accepted after ``reacquire.frames`` consecutive frames
in which it is found again where that motion puts it (within ``gate_px``), no faster than
``reacquire.max_speed_px`` per frame and still looking like the drone. A bird crossing near the old
position moves too fast or does not look like the drone, and is dropped. A candidate at a fresh GPS
cue is accepted at once (state ``gps_cued``).

The complete state is :meth:`Tracker.snapshot` (JSON-able; floats exact) and
:meth:`Tracker.restore`: a tracker built with the same configuration and restored from the
state after frame k gives bit-identical steps from frame k + 1 on. Everything a frame reads lies
within :func:`reach_px` of :attr:`Tracker.read_centre`.

The rim-contamination reference (``reference_noise``): ``"recent"`` (default) keeps the same
recent-noise median as :class:`snrmon.acquisition.measure.peak_snr.PeakSnrMeter`, fed with the
tracker's output frames; a number fixes it (DN); None skips the contamination test.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from snrmon.acquisition.measure.blob import Blob, analyse_blob
from snrmon.acquisition.measure.contamination import NoiseReference
from snrmon.acquisition.measure.peak_snr import (
    FLAG_GPS_CUED,
    FLAG_LOST,
    PeakSnr,
    PeakSnrConfig,
    pixel_of,
    result_with,
)
from snrmon.acquisition.measure.running_stats import RunningSnr
from snrmon.acquisition.track.candidate import Candidate, ObjectHistory, box_at, consistent, judge
from snrmon.acquisition.track.config import (
    ON_TARGET,
    REFUSED,
    TrackerConfig,
    TrackState,
    TrackStep,
    reach_px,
)
from snrmon.acquisition.track.measurement import TrackMeasurement
from snrmon.acquisition.track.motion import MotionModel
from snrmon.acquisition.track.reacquire import FrameGaps, GpsCue, LostSearch
from snrmon.acquisition.track.search import box_distance, brightest_in, find_objects, is_object

__all__ = [
    "ON_TARGET",
    "TrackState",
    "TrackStep",
    "Tracker",
    "TrackerConfig",
    "reach_px",
    "track_stack",
]


class Tracker:
    """Follows the drone from the operator's click (:meth:`click`) frame by frame: the track's
    own state (the click, the window, misses, its state) and, owned by it, its measurement
    (:class:`TrackMeasurement`), the drone's history, its motion model, the GPS cue, what
    dropped frames did and the lost-track search (:mod:`snrmon.acquisition.track.reacquire`)."""

    def __init__(
        self,
        at_xy: tuple[float, float],
        config: TrackerConfig | None = None,
        *,
        measurement: PeakSnrConfig | None = None,
        reference_noise: float | str | None = "recent",
        memory: tuple[NoiseReference, RunningSnr] | None = None,
        **settings,
    ) -> None:
        """``memory``: the noise reference and running statistics the track feeds
        (:class:`TrackMeasurement`), a measurer's own; None: a reference of the track's own and
        no running statistics."""
        if config is not None and settings:
            raise ValueError("give either config or settings, not both")
        self.config = config if config is not None else TrackerConfig(**settings)
        self.measurement = measurement if measurement is not None else PeakSnrConfig()
        c = self.config
        self._measure = TrackMeasurement(self.measurement, c, reference_noise, memory)
        self._history = ObjectHistory(c.appearance.frames, c.appearance.min_frames)
        self.motion = MotionModel(c.motion)
        self._cue = GpsCue()
        self._shape: tuple[int, int] | None = None
        self._gaps = FrameGaps()
        self._search = LostSearch()
        self.click(at_xy)

    # ----------------------------------------------------------------------------- commands
    def click(self, at_xy: tuple[float, float]) -> None:
        """The operator's click: the track starts afresh from the object nearest it."""
        self._click = pixel_of(at_xy)
        self._window = self._click
        self._anchored = False  # no object yet: the next frame looks near the click
        self._misses = 0
        self._confirmed = 0
        self._gaps.widen_px = 0
        self.track_state = TrackState.TRACKING
        self._history.clear()
        self._measure.clear()
        self.motion.reset(*self._click)
        self._search.pending = None

    def cue(self, x: float, y: float) -> None:
        """The drone's GPS position projected into this camera (pixels). Used while LOST;
        remembered (for the GUI's marker) otherwise. A non-finite position is a ValueError."""
        self._cue.give(x, y)

    @property
    def last_cue(self) -> tuple[float, float] | None:
        return self._cue.xy

    @property
    def reacquisitions(self) -> int:
        """How many times the drone was found again after a loss."""
        return self._search.reacquisitions

    @property
    def window_xy(self) -> tuple[int, int]:
        """Where the next frame's Eq. (4) search window is centred."""
        return self._window

    @property
    def read_centre(self) -> tuple[int, int]:
        """Centre of the square (half-size :func:`reach_px`) the next frame reads in."""
        if self.track_state in (TrackState.LOST, TrackState.REACQUIRING):
            # As update() will plan it: one miss more, the cue one frame older.
            return self._plan(self._misses + 1, use_cue=True, ahead=1)[1]
        return pixel_of(self.motion.predict())

    @property
    def reference_noise(self) -> float | None:
        """The contamination reference (DN) the next frame is measured against."""
        return self._measure.reference_noise

    # ----------------------------------------------------------------------------- per frame
    def skip(self, frames: int) -> None:
        """``frames`` camera frames were dropped before the next :meth:`update` (by the camera,
        or by a frame ring the measurement could not keep up with). The motion model moves on
        over them without decay (kept in the image), the cue ages, a candidate being confirmed
        is dropped (its frames must be consecutive), the search square widens by
        ``max_speed_px`` a frame, and a ``gate`` miss on the next frame is a drone that moved,
        looked for at once, not a confuser. Call it before reading :attr:`read_centre`."""
        n = int(frames)
        if n <= 0:
            return
        self._gaps.dropped(n)
        self._cue.age(n)
        if not self._anchored:
            return  # no track yet: the next frame looks near the click (or searches) anyway
        bounds = None if self._shape is None else (self._shape[1], self._shape[0])
        self.motion.advance(n, bounds)
        self._search.pending = None
        c = self.config
        self._gaps.widen(n, c.reacquire.max_speed_px, c.search.max_px)

    def update(self, pixels: np.ndarray, *, frames: int = 1) -> TrackStep:
        """Measure and track one frame (rows, columns), ``frames`` camera frames after the last
        one (> 1 after drops: :meth:`skip` of ``frames - 1`` first)."""
        self.skip(frames - 1)
        if pixels.ndim != 2:
            raise ValueError(f"a frame must be 2-D (rows, columns), got shape {pixels.shape}")
        if self._shape is None:
            self._shape = pixels.shape
        elif pixels.shape != self._shape:
            raise ValueError(
                f"frame of {pixels.shape[1]}x{pixels.shape[0]} px, but the track runs on "
                f"{self._shape[1]}x{self._shape[0]} px frames"
            )
        self._cue.age(1)
        ref = self.reference_noise
        if not self._anchored and self.track_state is TrackState.TRACKING:
            step = self._acquire(pixels, ref)
        elif self.track_state in (TrackState.LOST, TrackState.REACQUIRING):
            step = self._lost(pixels, ref)
        else:
            step = self._follow(pixels, ref)
        self._measure.remember(step.peak_snr)
        self._gaps.measured()
        return step

    def _analyse(self, pixels, seed, size_px: int, centre=None) -> Blob | None:
        if seed is None:
            return None
        at = None if centre is None else pixel_of(centre)
        return analyse_blob(pixels, seed, self.config.blob, min_half_px=size_px, centre_xy=at)

    def _acquire(self, pixels, ref) -> TrackStep:
        c = self.config
        cx, cy = self._click
        rows, cols = pixels.shape
        if not (0 <= cx < cols and 0 <= cy < rows):
            raise ValueError(
                f"click at x={cx}, y={cy} is off the {cols}x{rows} image "
                f"(x must be 0..{cols - 1}, y 0..{rows - 1})"
            )
        near = brightest_in(pixels, (cx - 2, cy - 2, cx + 2, cy + 2))
        objects = find_objects(
            pixels,
            (cx, cy),
            c.click_radius_px + 2,
            config=c.blob,
            min_significance=c.reacquire.snr,
            min_isolation=c.reacquire.isolation,
            seeds=() if near is None else (near,),
        )
        objects = [b for b in objects if box_distance(b.core_box, (cx, cy)) <= c.click_radius_px]
        if not objects:
            self._misses = 1
            self.track_state = TrackState.LOST
            size = self.measurement.search_px
            m = self._measure.measure(pixels, self._click, size, ref)
            return self._step(m, self._click, size, "no_object", {FLAG_LOST})
        blob = objects[0]
        m, at, size = self._measure.measure_object(pixels, blob, self._click, ref)
        self.motion.reset(blob.centroid_x, blob.centroid_y)
        self._accept(blob)
        return self._step(m, at, size, "", set())

    # ------------------------------------------------------------------ following
    def _follow(self, pixels, ref) -> TrackStep:
        c = self.config
        pred = self.motion.predict()
        hist = self._history
        core = box_at(hist.rel, *pred)
        seed = brightest_in(pixels, box_at(hist.rel, *pred, grow=c.gate_px))
        blob = self._analyse(pixels, seed, hist.size_px, pred)
        reason = judge(blob, pred, self._history, c)
        if reason in ("occluded", "faint", "undefined", "gate"):
            # The brightest pixel near the prediction may be clutter or another object beside
            # the drone: try the predicted core itself.
            seed2 = brightest_in(pixels, core)
            if seed2 is not None and seed2 != seed:
                blob2 = self._analyse(pixels, seed2, hist.size_px, pred)
                if judge(blob2, pred, self._history, c) == "":
                    blob, reason = blob2, ""
        if reason == "" and blob is not None:  # judge() calls a missing object "undefined"
            m, at, size = self._measure.measure_object(pixels, blob, self._window, ref)
            self.motion.update(blob.centroid_x, blob.centroid_y)
            self._accept(blob)
            if self.track_state is TrackState.GPS_CUED:
                self._confirmed += 1
                if self._confirmed >= c.cue.confirm_frames:
                    self.track_state = TrackState.TRACKING
            else:
                self.track_state = TrackState.TRACKING
            extra = {FLAG_GPS_CUED} if self.track_state is TrackState.GPS_CUED else set()
            return self._step(m, at, size, "", extra)
        return self._miss(pixels, ref, reason)

    def _miss(self, pixels, ref, reason: str) -> TrackStep:
        c = self.config
        self._misses += 1
        self._confirmed = 0
        self.motion.coast()
        if self._misses >= c.lost_frames:
            self.track_state = TrackState.LOST
        elif reason == "occluded":
            self.track_state = TrackState.OCCLUDED
        # A drone that vanished from its predicted place (a jump, a cut, a fast turn) is looked
        # for at once; one hidden by a confuser or merged with clutter is most likely still
        # where it was. Right after dropped frames, off the gate is a drone that moved on.
        vanished = reason in ("faint", "undefined") or (reason == "gate" and self._gaps.frames > 1)
        if self.track_state is TrackState.LOST or (
            vanished and self._misses >= c.search.after_misses
        ):
            found = self._reacquire(pixels, ref, use_cue=False)[0]
            if found is not None:
                return found
        at = self._window
        size = self.measurement.search_px
        m = self._measure.measure(pixels, at, size, ref)
        if max(abs(m.peak_x - at[0]), abs(m.peak_y - at[1])) > c.gate_px:
            size = 2 * c.gate_px + 1
            m = self._measure.measure(pixels, at, size, ref)
        lost = reason in REFUSED or self.track_state is TrackState.LOST
        extra = {FLAG_LOST} if lost else set()
        if self.track_state is TrackState.GPS_CUED:
            extra.add(FLAG_GPS_CUED)
        return self._step(m, at, size, reason, extra)

    def _accept(self, blob: Blob) -> None:
        self._window = (blob.peak_x, blob.peak_y)
        self._anchored = True
        self._misses = 0
        self._gaps.widen_px = 0
        self._search.pending = None
        self._history.add(blob)

    def _step(self, m: PeakSnr, at, size: int, reason: str, extra: set[str]) -> TrackStep:
        if extra - m.flags:
            m = result_with(m, flags=m.flags | extra)
        return TrackStep(m, self.track_state, int(at[0]), int(at[1]), size, reason, self._misses)

    # ------------------------------------------------------------------ reacquisition
    def _fresh_cue(self, ahead: int = 0) -> tuple[float, float] | None:
        """The GPS cue if it is fresh (``ahead`` frames from now) and in the image."""
        return self._cue.fresh(self.config.cue, self._shape, ahead)

    def _plan(self, misses: int, use_cue: bool, ahead: int = 0) -> tuple[str, tuple[int, int]]:
        """Where this frame's search runs (:meth:`LostSearch.plan`), the cue looked for only
        with ``use_cue`` (while lost)."""
        cue = self._fresh_cue(ahead) if use_cue else None
        return self._search.plan(misses, cue, self._cue.age_frames, self.motion, ahead)

    def _lost(self, pixels, ref) -> TrackStep:
        self._misses += 1
        self.motion.coast()
        found, kind, centre = self._reacquire(pixels, ref, use_cue=True)
        if found is not None:
            return found
        # A candidate dropped before lost_frames misses of a track: it coasts on (still
        # flagged). Without a track (nothing at the click) it stays lost until found.
        lost = self._misses >= self.config.lost_frames or not self._anchored
        self.track_state = TrackState.LOST if lost else TrackState.TRACKING
        if kind == "grow":  # the measurement holds at the last good position
            at, size = self._window, self.measurement.search_px
        else:  # measured where it was looked for
            at, size = centre, 2 * self.config.cue.radius_px + 1
        m = self._measure.measure(pixels, at, size, ref)
        return self._step(m, at, size, self._search.reason, {FLAG_LOST})

    def _reacquire(self, pixels, ref, *, use_cue: bool):
        """(step or None, plan kind, plan centre): confirm the pending candidate, or look for
        one at the cue or in the growing square (:meth:`_plan`)."""
        c = self.config
        self._search.reason = "searching"
        kind, centre = self._plan(self._misses, use_cue)
        if kind == "candidate":
            return self._confirm(pixels, ref), kind, centre
        half = LostSearch.half_px(kind, self._misses, self._gaps.widen_px, c.search, c.cue)
        objects = find_objects(
            pixels,
            centre,
            half,
            config=c.blob,
            min_significance=c.reacquire.snr,
            min_isolation=c.reacquire.isolation,
            size_px=max(self._history.size_px, 1),
            min_contrast=(self._history.prominence or 0.0) / c.appearance.brightness_factor,
        )
        objects = [b for b in objects if consistent(b, self._history, c.appearance)]
        if not objects:
            if use_cue and self._fresh_cue() is not None:
                self._search.reason = "faint"  # not where its GPS position says it is
            return None, kind, centre
        blob = objects[0]
        if kind == "cue":  # the GPS position is a strong prior: accepted at once
            self._cue.use()
            self.motion.reset(blob.centroid_x, blob.centroid_y)
            m, _, _ = self._measure.measure_object(pixels, blob, centre, ref)
            self._accept(blob)
            self.track_state = TrackState.GPS_CUED
            self._confirmed = 1
            return self._step(m, centre, 2 * half + 1, "", {FLAG_GPS_CUED}), kind, centre
        self._search.pending = Candidate.of(blob, cued=False)
        return self._confirming(pixels, blob, ref), kind, centre

    def _confirm(self, pixels, ref) -> TrackStep | None:
        """The pending candidate found again where its motion puts it (a step), or dropped
        (None: the search goes on from the next frame)."""
        c, r = self.config, self.config.reacquire
        cand, self._search.pending = self._search.pending, None
        assert cand is not None  # the plan says so
        pred = cand.predict()
        seed = brightest_in(pixels, box_at(cand.rel, pred[0], pred[1], grow=c.gate_px))
        blob = self._analyse(pixels, seed, cand.size_px, pred)
        if not (
            is_object(blob, r.snr, r.isolation)
            and max(abs(blob.centroid_x - pred[0]), abs(blob.centroid_y - pred[1])) <= c.gate_px
            and math.hypot(blob.centroid_x - cand.x, blob.centroid_y - cand.y) <= r.max_speed_px
            and consistent(blob, self._history, c.appearance)
        ):
            return None
        cand.follow(blob)
        if cand.count >= r.frames:
            return self._reacquired(pixels, blob, cand, ref)
        self._search.pending = cand
        return self._confirming(pixels, blob, ref)

    def _confirming(self, pixels, blob: Blob, ref) -> TrackStep:
        self.track_state = TrackState.REACQUIRING
        at = (blob.peak_x, blob.peak_y)
        m, at, size = self._measure.measure_object(pixels, blob, at, ref)
        return self._step(m, at, size, "confirming", {FLAG_LOST})

    def _reacquired(self, pixels, blob: Blob, cand: Candidate, ref) -> TrackStep:
        self.motion.reset(blob.centroid_x, blob.centroid_y, cand.vx, cand.vy)
        at = (blob.peak_x, blob.peak_y)
        m, at, size = self._measure.measure_object(pixels, blob, at, ref)
        self._accept(blob)
        self.track_state = TrackState.TRACKING
        self._search.reacquisitions += 1
        return self._step(m, at, size, "", set())

    # ------------------------------------------------------------------ state
    def snapshot(self) -> dict:
        """Everything the tracker remembers, JSON-able (str/int/float/bool/None, lists and
        dicts; floats kept exactly): :meth:`restore` on a tracker with the same
        configuration continues bit for bit."""
        pending, cue = self._search.pending, self._cue.xy
        return {
            "track_state": self.track_state.value,
            "click": list(self._click),
            "window": list(self._window),
            "anchored": self._anchored,
            "misses": self._misses,
            "confirmed": self._confirmed,
            "widen": self._gaps.widen_px,
            "cue": None if cue is None else list(cue),
            "cue_age": self._cue.age_frames,
            "shape": None if self._shape is None else list(self._shape),
            "search_reason": self._search.reason,
            "reacquisitions": self._search.reacquisitions,
            "motion": self.motion.snapshot(),
            "history": self._history.snapshot(),
            "reference": self._measure.reference_snapshot(),
            "wings": self._measure.wings_snapshot(),
            "pending": None if pending is None else pending.snapshot(),
        }

    def restore(self, d: dict) -> None:
        """Restore a :meth:`snapshot` taken from a tracker with the same configuration."""
        self.track_state = TrackState(d["track_state"])
        self._click = (int(d["click"][0]), int(d["click"][1]))
        self._window = (int(d["window"][0]), int(d["window"][1]))
        self._anchored = bool(d["anchored"])
        self._misses = int(d["misses"])
        self._confirmed = int(d["confirmed"])
        self._gaps.widen_px = int(d.get("widen", 0))  # states recorded before gaps were told: 0
        self._gaps.measured()
        self._cue.xy = None if d["cue"] is None else (float(d["cue"][0]), float(d["cue"][1]))
        self._cue.age_frames = int(d["cue_age"])
        self._shape = None if d["shape"] is None else (int(d["shape"][0]), int(d["shape"][1]))
        self._search.reason = str(d["search_reason"])
        self._search.reacquisitions = int(d["reacquisitions"])
        self.motion.restore(d["motion"])
        self._history.restore(d["history"])
        self._measure.restore(d["reference"], d["wings"])
        pending = d["pending"]
        self._search.pending = None if pending is None else Candidate.from_snapshot(pending)


def track_stack(
    stack: np.ndarray,
    at_xy: tuple[float, float],
    config: TrackerConfig | None = None,
    *,
    measurement: PeakSnrConfig | None = None,
    cues: Iterable[tuple[float, float] | None] | None = None,
    reference_noise: float | str | None = "recent",
) -> list[TrackStep]:
    """Run a :class:`Tracker` over a stack (N, rows, columns) from the click ``at_xy``;
    ``cues``: per frame, a projected GPS position given before that frame, or None."""
    if stack.ndim != 3:
        raise ValueError(f"a stack must be 3-D (frames, rows, columns), got shape {stack.shape}")
    tracker = Tracker(at_xy, config, measurement=measurement, reference_noise=reference_noise)
    cue_list = list(cues) if cues is not None else [None] * len(stack)
    if len(cue_list) != len(stack):
        raise ValueError(f"{len(cue_list)} cues for {len(stack)} frames")
    steps = []
    for frame, cue in zip(stack, cue_list, strict=True):
        if cue is not None:
            tracker.cue(*cue)
        steps.append(tracker.update(frame))
    return steps
