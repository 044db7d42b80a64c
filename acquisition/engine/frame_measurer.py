"""One camera's per-frame measurement state: the ROI, the tracker, Eq. (4) and the running stats.

The live pipeline and the replay of a recording both measure through this one class, so a
replay driven by the recorded ROI events reproduces the recorded per-frame SNR exactly.
"""

from __future__ import annotations

import numpy as np

from snrmon.acquisition.engine.inputs import Measurement, RunningFigures
from snrmon.acquisition.measure.peak_snr import (
    PeakSnr,
    PeakSnrConfig,
    PeakSnrMeter,
)
from snrmon.acquisition.stage_clock import EQ4, enter
from snrmon.acquisition.streams.ring import RingFrame
from snrmon.acquisition.track.config import TrackState
from snrmon.acquisition.track.tracker import Tracker, TrackerConfig, reach_px


def crop_half_px(config: PeakSnrConfig, tracker: TrackerConfig) -> int:
    """Half-size of the square around :attr:`FrameMeasurer.read_xy` that holds every pixel the
    measurement may read on the next frame (the tracker's search, the object's analysis window
    and background; the fixed window and its box without a tracker)."""
    return max(reach_px(tracker, config), config.search_px // 2 + config.box_px // 2 + 2)


class FrameMeasurer:
    """Measures frame after frame around an ROI, following the drone when ``track`` is on."""

    def __init__(
        self,
        config: PeakSnrConfig | None = None,
        *,
        window: int = 100,
        track: bool = True,
        tracker_config: TrackerConfig | None = None,
    ) -> None:
        self.meter = PeakSnrMeter(config, window=window)
        self.track = track
        self.tracker_config = tracker_config or TrackerConfig()
        # the search window's centre: the click, then where the track has it (None: no ROI)
        self.roi_centre: tuple[int, int] | None = None
        self.tracker: Tracker | None = None

    @property
    def state(self) -> TrackState:
        if self.roi_centre is None:
            return TrackState.IDLE
        return self.tracker.track_state if self.tracker is not None else TrackState.FIXED

    def set_roi(self, x: int, y: int) -> None:
        """The operator's click: a fresh track (and fresh statistics) from this point."""
        self.meter.reset()
        self.roi_centre = (int(x), int(y))
        self.tracker = None
        if self.track:
            self.tracker = self._tracker(self.roi_centre)

    @property
    def read_xy(self) -> tuple[int, int] | None:
        """Centre of the square (:func:`crop_half_px`) the next :meth:`measure` reads in."""
        if self.tracker is not None:
            return self.tracker.read_centre
        return self.roi_centre

    def _tracker(self, at: tuple[int, int]) -> Tracker:
        """A track from ``at`` that feeds this measurer's own noise reference and running
        statistics (one memory, whoever measures: the track or Eq. 4 alone)."""
        meter = self.meter
        return Tracker(
            at,
            self.tracker_config,
            measurement=meter.config,
            memory=(meter.reference, meter.running),
        )

    def clear_roi(self) -> None:
        self.roi_centre = None
        self.tracker = None

    def snapshot(self) -> dict:
        """Everything that carries over from frame to frame (ROI, track, running statistics,
        noise reference), exactly and JSON-able: :meth:`restore` on a measurer of the same
        settings continues bit-identically."""
        return {
            "roi": None if self.roi_centre is None else list(self.roi_centre),
            "meter": self.meter.snapshot(),
            "tracker": None if self.tracker is None else self.tracker.snapshot(),
        }

    def restore(self, state: dict) -> None:
        roi = state["roi"]
        self.meter.restore(state["meter"])
        if roi is None:
            self.roi_centre, self.tracker = None, None
            return
        self.roi_centre = (int(roi[0]), int(roi[1]))
        self.tracker = None
        if state["tracker"] is not None:
            if not self.track:
                raise ValueError("a tracked state restored into a measurer with tracking off")
            self.tracker = self._tracker(self.roi_centre)
            self.tracker.restore(state["tracker"])

    def skip(self, frames: int) -> None:
        """``frames`` camera frames were dropped before the next :meth:`measure`
        (:meth:`snrmon.acquisition.track.tracker.Tracker.skip`; nothing without a tracker). Call it
        before reading :attr:`read_xy`."""
        if self.tracker is not None:
            self.tracker.skip(frames)

    def cue(self, x: float, y: float) -> None:
        """A GPS position projected into this camera, for the tracker to reacquire near."""
        if self.tracker is not None:
            self.tracker.cue(x, y)

    def measure(
        self,
        pixels: np.ndarray,
        frame: RingFrame,
        *,
        range_m: float | None = None,
        range_source: str = "",
        cue_xy: tuple[float, float] | None = None,
        raw: RunningFigures | None = None,
    ) -> Measurement | None:
        """Eq. (4) on ``pixels`` (``frame``'s, corrected), with the track, and the running
        statistics after it, as the one :class:`Measurement` of ``frame``; None while no ROI is
        set. ``range_m`` (from ``range_source``) is the range at the frame's time, ``cue_xy`` the
        GPS cue applied just before it (None: none); ``raw``: the running statistics of the same
        track on the raw frame, while a correction is on."""
        step = self._step(pixels)
        if step is None:
            return None
        result, state, window, reason = step
        r = self.meter.running
        return Measurement(
            camera=frame.camera,
            seq=frame.seq,
            counter=frame.counter,
            t_host_ns=frame.t_host_ns,
            result=result,
            track_state=state,
            window_xy=window,
            snr_mean=r.mean,
            snr_std=r.std,
            snr_n=r.count,
            range_m=range_m,
            range_source=range_source,
            cue_xy=cue_xy,
            raw=raw,
            track_reason=reason,
        )

    def running_figures(self, pixels: np.ndarray) -> RunningFigures | None:
        """The same measurement as :meth:`measure`, for its running statistics only (the raw
        frame's track beside a corrected one); None while no ROI is set."""
        if self._step(pixels) is None:
            return None
        r = self.meter.running
        return RunningFigures(r.mean, r.std, r.count)

    def _step(self, pixels: np.ndarray) -> tuple[PeakSnr, TrackState, tuple[int, int], str] | None:
        """One frame: (Eq. 4 result, track state, the window's centre after it, why the drone
        was not found or "")."""
        if self.roi_centre is None:
            return None
        reason = ""
        if self.tracker is not None:
            step = self.tracker.update(pixels)
            result, state, reason = step.peak_snr, step.state, step.reason
            centre = (step.window_x, step.window_y)  # the track fed the running statistics
        else:
            running = enter(EQ4)  # the stages of a live frame (snrmon.acquisition.stage_clock)
            centre = self.roi_centre
            result, state = self.meter.measure(pixels, centre), TrackState.FIXED
            enter(running)
        window = (int(centre[0]), int(centre[1]))
        self.roi_centre = window
        return result, state, window, reason
