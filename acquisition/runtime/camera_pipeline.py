"""One live camera's path: device -> ring -> the engine (every frame) -> recorder.

Threads (one producer, a bounded ring, consumers that never block it; docs/architecture.md):

- the camera device's own reader thread copies each frame into a preallocated
  :class:`snrmon.acquisition.streams.ring.FrameRing` and returns at once (the producer never waits);
- this pipeline's measurement thread pops EVERY frame from its ring reader in order and hands it
  to the session's engine (:meth:`snrmon.acquisition.engine.session_engine.SessionEngine.on_frame`:
  the same per-frame engine a replay runs), then records the frame, the commands the engine applied
  before it, and its measurement; the recorder's queue never blocks (a backlog is counted as
  frames dropped by the recorder, and the measurement of a dropped frame is kept all the same);
- a display takes only the newest frame with :meth:`CameraPipeline.latest_frame` on its own
  timer, and numbers only from :meth:`CameraPipeline.status` and :meth:`CameraPipeline.series`.

Recording gaps: before the first recorded frame after frames the file does not hold (the first
frame of a recording, or the first after a recorder drop) the engine's state is recorded, so a
replay continues there exactly as live did.

Every frame accounted for: :meth:`CameraPipeline.accounting` says what became of each frame
received (recorded, dropped and why, received while no recording was on); the recording keeps it
in its ``summary_json``. A drop is never silent: any frame lost (a gap in the camera's counter,
a ring overrun, a recorder drop) is a warning in the log (stderr and the session's log) at most
once a second per camera with the frames lost since the last one, a ``frames_dropped`` event
in the recording, and the session's status carries it as an alarm.

``lossless``: a source that can wait (a simulated camera, a file) is paced by its consumers: the
device thread waits for the ring (``OverflowPolicy.WAIT``) and the measurement thread for the
recorder's backlog (the recorder's ``backlog_wait_s``), instead of either dropping a frame.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from snrmon.acquisition.columns import values_of
from snrmon.acquisition.engine.camera_engine import CameraEngine
from snrmon.acquisition.engine.inputs import (
    ClearReference,
    ClearRoi,
    Cue,
    FrameOutput,
    SetRoi,
    StartReference,
)
from snrmon.acquisition.engine.status import CameraStatus, FrameAccounting
from snrmon.acquisition.engine.warm_up import warm_up
from snrmon.acquisition.runtime.click_news import ClickNews
from snrmon.acquisition.stage_clock import HANDOVER, RECORDING, UNKNOWN, StageClock
from snrmon.acquisition.streams.ring import RING_OVERRUN, FrameRing, OverflowPolicy, RingFrame
from snrmon.drivers.camera.frame import Frame
from snrmon.drivers.device import Device

if TYPE_CHECKING:
    from snrmon.acquisition.engine.session_engine import SessionEngine
    from snrmon.acquisition.protocols import RecordingWriter

log = logging.getLogger(__name__)

CAMERA_GAP = "camera_gap"
"""Reason for frames missing from the camera's own counter (the camera, link or grabber)."""
DROP_REPORT_S = 1.0  # a drop warning at most this often per camera


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
        self.engine: CameraEngine = engine.cameras[name]
        self.shape = self.engine.shape
        policy = OverflowPolicy.WAIT if lossless else OverflowPolicy.OVERWRITE_OLDEST
        self.ring = FrameRing(ring_capacity, *self.shape, name=name, policy=policy)
        self._reader = self.ring.reader("measurement")
        self._lock = threading.Lock()
        self._recorder: RecordingWriter | None = None
        self._gap = False  # the last frame is not in the recording: record the state next
        self._history_due = False  # the stop table's history is not in the recording yet
        self._wrong_shape = 0
        self._measured = 0
        self._unrecorded = 0  # frames measured while no recorder was attached
        self._handled = 0  # frames taken from the ring for measurement
        self._given = 0  # of them, while the current recording was attached
        self._before = 0  # frames received and done with before the recording began
        self._overrun_base = 0  # ring overruns before the recording began
        self._in_flight: RecordingWriter | None = None  # the recorder the frame in hand goes to
        self._idle = threading.Condition(self._lock)
        self._reported: dict[str, int] = {}  # drops by reason already warned about
        self._last_report = 0.0
        self._report_lock = threading.Lock()  # the measurement thread and a detach both report
        self._latency_ns: deque[int] = deque(maxlen=1000)
        # Where each frame's time goes (snrmon.acquisition.stage_clock); the grab time of the
        # frame in each ring slot, written by the device thread before it pushes the frame.
        self.stages = StageClock()
        self._grab_ns = np.full(ring_capacity, UNKNOWN, np.int64)
        self.click_news = ClickNews()  # what became of the operator's click, for the console
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._unsubscribe: Callable[[], None] | None = None
        self._warm_s: float | None = None

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
        measurement thread, before the first frame it records: every frame measured before that
        one is in them, none after)."""
        overruns = self._reader.overruns
        with self._lock:
            self._recorder = recorder
            self._gap = True
            self._history_due = True
            self._given = 0
            self._before = self._handled + overruns
            self._overrun_base = overruns
        with self._report_lock:  # a new recorder counts its drops from 0
            self._reported = {
                k: v for k, v in self._reported.items() if k in (CAMERA_GAP, RING_OVERRUN)
            }

    def detach_recorder(self) -> dict:
        """Stop recording this camera; its :meth:`accounting` at that moment (for the
        recording's summary)."""
        with self._lock:
            rec, due = self._recorder, self._history_due
            self._recorder, self._history_due = None, False
            # The frame in hand still goes to this recorder: wait for it, so the accounting
            # below holds every frame given to the recorder.
            deadline = time.monotonic() + 10.0
            while rec is not None and self._in_flight is rec and time.monotonic() < deadline:
                self._idle.wait(0.1)
        if rec is not None and due:  # no frame came while recording: the history all the same
            self._record_history(rec)
        if rec is not None:
            self.report_drops(rec, final=True)
        return self.accounting(rec)

    def drops(self, rec: RecordingWriter | None = None) -> dict[str, int]:
        """Frames lost so far by reason: ``camera_gap`` (the camera's counter), ``ring_overrun``
        (the measurement fell a whole ring behind) and the recorder's (``recorder_backlog``,
        ``recording_stopped``) where it is recording (or ``rec``, the recorder it recorded to)."""
        out = {CAMERA_GAP: int(self.device.status().dropped)}
        out[RING_OVERRUN] = int(self._reader.overruns)
        rec = rec or self._recorder
        if rec is not None:
            out.update(rec.frames_of(self.name)[2])
        return out

    def accounting(self, rec: RecordingWriter | None = None) -> dict:
        """What became of every frame received since the pipeline started, for the recording
        ``rec`` (default: the one attached now): ``received = written + sum(dropped) +
        before_recording + after_recording + queued``. ``dropped`` by reason: ``ring_overrun``
        while recording, and the recorder's own; ``before_recording`` counts every frame received
        and done with before the recording began (measured, or lost to the ring), ``queued`` those
        still waiting for the measurement. ``camera_gap``: frames the camera never delivered
        (missing from its counter), so not received."""
        rec = rec or self._recorder
        overruns = self._reader.overruns
        received, queued = self.ring.pushed, self._reader.lag
        with self._lock:
            handled, given, before, base = (
                self._handled,
                self._given,
                self._before,
                self._overrun_base,
            )
        if rec is None:  # no recording: every frame received was received while not recording
            return {
                "received": int(received),
                "written": 0,
                "dropped": {RING_OVERRUN: int(overruns)},
                "before_recording": int(handled),
                "after_recording": 0,
                "queued": int(queued),
                "camera_gap": int(self.device.status().dropped),
            }
        _, written, rec_drops = rec.frames_of(self.name)
        return {
            "received": int(received),
            "written": int(written),
            "dropped": {RING_OVERRUN: int(overruns - base), **rec_drops},
            "before_recording": int(before),
            # measured after this recording was detached (a session that goes on)
            "after_recording": int(handled + overruns - before - given - (overruns - base)),
            "queued": int(queued),
            "camera_gap": int(self.device.status().dropped),
        }

    def report_drops(self, rec: RecordingWriter | None = None, *, final: bool = False) -> None:
        """Warn (once a second at most, or now when ``final``) about frames lost since the last
        warning, and record a ``frames_dropped`` event while recording."""
        now = time.monotonic()
        if not final and now - self._last_report < DROP_REPORT_S:
            return
        with self._report_lock:
            self._last_report = now
            totals = self.drops(rec)
            new = {k: v - self._reported.get(k, 0) for k, v in totals.items()}
            new = {k: v for k, v in new.items() if v > 0}
            if not new:
                return
            self._reported = totals
        log.warning(
            "%s: %d frames dropped (%s); %d in all since the start",
            self.name,
            sum(new.values()),
            ", ".join(f"{k} {v}" for k, v in sorted(new.items())),
            sum(totals.values()),
        )
        rec = rec or self._recorder
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
        dev = self.device.status()
        ring = self.ring.stats()
        reader = self._reader.stats()
        with self._lock:
            lat = np.array(self._latency_ns, dtype=float)
            rec = self._recorder
            measured = self._measured
        recorded = dropped_rec = 0
        if rec is not None:
            st = rec.status()
            recorded = int(st.frames_written.get(self.name, 0))
            dropped_rec = int(sum(st.dropped.get(self.name, {}).values()))
        with self._lock:
            unrecorded = self._unrecorded
        frames = FrameAccounting(
            received=ring.pushed,
            measured=measured,
            recorded=recorded,
            dropped_by_camera=dev.dropped,
            dropped_by_ring=reader.overruns,
            dropped_by_recorder=dropped_rec,
            before_recording=unrecorded,
        )
        fps = getattr(self.device, "measured_fps", None)
        fps = fps() if callable(fps) else 0.0
        p50, p99 = (np.percentile(lat, [50, 99]) / 1e6) if lat.size else (np.nan, np.nan)
        return self.engine.status(
            device=dev, frames=frames, fps=float(fps or 0.0), latency_ms=(float(p50), float(p99))
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
        t_write = frame.meta.get("t_write_ns")
        grab = frame.t_host_ns - t_write if isinstance(t_write, int) else UNKNOWN
        self._grab_ns[self.ring.pushed % len(self._grab_ns)] = grab  # the slot it goes to
        self.ring.push(frame)

    def _run(self) -> None:
        self.stages.attach()
        try:
            self._measure_all()
        finally:
            self.stages.detach()

    def _measure_all(self) -> None:
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
            finally:
                with self._lock:
                    self._in_flight = None
                    self._idle.notify_all()

    def _process(self, item: RingFrame) -> None:
        clock = self.stages
        grab = int(self._grab_ns[item.seq % len(self._grab_ns)])
        clock.begin(item.t_host_ns, item.t_ring_ns, grab)
        clock.enter(RECORDING)
        with self._lock:
            rec, history, self._history_due = self._recorder, self._history_due, False
            self._handled += 1
            if rec is None:
                self._unrecorded += 1
            else:
                self._given += 1
                self._in_flight = rec
        if rec is not None and history:
            self._record_history(rec)
        index = None
        if rec is not None:
            index = rec.add_frame(self.name, item)
            with self._lock:
                resume, self._gap = (self._gap and index is not None), index is None
            if resume:
                self._record_resume(rec, item)
        out = self.session_engine.on_frame(
            self.name, item.pixels, seq=item.seq, counter=item.counter, t_host_ns=item.t_host_ns
        )
        clock.enter(HANDOVER)
        self.click_news.frame(out.applied, out.measurement)
        if rec is not None:
            clock.enter(RECORDING)
            self._record(rec, index, item, out)
        latency = clock.end()
        with self._lock:
            self._latency_ns.append(latency)
            self._measured += 1
        self.report_drops(rec)

    def _record_history(self, rec: RecordingWriter) -> None:
        """The measurements a stop begun before the recording would be summarised from: rows
        without frames, so a replay builds the same stop table. Taken on the measurement thread
        (or once it has stopped), so exactly the frames measured before the first recorded one."""
        for t, r in self.session_engine.stop_table.history(self.name):
            rec.add_measurement(self.name, -1, counter=-1, t_host_ns=t, **values_of(r))

    def _record_resume(self, rec: RecordingWriter, item: RingFrame) -> None:
        """The first recorded frame after frames the file does not hold: the engine's state and
        the background reference in force, so a replay continues from here exactly."""
        corrector = self.engine.corrector
        if corrector.reference_offset is not None and corrector.reference_summary is not None:
            summary = {**corrector.reference_summary, "in_force": True}
            rec.add_reference(
                self.name, corrector.reference_offset, summary, t_host_ns=item.t_host_ns
            )
        rec.add_state(self.name, item.counter, item.t_host_ns, self.engine.snapshot())

    def _record(
        self, rec: RecordingWriter, index: int | None, item: RingFrame, out: FrameOutput
    ) -> None:
        for c in out.applied:
            # At the frame they took effect on, so a replay applies them there too.
            if isinstance(c, SetRoi):
                payload = {"x": c.x, "y": c.y, "counter": item.counter}
                rec.add_event(
                    "roi_set", camera=self.name, payload=payload, t_host_ns=item.t_host_ns
                )
            elif isinstance(c, ClearRoi | ClearReference | StartReference):
                kind = {
                    ClearRoi: "roi_cleared",
                    ClearReference: "reference_cleared",
                    StartReference: "reference_started",
                }[type(c)]
                rec.add_event(
                    kind,
                    camera=self.name,
                    payload={"counter": item.counter},
                    t_host_ns=item.t_host_ns,
                )
        if out.reference_done is not None:
            rec.add_reference(
                self.name,
                out.reference_done.offset,
                out.reference_done.summary,
                t_host_ns=item.t_host_ns,
            )
        if out.measurement is not None:
            rec.add_measured(self.name, index, out.measurement)
