"""Finding a lost drone again (the tracker's rules 5 and 6, docs/tracking.md).

While misses last, a square around the predicted position grows by ``search_growth_px`` per
missed frame from ``search_start_px`` to ``search_max_px``; once LOST with a fresh GPS cue, the
``2 cue_radius_px + 1`` square around the cue is searched on the frame the cue arrives and then
every other frame (one square a frame: the engine corrects only around :attr:`read_centre`).
Objects in it with prominence >= ``reacquire_snr`` sigma that look like the drone (prominence and
core area within ``brightness_factor`` / ``size_factor`` of its history) are candidates; the
nearest is followed with its own motion and accepted after ``reacquire_frames`` consecutive
frames in which it is found again where that motion puts it (within ``gate_px``), no faster than
``max_speed_px`` per frame and still looking like the drone. A bird crossing near the old
position moves too fast or does not look like the drone, and is dropped. A candidate at a fresh
GPS cue is accepted at once (state ``gps_cued``).

:class:`Reacquisition` is a part of :class:`acquisition.track.tracker.Tracker` (it works on the
tracker's own state); kept apart so each file reads on its own.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from acquisition.measure.blob import Blob
from acquisition.measure.peak_snr import FLAG_GPS_CUED, FLAG_LOST, pixel_of
from acquisition.track.candidate import Candidate, box_at, consistent
from acquisition.track.config import TrackState, TrackStep
from acquisition.track.search import brightest_in, find_objects, is_object

if TYPE_CHECKING:
    import numpy as np

    from acquisition.measure.peak_snr import PeakSnr, PeakSnrConfig
    from acquisition.measure.target_snr import TargetMeter
    from acquisition.track.candidate import ObjectHistory
    from acquisition.track.config import TrackerConfig
    from acquisition.track.motion import MotionModel


class Reacquisition:
    """The lost-track search and the confirmation of its candidates (module docstring)."""

    # The tracker's own state and parts this mixin works on (set by Tracker.__init__).
    config: TrackerConfig
    measurement: PeakSnrConfig
    motion: MotionModel
    reacquisitions: int
    track_state: TrackState
    _cue: tuple[float, float] | None
    _cue_age: int
    _shape: tuple[int, int] | None
    _pending: Candidate | None
    _misses: int
    _widen: int
    _anchored: bool
    _window: tuple[int, int]
    _history: ObjectHistory
    _meter: TargetMeter
    _search_reason: str

    if TYPE_CHECKING:

        def _analyse(self, pixels: np.ndarray, seed, size_px: int, centre=None) -> Blob | None: ...

        def _accept(self, blob: Blob) -> None: ...

        def _step(self, m: PeakSnr, at, size: int, reason: str, extra: set[str]) -> TrackStep: ...

    def _fresh_cue(self, ahead: int = 0) -> tuple[float, float] | None:
        """The GPS cue if it is no older than ``cue_max_age_frames`` (``ahead`` frames from
        now) and in the image."""
        if self._cue is None or self._cue_age + ahead > self.config.cue_max_age_frames:
            return None
        rows, cols = self._shape or (1 << 30, 1 << 30)
        x, y = pixel_of(self._cue)
        return self._cue if (0 <= x < cols and 0 <= y < rows) else None

    def _plan(self, misses: int, use_cue: bool, ahead: int = 0) -> tuple[str, tuple[int, int]]:
        """Where this frame's search runs: ("candidate", its predicted position) while one is
        being confirmed; ("cue", the cue) while lost with a fresh cue, on the frame it arrives
        and then every other frame; ("grow", the predicted position) otherwise. One place a
        frame: the engine corrects only the square around it (:attr:`read_centre` asks the same
        with ``ahead`` = 1)."""
        if self._pending is not None:
            return "candidate", pixel_of(self._pending.predict())
        cue = self._fresh_cue(ahead) if use_cue else None
        if cue is not None and (misses % 2 == 1 or self._cue_age + ahead <= 1):
            return "cue", pixel_of(cue)
        return "grow", pixel_of(self.motion.predict())

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
            at, size = centre, 2 * self.config.cue_radius_px + 1
        m = self._meter.measure(pixels, at, size, ref)
        return self._step(m, at, size, self._search_reason, {FLAG_LOST})

    def _reacquire(self, pixels, ref, *, use_cue: bool):
        """(step or None, plan kind, plan centre): confirm the pending candidate, or look for
        one at the cue or in the growing square (:meth:`_plan`)."""
        c = self.config
        self._search_reason = "searching"
        kind, centre = self._plan(self._misses, use_cue)
        if kind == "candidate":
            cand, self._pending = self._pending, None
            assert cand is not None  # the plan says so
            pred = cand.predict()
            seed = brightest_in(pixels, box_at(cand.rel, pred[0], pred[1], grow=c.gate_px))
            blob = self._analyse(pixels, seed, cand.size_px, pred)
            if not (
                is_object(blob, c.reacquire_snr, c.reacquire_isolation)
                and max(abs(blob.centroid_x - pred[0]), abs(blob.centroid_y - pred[1])) <= c.gate_px
                and math.hypot(blob.centroid_x - cand.x, blob.centroid_y - cand.y) <= c.max_speed_px
                and consistent(blob, self._history, c)
            ):  # dropped; the search goes on from the next frame
                return None, kind, centre
            cand.follow(blob)
            if cand.count >= c.reacquire_frames:
                return self._reacquired(pixels, blob, cand, ref), kind, centre
            self._pending = cand
            return self._confirming(pixels, blob, ref), kind, centre
        if kind == "cue":
            half = c.cue_radius_px
        else:
            grow = c.search_start_px + c.search_growth_px * (self._misses - 1) + self._widen
            half = min(grow, c.search_max_px)
        objects = find_objects(
            pixels, centre, half, config=c.blob, min_significance=c.reacquire_snr,
            min_isolation=c.reacquire_isolation, size_px=max(self._history.size_px, 1),
            min_contrast=(self._history.prominence or 0.0) / c.brightness_factor,
        )  # fmt: skip
        objects = [b for b in objects if consistent(b, self._history, c)]
        if not objects:
            if use_cue and self._fresh_cue() is not None:
                self._search_reason = "faint"  # not where its GPS position says it is
            return None, kind, centre
        blob = objects[0]
        if kind == "cue":  # the GPS position is a strong prior: accepted at once
            self._cue = None  # used: a later loss needs a fresh position
            self.motion.reset(blob.centroid_x, blob.centroid_y)
            m, _, _ = self._meter.measure_object(pixels, blob, centre, ref)
            self._accept(blob)
            self.track_state = TrackState.GPS_CUED
            self._confirmed = 1
            return self._step(m, centre, 2 * half + 1, "", {FLAG_GPS_CUED}), kind, centre
        self._pending = Candidate.of(blob, cued=False)
        return self._confirming(pixels, blob, ref), kind, centre

    def _confirming(self, pixels, blob: Blob, ref) -> TrackStep:
        self.track_state = TrackState.REACQUIRING
        m, at, size = self._meter.measure_object(pixels, blob, (blob.peak_x, blob.peak_y), ref)
        return self._step(m, at, size, "confirming", {FLAG_LOST})

    def _reacquired(self, pixels, blob: Blob, cand: Candidate, ref) -> TrackStep:
        self.motion.reset(blob.centroid_x, blob.centroid_y, cand.vx, cand.vy)
        m, at, size = self._meter.measure_object(pixels, blob, (blob.peak_x, blob.peak_y), ref)
        self._accept(blob)
        self.track_state = TrackState.TRACKING
        self.reacquisitions += 1
        return self._step(m, at, size, "", set())

    # ------------------------------------------------------------------ measurement
