"""One live camera's path: device -> ring -> the engine (every frame) -> recorder.

Threads (one producer, a bounded ring, consumers that never block it; docs/architecture.md):

- the camera device's own reader thread copies each frame into a preallocated
  :class:`snrmon.acquisition.streams.ring.FrameRing` and returns at once (the producer never waits);
- this pipeline's measurement thread
  (:class:`~snrmon.acquisition.runtime.measurement_thread.MeasurementThread`) pops EVERY frame
  from its ring reader in order and hands it,
  as the ring gave it, to the session's engine
  (:meth:`snrmon.acquisition.engine.session_engine.SessionEngine.on_frame`: the same per-frame
  engine a replay runs), which returns the frame's
  :class:`~snrmon.acquisition.engine.inputs.FrameOutput`; the pipeline hands that to its
  subscribers: the recording (:class:`snrmon.acquisition.runtime.recording_tap.RecordingTap`,
  whose queue never blocks: a backlog is counted as frames dropped by the recorder, and the
  measurement of a dropped frame is kept all the same) and the click's news; the stop table and
  the measurement listeners are the engine's own;
- a display takes only the newest frame with :meth:`CameraPipeline.latest_frame` on its own
  timer, and numbers only from :meth:`CameraPipeline.status` and :meth:`CameraPipeline.series`.

Every frame accounted for: :meth:`CameraPipeline.accounting` says what became of each frame
received (:class:`~snrmon.acquisition.engine.status.FrameAccounting`: recorded, dropped and why,
received while no recording was on, of the wrong shape); the status carries it and the
recording keeps it in its ``summary_json``. A drop is never silent: any frame lost (a gap in the
camera's counter, a ring overrun, a frame of the wrong shape, a recorder drop) is a warning in
the log (stderr and the session's log) at most once a second per camera with the frames lost
since the last one, a ``frames_dropped`` event in the recording, and the session's status
carries it as an alarm.

``lossless``: a source that can wait (a simulated camera, a file) is paced by its consumers: the
device thread waits for the ring (``OverflowPolicy.WAIT``) and the measurement thread for the
recorder's backlog (the recorder's ``backlog_wait_s``), instead of either dropping a frame.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from snrmon.acquisition.engine.camera_engine import CameraEngine
from snrmon.acquisition.engine.inputs import (
    ClearReference,
    ClearRoi,
    Cue,
    SetRoi,
    StartReference,
)
from snrmon.acquisition.engine.status import (
    CameraStatus,
    FrameAccounting,
    Latency,
    RunningStatistics,
)
from snrmon.acquisition.engine.warm_up import warm_up
from snrmon.acquisition.runtime.click_news import ClickNews
from snrmon.acquisition.runtime.frame_tally import DropWarnings, FrameTally
from snrmon.acquisition.runtime.measurement_thread import MeasurementThread
from snrmon.acquisition.runtime.recording_tap import RecordingTap
from snrmon.acquisition.stage_clock import HANDOVER, RECORDING, UNKNOWN, StageClock
from snrmon.acquisition.streams.delivered_rate import DeliveredRate
from snrmon.acquisition.streams.ring import RING_OVERRUN, FrameRing, OverflowPolicy, RingFrame
from snrmon.drivers.camera.frame import Frame
from snrmon.drivers.device import Device

if TYPE_CHECKING:
    from snrmon.acquisition.engine.session_engine import SessionEngine
    from snrmon.acquisition.protocols import RecordingWriter

log = logging.getLogger(__name__)

CAMERA_GAP = "camera_gap"
"""Reason for frames missing from the camera's own counter (the camera, link or grabber)."""
WRONG_SHAPE = "wrong_shape"
"""Reason for frames the camera delivered at another size than its configured one."""


class CameraPipeline:
    """Acquisition, measurement and recording of one camera (no Qt).

    Args:
        name: the camera's name ("mwir", "lwir").
        device: the camera driver (any :class:`snrmon.drivers.device.Device` of :class:`Frame`).
        engine: the session's engine, which holds this camera's :class:`CameraEngine`.
        ring_capacity: frames held for the slowest consumer (default 2 s at 60 fps).
        lossless: the device waits for the measurement rather than lose a frame (module
            docstring); only for a source that can wait.
    """

    def __init__(
        self,
        name: str,
        device: Device[Frame],
        engine: SessionEngine,
        *,
        ring_capacity: int = 120,
        lossless: bool = False,
    ) -> None:
        self.name = name
        self.device = device
        self.session_engine = engine
        policy = OverflowPolicy.WAIT if lossless else OverflowPolicy.OVERWRITE_OLDEST
        self.ring = FrameRing(ring_capacity, *self.shape, name=name, policy=policy)
        self._reader = self.ring.reader("measurement")
        self.tally = FrameTally()
        self.recording = RecordingTap(
            name, self.engine, lambda: engine.stop_table.history(name), self.tally
        )
        self._warnings = DropWarnings()
        # Where each frame's time goes (snrmon.acquisition.stage_clock); the grab time of the
        # frame in each ring slot, written by the device thread before it pushes the frame.
        self.stages = StageClock()
        self._grab_ns = np.full(ring_capacity, UNKNOWN, np.int64)
        self.click_news = ClickNews()  # what became of the operator's click, for the console
        # The frames the camera delivered per second, as this pipeline takes them (the status's
        # fps: not the rate the driver was asked for).
        self.delivered = DeliveredRate()
        self.measuring = MeasurementThread(
            name,
            self._reader,
            self._process,
            self.recording.frame_done,
            self.stages,
            statistics=self._statistics,
        )
        self._unsubscribe: Callable[[], None] | None = None
        self._warm_s: float | None = None

    @property
    def engine(self) -> CameraEngine:
        """This camera's engine (the session engine's)."""
        return self.session_engine.cameras[self.name]

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns) of this camera's frames."""
        return self.engine.shape

    # ------------------------------------------------------------------ control
    def warm_up(self) -> float:
        """Load the compiled analysis (:func:`snrmon.acquisition.engine.warm_up.warm_up`; the first
        run on a machine compiles it, 15-22 s) unless done already; returns the seconds the
        first call took. :meth:`start` calls it before it opens the device; call it earlier
        where something else must not start its clock meanwhile (a simulated flight)."""
        if self._warm_s is None:
            self._warm_s = warm_up(self.engine)
            log.info("%s: compiled analysis ready in %.2f s", self.name, self._warm_s)
        return self._warm_s

    def start(self) -> None:
        """Warm up (:meth:`warm_up`), open the device and start the measurement thread."""
        self.warm_up()
        self._unsubscribe = self.device.subscribe(self._on_frame)
        self.measuring.start()
        self.device.open()

    def stop(self) -> None:
        """Close the device, then let the measurement thread drain what is in the ring."""
        self.device.close()
        if self._unsubscribe is not None:
            self._unsubscribe()
        self.measuring.stop()
        self._reader.close()

    def set_roi(self, x: int, y: int) -> None:
        """The operator's click: centre the search window at column ``x``, row ``y``. Applied
        before the next frame, so a measurement never mixes two ROIs; the running statistics
        restart (they belong to one target)."""
        self.engine.post(SetRoi(int(x), int(y)))

    def clear_roi(self) -> None:
        self.engine.post(ClearRoi())

    def cue(self, x: float, y: float) -> None:
        """A projected GPS position for the tracker to reacquire a lost target near."""
        self.engine.post(Cue(float(x), float(y)))

    def set_calibration(self, calibration) -> None:
        """Apply a radiometric calibration
        (:class:`snrmon.acquisition.calibrate.calibration.Calibration`)
        to the measured window and follow the sky temperature. Call before ``start``."""
        self.engine.set_calibration(calibration)

    def capture_reference(self, n_frames: int = 64) -> None:
        """Average the next ``n_frames`` frames (clear sky, no drone) into the background
        reference that removes the fixed-pattern noise before Eq. (4)."""
        self.engine.post(StartReference(int(n_frames)))

    def clear_reference(self) -> None:
        self.engine.post(ClearReference())

    def attach_recorder(self, recorder: RecordingWriter) -> None:
        """Record every frame from now on (and its measurement) into ``recorder``; the
        measurements the stop table keeps to seed a backdated stop go in first (on the
        measurement thread, before the first frame it records)."""
        self.recording.attach(recorder, self._reader.overruns)
        # a new recorder counts its drops from 0
        self._warnings.recorder_changed(keep=(CAMERA_GAP, RING_OVERRUN, WRONG_SHAPE))

    def detach_recorder(self) -> FrameAccounting:
        """Stop recording this camera; its :meth:`accounting` at that moment (for the
        recording's summary)."""
        rec = self.recording.detach()
        if rec is not None:
            self.report_drops(rec, final=True)
        return self.accounting(rec)

    def drops(self, rec: RecordingWriter | None = None) -> dict[str, int]:
        """Frames lost so far by reason: ``camera_gap`` (the camera's counter), ``ring_overrun``
        (the measurement fell a whole ring behind), ``wrong_shape`` and the recorder's
        (``recorder_backlog``, ``recording_stopped``) where it is recording (or ``rec``, the
        recorder it recorded to)."""
        out = {CAMERA_GAP: int(self.device.status().dropped)}
        out[RING_OVERRUN] = int(self._reader.overruns)
        out[WRONG_SHAPE] = self.tally.wrong_shape
        rec = rec or self.recording.recorder
        if rec is not None:
            out.update(rec.frames_of(self.name)[2])
        return out

    def accounting(self, rec: RecordingWriter | None = None) -> FrameAccounting:
        """What became of every frame received since the pipeline started, for the recording
        ``rec`` (default: the one attached now; none: no recording)
        (:class:`~snrmon.acquisition.engine.status.FrameAccounting`)."""
        rec = rec or self.recording.recorder
        overruns = self._reader.overruns
        pushed, lag = self.ring.pushed, self._reader.lag
        recorded = None
        if rec is not None:
            _, written, rec_drops = rec.frames_of(self.name)
            recorded = (written, rec_drops)
        return self.tally.accounting(
            pushed=pushed,
            overruns=overruns,
            lag=lag,
            camera_gap=int(self.device.status().dropped),
            recorded=recorded,
        )

    def report_drops(self, rec: RecordingWriter | None = None, *, final: bool = False) -> None:
        """Warn (once a second at most, or now when ``final``) about frames lost since the last
        warning, and record a ``frames_dropped`` event while recording."""
        if not self._warnings.due(final=final):
            return
        totals = self.drops(rec)
        new = self._warnings.new(totals)
        if new is None:
            return
        log.warning(
            "%s: %d frames dropped (%s); %d in all since the start",
            self.name,
            sum(new.values()),
            ", ".join(f"{k} {v}" for k, v in sorted(new.items())),
            sum(totals.values()),
        )
        rec = rec or self.recording.recorder
        if rec is not None:
            rec.add_event("frames_dropped", camera=self.name, payload={"new": new, "total": totals})

    @property
    def corrector(self):
        return self.engine.corrector

    @property
    def sky(self):
        """The apparent sky temperature series (with a calibration), else None."""
        return self.engine.sky

    # ------------------------------------------------------------------ reading
    def click_messages(self) -> list[str]:
        """What became of the operator's click since the last call (:class:`ClickNews`)."""
        return self.click_news.take()

    def latest_frame(
        self, *, unless_seq: int | None = None, out: np.ndarray | None = None
    ) -> RingFrame | None:
        """The newest frame (a copy, into ``out`` if given), for a display; never waits. None
        when there is none yet, or when its ``seq`` is ``unless_seq`` (shown already)."""
        return self.ring.peek_last(out, unless_seq=unless_seq)

    def apparent_temp_k(self, x: int, y: int, dn: float) -> float | None:
        """Pixel (x, y)'s raw ``dn`` as an apparent temperature (K); None uncalibrated."""
        return self.engine.apparent_temp_k(x, y, dn)

    def series(self) -> np.ndarray:
        """The recent per-frame record for charts: rows of (t_host_ns, snr, running mean,
        running std, range_m or NaN)."""
        return self.engine.series()

    def stage_times(self) -> dict:
        """Where the recent frames' time went, stage by stage
        (:meth:`snrmon.acquisition.stage_clock.StageClock.summary`)."""
        return self.stages.summary()

    def status(self) -> CameraStatus:
        """The engine's status with the device's health, the frame accounting and the frames
        delivered per second (:attr:`delivered`); its statistics (the error of the running
        mean, the figures, the stop's progress, the latency) those the measurement thread took
        last (:attr:`MeasurementThread.statistics`), so a console's status costs its thread
        no statistics."""
        return self.engine.status(self.measuring.statistics).with_frames(
            self.device.status(), self.accounting(), self.delivered.per_s()
        )

    def _statistics(self) -> RunningStatistics:
        """The status's statistics now, with the latency's median and 99th percentile (ms):
        taken on the measurement thread (:class:`MeasurementThread`)."""
        p50, p99 = self.stages.latency_ms()
        return dataclasses.replace(self.engine.statistics(), latency=Latency(p50, p99))

    # ------------------------------------------------------------------ threads
    def _on_frame(self, frame: Frame) -> None:
        # Device thread: one copy into the ring, nothing else.
        if frame.pixels.shape != self.shape:
            self.tally.wrong_shape_frame()
            log.warning(
                "%s: frame of shape %s dropped, expected %s",
                self.name,
                frame.pixels.shape,
                self.shape,
            )
            return
        t_write = frame.meta.get("t_write_ns")
        grab = frame.t_host_ns - t_write if isinstance(t_write, int) else UNKNOWN
        self._grab_ns[self.ring.pushed % len(self._grab_ns)] = grab  # the slot it goes to
        self.ring.push(frame)

    def _process(self, frame: RingFrame) -> None:
        clock = self.stages
        grab = int(self._grab_ns[frame.seq % len(self._grab_ns)])
        clock.begin(frame.t_host_ns, frame.t_ring_ns, grab)
        self.delivered.frame(frame.seq)
        clock.enter(RECORDING)
        rec, index = self.recording.frame_taken(frame)
        out = self.session_engine.on_frame(frame)
        clock.enter(HANDOVER)
        self.click_news.frame(out)
        if rec is not None:
            clock.enter(RECORDING)
            self.recording.frame_measured(rec, index, out)
        clock.end()
        self.report_drops(rec)
