"""What one live camera hands its recording, frame by frame: the subscriber of the pipeline that
writes (through :class:`snrmon.acquisition.protocols.RecordingWriter`) the frame, the commands the
engine applied before it, a background reference completed on it, and its measurement.

Recording gaps: before the first recorded frame after frames the file does not hold (the first
frame of a recording, or the first after a recorder drop) the engine's state is recorded, so a
replay continues there exactly as live did. The measurements the stop table keeps to seed a
backdated stop go in before the first frame recorded (every frame measured before that one is in
them, none after).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING

from snrmon.acquisition.engine.camera_engine import CameraEngine
from snrmon.acquisition.engine.inputs import FrameOutput, recorded_commands
from snrmon.acquisition.measure.peak_snr import PeakSnr
from snrmon.acquisition.runtime.frame_tally import FrameTally
from snrmon.acquisition.streams.ring import RingFrame

if TYPE_CHECKING:
    from snrmon.acquisition.protocols import RecordingWriter

History = Callable[[], Iterable[tuple[int, PeakSnr]]]
"""The stop table's kept measurements of the camera: (t_host_ns, Eq. 4 result), oldest first."""


class RecordingTap:
    """The recording of one camera's frames (module docstring). The measurement thread calls
    :meth:`frame_taken` before the engine measures a frame, :meth:`frame_measured` after, and
    :meth:`frame_done` once it is done with it; :meth:`attach` and :meth:`detach` any thread.
    Whether a frame goes to a recording is counted in ``tally`` under the same lock as the
    recording's start, so each frame counts on one side of it."""

    def __init__(self, name: str, engine: CameraEngine, history: History, tally: FrameTally):
        self.name = name
        self.engine = engine
        self.history = history
        self.tally = tally
        self._lock = threading.Lock()
        self._idle = threading.Condition(self._lock)
        self._recorder: RecordingWriter | None = None
        self._gap = False  # the last frame is not in the recording: record the state next
        self._history_due = False  # the stop table's history is not in the recording yet
        self._in_flight: RecordingWriter | None = None  # the recorder the frame in hand goes to

    @property
    def recorder(self) -> RecordingWriter | None:
        with self._lock:
            return self._recorder

    def attach(self, recorder: RecordingWriter, overruns: int) -> None:
        """Record every frame from the next one on into ``recorder`` (the ring had overrun
        ``overruns`` frames before)."""
        with self._lock:
            self.tally.recording_began(overruns)
            self._recorder = recorder
            self._gap = True
            self._history_due = True

    def detach(self) -> RecordingWriter | None:
        """Stop recording; the recorder it recorded to (None: none), once the frame in hand has
        gone to it (so that the recorder holds every frame given to it)."""
        with self._lock:
            rec, due = self._recorder, self._history_due
            self._recorder, self._history_due = None, False
            deadline = time.monotonic() + 10.0
            while rec is not None and self._in_flight is rec and time.monotonic() < deadline:
                self._idle.wait(0.1)
        if rec is not None and due:  # no frame came while recording: the history all the same
            self._record_history(rec)
        return rec

    def frame_taken(self, frame: RingFrame) -> tuple[RecordingWriter | None, int | None]:
        """Before ``frame`` is measured: (the recorder it goes to, its index there); (None,
        None) when not recording, (recorder, None) when the recorder dropped it."""
        with self._lock:
            rec, history, self._history_due = self._recorder, self._history_due, False
            self._in_flight = rec
            self.tally.taken(recording=rec is not None)
        if rec is None:
            return None, None
        if history:
            self._record_history(rec)
        index = rec.add_frame(self.name, frame)
        with self._lock:
            resume, self._gap = (self._gap and index is not None), index is None
        if resume:
            self._record_resume(rec, frame)
        return rec, index

    def frame_measured(self, rec: RecordingWriter, index: int | None, out: FrameOutput) -> None:
        """What the engine made of the frame: the commands it applied before it (at the frame
        they took effect on, so a replay applies them there too), a reference completed on it
        and its measurement (kept when the recorder dropped the frame)."""
        frame = out.frame
        for c in recorded_commands(out.applied):
            payload = {**c.payload(), "counter": frame.counter}
            rec.add_event(c.EVENT, camera=self.name, payload=payload, t_host_ns=frame.t_host_ns)
        done = out.reference_done
        if done is not None:
            rec.add_reference(self.name, done.offset, done.summary, t_host_ns=frame.t_host_ns)
        if out.measurement is not None:
            rec.add_measurement(self.name, index, out.measurement)

    def frame_done(self) -> None:
        with self._lock:
            self._in_flight = None
            self._idle.notify_all()

    def _record_history(self, rec: RecordingWriter) -> None:
        """The measurements a stop begun before the recording would be summarised from: rows
        without frames, so a replay builds the same stop table. Taken on the measurement thread
        (or once it has stopped), so exactly the frames measured before the first recorded one."""
        for t, r in self.history():
            rec.add_measurement(self.name, -1, r, t_host_ns=t)

    def _record_resume(self, rec: RecordingWriter, frame: RingFrame) -> None:
        """The first recorded frame after frames the file does not hold: the engine's state and
        the background reference in force, so a replay continues from here exactly."""
        corrector = self.engine.corrector
        if corrector.reference_offset is not None and corrector.reference_summary is not None:
            summary = {**corrector.reference_summary, "in_force": True}
            rec.add_reference(
                self.name, corrector.reference_offset, summary, t_host_ns=frame.t_host_ns
            )
        rec.add_state(self.name, frame.counter, frame.t_host_ns, self.engine.snapshot())
