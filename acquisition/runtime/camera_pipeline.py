"""One camera's path through the console: device -> ring -> measurement (every frame) -> recorder.

Threads (DESIGN "The data that flows", anchors (b) item 5):

- the camera device's own reader thread copies each frame into a preallocated
  :class:`acquisition.runtime.ring.FrameRing` and returns at once (the producer never waits);
- this pipeline's measurement thread pops EVERY frame from its ring reader in order, runs
  Eq. (4) (with the tracker once an ROI is set), folds the SNR into the 100-frame running
  statistics, and hands the frame and its measurement to the recorder's queue (which never
  blocks: a recorder backlog is counted as frames dropped by the recorder);
- a display takes only the newest frame with :meth:`CameraPipeline.latest_frame` on its own
  timer, and numbers only from :meth:`CameraPipeline.status` and :meth:`CameraPipeline.series`.

Every statistic is computed here, in the processing thread, never in a viewer.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from acquisition.engine.camera_analysis import CameraAnalysis
from acquisition.engine.frame_correction import FrameCorrector
from acquisition.engine.frame_measurer import FrameMeasurer
from acquisition.engine.status import CameraStatus, FrameAccounting
from acquisition.measure.peak_snr import PeakSnr, PeakSnrConfig
from acquisition.measure.track_noise import TrackNoise
from acquisition.runtime.ring import FrameRing, RingFrame
from acquisition.track.tracker import TrackerConfig
from drivers.camera.frame import Frame
from drivers.device import Device

log = logging.getLogger(__name__)

RangeLookup = Callable[[int], tuple[float | None, str]]
"""``range_at(t_host_ns) -> (range_m or None, source)``: the session's range for a frame time."""


@dataclass(frozen=True, slots=True)
class Measurement:
    """One measured frame as the listeners (recorder, stop table, charts) receive it."""

    camera: str
    seq: int
    counter: int
    t_host_ns: int
    result: PeakSnr
    track_state: str
    snr_mean: float
    snr_std: float
    snr_n: int
    range_m: float | None
    range_source: str
    snr_mean_raw: float = float("nan")  # the same track on raw frames, while a correction is on
    snr_std_raw: float = float("nan")


class CameraPipeline:
    """Acquisition, measurement and recording of one camera (no Qt).

    Args:
        name: the camera's name ("mwir", "lwir").
        device: the camera driver (any :class:`drivers.device.Device` of :class:`Frame`).
        shape: (rows, columns) of its frames.
        ring_capacity: frames held for the slowest consumer (default 2 s at 60 fps).
        config: the Eq. (4) settings.
        window: frames in the running statistics (the paper's 100).
        range_at: the session's range lookup for a frame's host time.
        track: follow the drone from the click with :class:`acquisition.track.tracker.Tracker`;
            False keeps the search window where the operator clicked.
        tracker_config: the tracker's gate and thresholds (its Eq. 4 settings come from
            ``config``).
    """

    def __init__(
        self,
        name: str,
        device: Device[Frame],
        shape: tuple[int, int],
        *,
        ring_capacity: int = 120,
        config: PeakSnrConfig | None = None,
        window: int = 100,
        range_at: RangeLookup | None = None,
        track: bool = True,
        tracker_config: TrackerConfig | None = None,
        series_length: int = 2000,
    ) -> None:
        self.name = name
        self.device = device
        self.shape = (int(shape[0]), int(shape[1]))
        self.ring = FrameRing(ring_capacity, *self.shape, name=name)
        self.analysis = CameraAnalysis(
            name, self.shape, config, window=window, track=track, tracker_config=tracker_config
        )
        self._reference_pending: int | None = None
        self.range_at = range_at
        self._reader = self.ring.reader("measurement")
        self._lock = threading.Lock()
        self._roi: tuple[int, int] | None = None
        self._roi_pending: tuple[int, int] | None = None
        self._clear_pending = False
        self._cue_pending: tuple[float, float] | None = None
        self._gps_xy: tuple[float, float] | None = None
        self._track_state = "idle"
        self._track_reason = ""
        self._listeners: list[Callable[[Measurement, RingFrame], None]] = []
        self._recorder = None
        self._measured = 0
        self._wrong_shape = 0
        self._last: Measurement | None = None
        self._latency_ns: deque[int] = deque(maxlen=1000)
        self._series: deque[tuple[int, float, float, float, float | None]] = deque(
            maxlen=series_length
        )
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._unsubscribe: Callable[[], None] | None = None

    @property
    def measurer(self) -> FrameMeasurer:
        return self.analysis.measurer

    @property
    def corrector(self) -> FrameCorrector:
        return self.analysis.corrector

    @property
    def noise(self) -> TrackNoise:
        return self.analysis.noise

    @property
    def sky(self):
        """The apparent sky temperature series (with a calibration), else None."""
        return self.analysis.sky

    # ------------------------------------------------------------------ control
    def start(self) -> None:
        """Open the device and start the measurement thread."""
        self._stop.clear()
        self._unsubscribe = self.device.subscribe(self._on_frame)
        self._thread = threading.Thread(target=self._run, name=f"measure-{self.name}", daemon=True)
        self._thread.start()
        self.device.open()

    def stop(self) -> None:
        """Close the device, then let the measurement thread drain what is in the ring."""
        self.device.close()
        if self._unsubscribe is not None:
            self._unsubscribe()
        self._stop.set()
        if self._thread is not None:
            self._thread.join(10.0)
        self._reader.close()

    def set_roi(self, x: int, y: int) -> None:
        """The operator's click: centre the search window at column ``x``, row ``y``.

        Applied by the measurement thread before its next frame, so a measurement never mixes
        two ROIs. The running statistics restart: they belong to one target position.
        """
        h, w = self.shape
        if not (0 <= x < w and 0 <= y < h):
            raise ValueError(f"ROI ({x}, {y}) is outside the {self.name} image ({w} x {h})")
        with self._lock:
            self._roi_pending = (int(x), int(y))

    def clear_roi(self) -> None:
        with self._lock:
            self._roi_pending = None
            self._clear_pending = True

    def cue(self, x: float, y: float) -> None:
        """A projected GPS position for the tracker to reacquire a lost target near."""
        with self._lock:
            self._cue_pending = (float(x), float(y))
            self._gps_xy = (float(x), float(y))

    def set_calibration(self, calibration) -> None:
        """Apply a radiometric calibration (:class:`acquisition.calibrate.calibration.Calibration`)
        to
        the measured window from the next frame on, and follow the apparent sky temperature
        of the background pixels (issue 9). Call before ``start``."""
        self.analysis.set_calibration(calibration)

    def capture_reference(self, n_frames: int = 64) -> None:
        """Average the next ``n_frames`` frames (clear sky, no drone) into the background
        reference that removes the fixed-pattern noise before Eq. (4)."""
        if int(n_frames) < 2:
            raise ValueError(f"a background reference needs at least 2 frames, got {n_frames}")
        with self._lock:
            self._reference_pending = int(n_frames)

    def clear_reference(self) -> None:
        with self._lock:
            self._reference_pending = 0

    def add_listener(self, callback: Callable[[Measurement, RingFrame], None]) -> None:
        """``callback(measurement, frame)`` on the measurement thread after every frame."""
        with self._lock:
            self._listeners.append(callback)

    def attach_recorder(self, recorder) -> None:
        """Record every frame from now on (and its measurement) into ``recorder``."""
        with self._lock:
            self._recorder = recorder

    def detach_recorder(self) -> None:
        with self._lock:
            self._recorder = None

    # ------------------------------------------------------------------ reading
    def latest_frame(self) -> RingFrame | None:
        """The newest frame (a copy), for a display; never waits."""
        return self.ring.peek_last()

    def series(self) -> np.ndarray:
        """The recent per-frame record for charts: rows of (t_host_ns, snr, running mean,
        running std, range_m or NaN)."""
        with self._lock:
            rows = list(self._series)
        arr = np.array(rows, dtype=float) if rows else np.empty((0, 5))
        return arr

    def status(self) -> CameraStatus:
        dev = self.device.status()
        ring = self.ring.stats()
        reader = self._reader.stats()
        with self._lock:
            last = self._last
            measured = self._measured
            roi = self._roi
            gps_xy = self._gps_xy
            state = self._track_state
            reason = self._track_reason
            lat = np.array(self._latency_ns, dtype=float)
            rec = self._recorder
        recorded = 0
        dropped_rec = 0
        if rec is not None:
            st = rec.status()
            recorded = int(st.frames_written.get(self.name, 0))
            dropped_rec = int(sum(st.dropped.get(self.name, {}).values()))
        frames = FrameAccounting(
            received=ring.pushed,
            measured=measured,
            recorded=recorded,
            dropped_by_camera=dev.dropped,
            dropped_by_ring=reader.overruns,
            dropped_by_recorder=dropped_rec,
        )
        fps = getattr(self.device, "measured_fps", None)
        fps = fps() if callable(fps) else 0.0
        p50, p99 = (np.percentile(lat, [50, 99]) / 1e6) if lat.size else (np.nan, np.nan)
        fig = self.analysis.figures()
        return CameraStatus(
            name=self.name,
            device=dev,
            frames=frames,
            fps=float(fps or 0.0),
            roi_xy=roi,
            gps_xy=gps_xy,
            track_state=state,
            track_reason=reason,
            last=last.result if last else None,
            snr_mean=last.snr_mean if last else float("nan"),
            snr_std=last.snr_std if last else float("nan"),
            snr_n=last.snr_n if last else 0,
            snr_mean_raw=last.snr_mean_raw if last else float("nan"),
            snr_std_raw=last.snr_std_raw if last else float("nan"),
            reference_frames=fig.reference_frames,
            sky_temp_k=fig.sky_temp_k,
            fixed_pattern_dn=fig.fixed_pattern_dn,
            range_m=last.range_m if last else None,
            range_source=last.range_source if last else "",
            latency_ms_p50=float(p50),
            latency_ms_p99=float(p99),
            noise_total_dn=fig.noise_total_dn,
            noise_temporal_dn=fig.noise_temporal_dn,
            noise_spatial_dn=fig.noise_spatial_dn,
        )

    # ------------------------------------------------------------------ threads
    def _on_frame(self, frame: Frame) -> None:
        # Device thread: one copy into the ring, nothing else.
        if frame.pixels.shape != self.shape:
            with self._lock:
                self._wrong_shape += 1
            log.warning(
                "%s: frame of shape %s dropped, expected %s",
                self.name,
                frame.pixels.shape,
                self.shape,
            )
            return
        self.ring.push(frame)

    def _run(self) -> None:
        while True:
            item = self._reader.pop_next(timeout=0.1)
            if item is None:
                if self._stop.is_set() and self._reader.lag == 0:
                    return
                continue
            try:
                self._process(item)
            except Exception:  # a measurement bug must not stop acquisition
                log.exception("%s: measurement failed on frame %d", self.name, item.counter)

    def _process(self, item: RingFrame) -> None:
        with self._lock:
            pending, self._roi_pending = self._roi_pending, None
            if pending is not None:
                # The click is in force from this frame on, before its (slower) measurement: a
                # recording started meanwhile records it as resumed.
                self._roi = pending
            clear, self._clear_pending = self._clear_pending, False
            cue, self._cue_pending = self._cue_pending, None
            reference, self._reference_pending = self._reference_pending, None
            recorder = self._recorder
            listeners = list(self._listeners)
        analysis = self.analysis
        if reference == 0:
            analysis.clear_reference()
        elif reference is not None:
            analysis.start_reference(reference)
        if clear:
            analysis.clear_roi()
        if pending is not None:
            analysis.set_roi(*pending)
            if recorder is not None:
                # Recorded at the frame it took effect on, so a replay applies it there too.
                recorder.add_event(
                    "roi_set",
                    camera=self.name,
                    payload={"x": pending[0], "y": pending[1], "counter": item.counter},
                    t_host_ns=item.t_host_ns,
                )
        if cue is not None:
            analysis.cue(*cue)
        index = recorder.add_frame(self.name, item) if recorder is not None else None
        out = analysis.analyze(item.pixels, item.counter, item.t_host_ns)
        if out.reference_done is not None and recorder is not None:
            recorder.add_event(
                "background_reference",
                camera=self.name,
                payload=out.reference_done,
                t_host_ns=item.t_host_ns,
            )
        fr = out.result
        if fr is None:
            with self._lock:
                self._measured += 1
                self._roi = None
                self._track_state = "idle"
                self._track_reason = ""
            return
        range_m, source = self.range_at(item.t_host_ns) if self.range_at else (None, "")
        m = Measurement(
            self.name,
            item.seq,
            item.counter,
            item.t_host_ns,
            fr.result,
            fr.state,
            fr.snr_mean,
            fr.snr_std,
            fr.snr_n,
            range_m,
            source,
            out.snr_mean_raw,
            out.snr_std_raw,
        )
        if recorder is not None:
            recorder.add_peak_snr(self.name, index, item.counter, item.t_host_ns, fr.result)
        latency = time.monotonic_ns() - item.t_host_ns
        with self._lock:
            self._measured += 1
            self._last = m
            self._track_state = fr.state
            self._track_reason = fr.reason
            self._roi = fr.window_xy
            self._latency_ns.append(latency)
            rng = np.nan if range_m is None else range_m
            self._series.append((item.t_host_ns, fr.result.snr, fr.snr_mean, fr.snr_std, rng))
        for cb in listeners:
            try:
                cb(m, item)
            except Exception:
                log.exception("%s: measurement listener failed", self.name)
