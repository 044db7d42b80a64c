"""The one per-frame engine of a camera: live, the console's replay and batch replay all run it.

Per frame (:meth:`CameraEngine.process`), in this order:

1. the commands posted since the last frame are applied in the order posted, except that a GPS
   cue is applied last, to the track of this frame's click if there is one (ROI, background
   reference, restore of a recorded state, GPS cue), and returned so the caller can record them
   at this frame;
2. a background reference capture in progress is fed
   (:class:`snrmon.acquisition.engine.frame_correction.FrameCorrector`);
3. Eq. (4) with the tracker on the corrected window
   (:class:`snrmon.acquisition.engine.frame_measurer.FrameMeasurer`) and, while a correction is on,
   the same track on the raw frame (the console reports the SNR with and without it, section 6);
4. the section 6 noise figures of the raw pixels around the track
   (:class:`snrmon.acquisition.measure.track_noise.TrackNoise`, a few times a second, and the 3D
   noise of the background clear of it over blocks of 100 frames) and, with a
   radiometric calibration, the apparent sky temperature of the background (sections 8-9);
5. the range at the frame's time, the :class:`~snrmon.acquisition.engine.inputs.Measurement`, the
   chart series and the published status.

Threads: one thread (a live camera's measurement thread, or a replay worker) owns an engine and
calls :meth:`process`; :meth:`post` may be called from any thread; :meth:`status`, :meth:`series`
and :meth:`figures` read only whole values the owner publishes under a lock.

Replay across a recording gap: the live engine records :meth:`snapshot` (JSON-able, exact) before
the first recorded frame after frames it measured but the recorder dropped; the replay posts
:class:`~snrmon.acquisition.engine.inputs.Restore` before that frame and so continues exactly as
live. Frame gaps: the frames elapsed since the last processed frame come from the camera's counter
(more than 1 after camera or ring drops; a counter that repeats, restarts or goes backwards
counts as 1) and are told to the trackers before the frame is read
(:meth:`snrmon.acquisition.track.tracker.Tracker.skip`). The last counter is part of the snapshot,
so a replay, which feeds the recorded counters, sees the same gaps.
The noise and sky figures are not part of the snapshot (they are figures, not measurements):
after a gap they restart from the frames at hand.
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from snrmon.acquisition.engine.frame_correction import FrameCorrector
from snrmon.acquisition.engine.frame_measurer import FrameMeasurer, crop_half_px
from snrmon.acquisition.engine.inputs import (
    ApplyReference,
    ClearReference,
    ClearRoi,
    Command,
    Cue,
    FrameOutput,
    Measurement,
    ReferenceDone,
    Restore,
    SetRoi,
    StartReference,
)
from snrmon.acquisition.engine.lazy_frame import LazyFrame, plain
from snrmon.acquisition.engine.status import (
    AnalysisFigures,
    CameraStatus,
    FrameAccounting,
    ModelAtRange,
    RunningStatistics,
)
from snrmon.acquisition.measure.model_agreement import model_agreement
from snrmon.acquisition.measure.peak_snr import PeakSnrConfig
from snrmon.acquisition.measure.track_noise import TrackNoise
from snrmon.acquisition.stage_clock import CORRECTION, HANDOVER, STATISTICS, TRACKING, enter
from snrmon.acquisition.stops.detector import mean_error
from snrmon.acquisition.stops.table import StopProgress, expected_eq4_rule
from snrmon.acquisition.streams.ring import RingFrame
from snrmon.acquisition.track.config import TrackState
from snrmon.acquisition.track.tracker import TrackerConfig

if TYPE_CHECKING:
    from snrmon.acquisition.calibrate.sky_temperature import SkyTemperature
    from snrmon.acquisition.prediction import Predictor
from snrmon.drivers.device import DeviceState, DeviceStatus

log = logging.getLogger(__name__)

SKY_FRAMES = 100  # the sky temperature shown: the mean over the last 100 frames, like the SNR
SNAPSHOT_VERSION = 1
NAN = math.nan

RangeLookup = Callable[[int], tuple[float | None, str]]
"""``range_at(t_host_ns) -> (range_m or None, source)``: the session's range for a frame time."""


class CameraEngine:
    """The per-frame processing of one camera (module docstring).

    Args:
        name: the camera's name ("mwir", "lwir").
        shape: (rows, columns) of its frames.
        config: the Eq. (4) settings.
        window: frames in the running statistics (the paper's 100).
        track: follow the drone from the click; False keeps the window where it was put.
        tracker_config: the tracker's own numbers (its Eq. 4 settings are ``config``).
        series_length: per-frame rows kept for the strip charts.
    """

    def __init__(
        self,
        name: str,
        shape: tuple[int, int],
        config: PeakSnrConfig | None = None,
        *,
        window: int = 100,
        track: bool = True,
        tracker_config: TrackerConfig | None = None,
        series_length: int = 2000,
    ) -> None:
        self.name = name
        self.shape = (int(shape[0]), int(shape[1]))
        self.measurer = FrameMeasurer(
            config, window=window, track=track, tracker_config=tracker_config
        )
        self.raw_measurer = FrameMeasurer(
            config, window=window, track=track, tracker_config=tracker_config
        )
        cfg = self.config
        half = crop_half_px(cfg, self.measurer.tracker_config)  # lazy: frame_correction.py
        self.corrector = FrameCorrector(self.shape, half, lazy=cfg.background is None)
        self.noise = self._track_noise(cfg)
        self.sky: SkyTemperature | None = None  # with a calibration
        # The model the status reads its prediction at the last range from (the session's).
        self.predictor: Predictor | None = None
        # The latest stop's progress for this camera, for the status (the session's stop table).
        self.stop_progress: Callable[[], StopProgress | None] | None = None
        self._lock = threading.Lock()  # the inbox's
        self._inbox: list[Command] = []
        self._shown = Published(series_length)  # what readers on other threads see
        self._last_counter: int | None = None  # of the last frame process() was given
        # Tell the tracker about frames dropped before measurement (off to replay a session
        # recorded before it was told: format 2.0).
        self.tell_gaps = True
        # Figures only a display shows, off in a batch replay: the raw-SNR track beside a
        # corrected one (the console, the HIL's FPN check; half a frame's work), the noise, the
        # running window's values the status takes the error of the mean from.
        self.display_figures = True

    def _track_noise(self, cfg: PeakSnrConfig) -> TrackNoise:
        try:
            return TrackNoise(
                self.shape,
                box_px=cfg.box_px,
                background=cfg.background,
                detrend=cfg.detrend,
                ddof=cfg.ddof,
            )
        except ValueError as exc:  # a rectangle off this image: noise around the track instead
            log.warning("%s: clear-sky rectangle not used for the noise: %s", self.name, exc)
            return TrackNoise(self.shape, box_px=cfg.box_px, detrend=cfg.detrend, ddof=cfg.ddof)

    # ------------------------------------------------------------------ commands (any thread)
    def post(self, command: Command) -> None:
        """Queue a command for the next frame. An ROI off the image is refused here, at once."""
        if isinstance(command, SetRoi):
            h, w = self.shape
            if not (0 <= command.x < w and 0 <= command.y < h):
                raise ValueError(
                    f"ROI ({command.x}, {command.y}) is outside the {self.name} image ({w} x {h})"
                )
        if isinstance(command, StartReference) and int(command.n_frames) < 2:
            raise ValueError(
                f"a background reference needs at least 2 frames, got {command.n_frames}"
            )
        with self._lock:
            if isinstance(command, Cue):
                # Only the newest position matters: one cue per frame at most.
                self._inbox = [c for c in self._inbox if not isinstance(c, Cue)]
            self._inbox.append(command)
        if isinstance(command, Cue):
            self._shown.show_gps(command.x, command.y)

    def show_gps(self, x: float, y: float) -> None:
        """Where the drone's GPS position falls in this camera, for the display only (a replay
        that applies the recorded cues still shows every fix)."""
        self._shown.show_gps(float(x), float(y))

    def set_calibration(self, calibration) -> None:
        """Correct the measured window with a radiometric calibration and follow the apparent
        sky temperature of the background pixels
        (:class:`snrmon.acquisition.calibrate.calibration.Calibration`). Call before the first
        frame."""
        from snrmon.acquisition.calibrate.sky_temperature import SkyTemperature

        self.corrector.calibration = calibration
        self.sky = SkyTemperature(self.name, calibration, box_px=self.config.box_px, maxlen=600)

    def apparent_temp_k(self, x: int, y: int, dn: float) -> float | None:
        """The apparent (brightness) temperature of raw value ``dn`` at pixel (x, y) by the
        camera's radiometric calibration (its two-point map at that pixel, then the band's
        Planck inversion); None without a calibration."""
        calibration = self.corrector.calibration
        if calibration is None:
            return None
        rows, cols = calibration.offset_dn.shape
        if not (0 <= y < rows and 0 <= x < cols):
            return None
        return float(calibration.pixels_temperature_k([dn], [y], [x])[0])

    # ------------------------------------------------------------------ per frame (owner)
    def process(self, frame: RingFrame, range_at: RangeLookup | None = None) -> FrameOutput:
        """Apply the pending commands, then analyse one raw frame of this camera as the ring
        gave it (``range_at``: the range at its time; None: no range)."""
        if frame.camera != self.name:
            raise ValueError(f"a frame of camera {frame.camera!r} given to {self.name!r}'s engine")
        enter(TRACKING)  # the stages of a live frame (snrmon.acquisition.stage_clock)
        pixels, counter, t_host_ns = frame.pixels, frame.counter, frame.t_host_ns
        applied = self._apply_commands()  # a Restore sets _last_counter as it was live
        last, self._last_counter = self._last_counter, int(counter)
        if self.tell_gaps and last is not None and counter > last + 1:  # frames dropped between
            self.measurer.skip(counter - last - 1)
            if self._raw_track:  # the raw track runs only while a correction is on
                self.raw_measurer.skip(counter - last - 1)
        cue = next((c for c in applied if isinstance(c, Cue)), None)
        done = self._feed_reference(pixels, counter)
        range_m, source = (None, "")
        if self.measurer.roi_centre is not None and range_at is not None:
            range_m, source = range_at(t_host_ns)
        enter(TRACKING)
        raw = self.raw_measurer.running_figures(pixels) if self._raw_track else None
        enter(CORRECTION)
        corrected = self.corrector.apply(pixels, self.measurer.read_xy)
        enter(TRACKING)
        m = self.measurer.measure(
            corrected,
            frame,
            range_m=range_m,
            range_source=source,
            cue_xy=None if cue is None else (cue.x, cue.y),
            raw=raw,
        )
        enter(STATISTICS)
        peak_xy = None if m is None else (m.result.peak_x, m.result.peak_y)
        if self.display_figures:  # raw pixels (the camera's own FPN), a band of the frame
            self.noise.update(plain(pixels), t_host_ns, peak_xy)
        if m is not None and self.sky is not None:
            if type(pixels) is LazyFrame:  # compiled code reads the region: made first
                pixels = plain(pixels, self.sky.box(m.result))
            self.sky.add(t_host_ns, pixels, m.result)
        enter(HANDOVER)
        if m is None:
            self._shown.unmeasured()
            return FrameOutput(frame, None, applied, done)
        window = self.measurer.meter.running.values() if self.display_figures else None
        self._shown.publish(m, window)
        return FrameOutput(frame, m, applied, done)

    def _feed_reference(self, pixels: np.ndarray, counter: int) -> ReferenceDone | None:
        """A background reference capture in progress takes the frame; the reference when it
        completes on it (the raw track starts there), else None."""
        corrector = self.corrector
        if not corrector.capturing:
            return None
        enter(CORRECTION)
        summary = corrector.feed(pixels, counter)
        if summary is None or corrector.reference_offset is None:
            return None
        self._raw_track_from_here()
        return ReferenceDone(corrector.reference_offset, summary)

    def publish_recorded(self, m: Measurement) -> None:
        """A frame measured live but missing from the recording: its recorded measurement is
        shown (status, series) as it was; nothing is re-measured. The last counter stays that
        of the last frame this engine's trackers saw: an exact replay restores the live one (the
        state recorded before the next recorded frame holds it)."""
        self._shown.publish(m, None)  # its running window's values are not recorded

    def _apply_commands(self) -> tuple[Command, ...]:
        with self._lock:
            commands, self._inbox = self._inbox, []
        # A GPS cue goes to the track in force after this frame's click, however the two
        # threads' posts interleaved (a click makes a new tracker; a cue applied before it would
        # be lost live, but kept by a replay that posts the recorded click first).
        commands.sort(key=lambda c: isinstance(c, Cue))
        for c in commands:
            if isinstance(c, SetRoi):
                self.measurer.set_roi(c.x, c.y)
                self.raw_measurer.set_roi(c.x, c.y)
            elif isinstance(c, ClearRoi):
                self.measurer.clear_roi()
                self.raw_measurer.clear_roi()
            elif isinstance(c, Cue):
                self.measurer.cue(c.x, c.y)
                self.raw_measurer.cue(c.x, c.y)
            elif isinstance(c, StartReference):
                self.corrector.start_reference(c.n_frames)
            elif isinstance(c, ClearReference):
                self.corrector.clear_reference()
            elif isinstance(c, ApplyReference):
                self.corrector.set_reference_offset(c.offset, c.summary)
                if c.restart_raw:
                    self._raw_track_from_here()
            elif isinstance(c, Restore):
                self.restore(c.state)
        return tuple(commands)

    def _raw_track_from_here(self) -> None:
        # The raw track starts where the corrected track is when the correction begins.
        if self.measurer.roi_centre is not None:
            self.raw_measurer.set_roi(*self.measurer.roi_centre)

    # ------------------------------------------------------------------ state (owner)
    @property
    def _raw_track(self) -> bool:
        return self.display_figures and self.corrector.active

    def snapshot(self) -> dict:
        """The measurement state that carries over from frame to frame, exactly (JSON-able)."""
        return {
            "version": SNAPSHOT_VERSION,
            "measurer": self.measurer.snapshot(),
            "raw_measurer": self.raw_measurer.snapshot(),
            "last_counter": self._last_counter,
        }

    def restore(self, state: dict) -> None:
        if state.get("version") != SNAPSHOT_VERSION:
            raise ValueError(
                f"{self.name}: engine state version {state.get('version')!r} is not "
                f"{SNAPSHOT_VERSION}"
            )
        self.measurer.restore(state["measurer"])
        self.raw_measurer.restore(state["raw_measurer"])
        last = state.get("last_counter")  # None in states recorded before gaps were told
        self._last_counter = None if last is None else int(last)

    # ------------------------------------------------------------------ reading (any thread)
    @property
    def config(self) -> PeakSnrConfig:
        """The Eq. (4) settings (the measurer's)."""
        return self.measurer.meter.config

    @property
    def roi_centre(self) -> tuple[int, int] | None:
        """The search window's centre after the last frame (None: not measuring)."""
        return self._shown.roi_centre

    @property
    def track_state(self) -> TrackState:
        return self._shown.track_state

    def series(self) -> np.ndarray:
        """The recent per-frame record for charts: rows of (t_host_ns, snr, running mean,
        running std, range_m or NaN)."""
        return self._shown.series()

    def figures(self) -> AnalysisFigures:
        total, temporal, spatial = self.noise.figures()
        sky = self.sky.mean_temp_k(last=SKY_FRAMES) if self.sky is not None else NAN
        c = self.corrector
        return AnalysisFigures(
            c.reference_frames,
            c.fixed_pattern_dn,
            sky,
            total,
            temporal,
            spatial,
            self.noise.cube.latest,
        )

    def statistics(self) -> RunningStatistics:
        """The statistics of the status over the frames measured so far (the running window's
        error of the mean, the figures, the stop's progress): the work of a status, for the
        thread that measures the frames to take (:class:`RunningStatistics`). The latency is
        the frames' mover's to add."""
        window = self._shown.now()[5]
        return RunningStatistics(
            # the error of the mean of the window the running mean was taken over
            mean_error(window) if window is not None else NAN,
            self.figures(),
            self.stop_progress() if self.stop_progress is not None else None,
        )

    def status(self, statistics: RunningStatistics | None = None) -> CameraStatus:
        """The camera's status as the engine knows it: the track, its last measured frame, the
        model there and the figures; its statistics those given (taken on the measuring
        thread a moment before, :meth:`statistics`), else taken now. What only the frames'
        mover knows (the device's health, the frame accounting, the frame rate, the latency)
        it puts in (:meth:`CameraStatus.with_frames`); until then the device is streaming and
        every frame measured is one received while not recording."""
        last, roi, state, gps_xy, measured, _window = self._shown.now()
        stats = statistics if statistics is not None else self.statistics()
        device = DeviceStatus(self.name, DeviceState.STREAMING, readings=measured)
        frames = FrameAccounting(received=measured, before_recording=measured)
        model = self._model_at(last)
        predictor = self.predictor
        psf_source = (
            predictor.curves_psf_source.get(self.name) if predictor is not None and model else None
        )
        agreement = None
        rule = expected_eq4_rule(last.result.background) if last is not None else None
        if last is not None and model and rule is not None:
            # the reading of the rule this frame's background makes applicable (the paper's
            # 7x7 rim, or the console's rim outside the drone's extent)
            agreement = model_agreement(last.snr_mean, stats.snr_sem, model, f"expected_eq4_{rule}")
        return CameraStatus(
            name=self.name,
            device=device,
            frames=frames,
            roi_xy=roi,
            gps_xy=gps_xy,
            track_state=state,
            last=last,
            model=ModelAtRange(model, psf_source, agreement),
            figures=stats.figures,
            latency=stats.latency,
            snr_sem=stats.snr_sem,
            stop=stats.stop,
        )

    def _model_at(self, last: Measurement | None) -> dict[str, float]:
        predictor = self.predictor
        if predictor is None or last is None or last.range_m is None:
            return {}
        return predictor(self.name, last.range_m)


class Published:
    """What a camera's engine publishes after each frame, for readers on any thread (the
    status, the charts): the last measurement and its running window's values, the track's
    state and window centre, the GPS position shown, the frames processed, and the strip
    chart's rows in a ring of preallocated rows (a row written per frame, two slices copied when
    the console asks: a list of tuples made into an array cost the GUI thread ~0.5 ms at each
    status refresh). Written by the engine's owner, read whole under one lock."""

    def __init__(self, series_length: int) -> None:
        self._lock = threading.Lock()
        self._last: Measurement | None = None
        self._window: np.ndarray | None = None  # the running window's values after _last
        self._state = TrackState.IDLE
        self._roi_centre: tuple[int, int] | None = None
        self._gps_xy: tuple[float, float] | None = None
        self._measured = 0  # frames processed (measured or not)
        self._series = np.empty((series_length, 5))
        self._series_rows = 0  # rows ever written

    def show_gps(self, x: float, y: float) -> None:
        with self._lock:
            self._gps_xy = (x, y)

    def unmeasured(self) -> None:
        """A frame processed without an ROI: not measuring."""
        with self._lock:
            self._measured += 1
            self._roi_centre, self._state = None, TrackState.IDLE

    def publish(self, m: Measurement, window: np.ndarray | None) -> None:
        rng = NAN if m.range_m is None else m.range_m
        with self._lock:
            self._measured += 1
            self._last = m
            self._window = window
            self._state = m.track_state
            self._roi_centre = m.window_xy
            row = self._series[self._series_rows % len(self._series)]
            row[:] = (m.t_host_ns, m.result.snr, m.snr_mean, m.snr_std, rng)
            self._series_rows += 1

    def now(
        self,
    ) -> tuple[
        Measurement | None,
        tuple[int, int] | None,
        TrackState,
        tuple[float, float] | None,
        int,
        np.ndarray | None,
    ]:
        """(last measurement, window centre, track state, GPS position, frames processed, the
        running window's values), as one."""
        with self._lock:
            return (
                self._last,
                self._roi_centre,
                self._state,
                self._gps_xy,
                self._measured,
                self._window,
            )

    @property
    def roi_centre(self) -> tuple[int, int] | None:
        with self._lock:
            return self._roi_centre

    @property
    def track_state(self) -> TrackState:
        with self._lock:
            return self._state

    def series(self) -> np.ndarray:
        with self._lock:
            n, ring = self._series_rows, self._series
            if n <= len(ring):
                return ring[:n].copy()
            k = n % len(ring)  # the oldest row kept
            return np.concatenate([ring[k:], ring[:k]])
