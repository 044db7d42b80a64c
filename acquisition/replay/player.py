"""The console's replay of a recorded session: a :class:`ReplayPlayer` with the live Session's face.

The console drives a live :class:`snrmon.acquisition.runtime.session.Session` through a small
surface (:class:`snrmon.acquisition.protocols.ConsoleSession`); the player offers the same surface
on a recording, so the same window shows a replay. One worker thread plays the recording's timeline
(:class:`snrmon.acquisition.replay.feeder.Feeder`) into a fresh
:class:`snrmon.acquisition.engine.session_engine.SessionEngine` built with the recording's settings:
the live engine itself, so the replay shows the numbers the operator saw (per-frame SNR, running
statistics, noise and sky figures, the stop table filling as it did), the recorded GPS fix and its
projection.

Controls (:class:`snrmon.acquisition.protocols.ReplayControls`, any thread): :meth:`play`,
:meth:`pause`, :meth:`step` (one recorded frame of one camera), :meth:`seek` (a frame index),
:meth:`set_speed` (x real time, paced by the recorded ``t_host_ns``). A seek restarts the
measurement at the target: the track starts at the recorded window of the camera's last measured
frame before it, the running statistics and the stop table hold what is measured from there on. A
click measures the shown frame again around the new point. Recording, stop marks, references and
notes are refused (ValueError "not available in replay").
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from snrmon.acquisition.engine.inputs import ClearRoi, SetRoi
from snrmon.acquisition.engine.session_engine import SessionEngine
from snrmon.acquisition.engine.status import RecordingStatus, SessionStatus
from snrmon.acquisition.prediction import (
    MeasuredNoise,
    ModelRequest,
    Predictor,
    Weather,
    config_predictor,
)
from snrmon.acquisition.record.reader import SessionFile, open_session
from snrmon.acquisition.record.stream_rows import fix_from_row
from snrmon.acquisition.replay.batch import engine_for
from snrmon.acquisition.replay.camera import ReplayCamera
from snrmon.acquisition.replay.feeder import Feeder
from snrmon.acquisition.replay.recorded import FIX, FRAME, RecordedInputs, recorded_inputs
from snrmon.acquisition.stops.table import StopRow
from snrmon.acquisition.streams.ring import RingFrame
from snrmon.drivers.gps.fix import GpsFix

NOT_IN_REPLAY = "not available in replay"


@dataclass(frozen=True, slots=True)
class ReplayPosition:
    """Where the replay is: ``index`` of the last shown frame (-1 before the first) out of
    ``length``, its recorded time, and whether it is playing and how fast."""

    index: int
    length: int
    t_s: float  # seconds since the recording's first frame
    duration_s: float
    playing: bool
    speed: float


class ShownFrames:
    """The recorded frames a replay can show (a dropped frame has nothing to show): each one's
    entry in the recorded timeline and its recorded time."""

    def __init__(self, timeline: np.ndarray) -> None:
        self.entries = np.flatnonzero((timeline["kind"] == FRAME) & (timeline["frame"] >= 0))
        self.t_ns = timeline["t_ns"][self.entries]
        self._t0_ns = int(self.t_ns[0])

    def __len__(self) -> int:
        return len(self.t_ns)

    def t_s(self, index: int) -> float:
        """Shown frame ``index``'s time (s) since the first one (0 before the first)."""
        return (int(self.t_ns[index]) - self._t0_ns) / 1e9 if index >= 0 else 0.0

    @property
    def duration_s(self) -> float:
        return self.t_s(len(self) - 1)


class ReplayTransport:
    """What the controls asked of the replay's worker and where it stands: playing or paused and
    how fast, frames still to step, a seek and ROI clicks pending, the index of the last shown
    frame (-1 before the first), and whether the worker is busy with a job; all under one
    condition, so any thread may command it. The worker takes its jobs from :meth:`take_job`
    (paced to the recorded clock when playing) and reports each with :meth:`done`."""

    def __init__(self, frames: ShownFrames, speed: float) -> None:
        self._frames = frames
        self.cond = threading.Condition()
        self.playing = False
        self.speed = self.valid_speed(speed)
        self.index = -1
        self._steps = 0
        self._seek_to: int | None = None
        self._roi_requests: list[tuple[str, int | None, int | None]] = []
        self._stopping = False
        self._anchor: tuple[float, int] | None = None  # (wall s, recorded ns) for pacing
        self._busy = False

    @staticmethod
    def valid_speed(speed: float) -> float:
        speed = float(speed)
        if not (0.01 <= speed <= 1000.0):
            raise ValueError(f"replay speed must be 0.01 to 1000 x real time, got {speed}")
        return speed

    def play(self) -> None:
        with self.cond:
            if self.index >= len(self._frames) - 1:
                return
            self.playing, self._anchor = True, None
            self.cond.notify_all()

    def pause(self) -> None:
        with self.cond:
            self.playing = False
            self.cond.notify_all()

    def step(self, n: int) -> None:
        with self.cond:
            self.playing = False
            self._steps += int(n)
            self.cond.notify_all()

    def seek(self, index: int) -> None:
        with self.cond:
            self._seek_to, self._steps, self._anchor = int(index), 0, None
            self.cond.notify_all()

    def set_speed(self, speed: float) -> None:
        with self.cond:
            self.speed, self._anchor = self.valid_speed(speed), None

    def click(self, camera: str, x: int | None, y: int | None) -> None:
        """A click (None: the track released) for the worker to measure the shown frame by."""
        with self.cond:
            self._roi_requests.append((camera, x, y))
            self.cond.notify_all()

    def stop(self) -> None:
        with self.cond:
            self._stopping = True
            self.cond.notify_all()

    def wait_idle(self, timeout: float) -> bool:
        with self.cond:
            return self.cond.wait_for(
                lambda: (
                    not (
                        self._steps or self._seek_to is not None or self._roi_requests or self._busy
                    )
                ),
                timeout,
            )

    def wait_end(self, timeout: float) -> bool:
        last = len(self._frames) - 1
        with self.cond:
            return self.cond.wait_for(lambda: self.index >= last and not self._busy, timeout)

    def take_job(self) -> tuple[str, Any] | None:
        """The worker's next job, waited for (the worker is busy with it from now on); None:
        the replay stops."""
        with self.cond:
            job = self._next_job()
            if job is not None:
                self._busy = True
            return job

    def done(self, index: int | None) -> None:
        """The worker finished its job, showing frame ``index`` (None: the shown frame stays)."""
        with self.cond:
            if index is not None:
                self.index = index
            self._busy = False
            self.cond.notify_all()

    def _next_job(self) -> tuple[str, Any] | None:
        """Wait for something to do; returns the job (under the condition's lock)."""
        c = self.cond
        while True:
            if self._stopping:
                return None
            if self._seek_to is not None:
                k, self._seek_to = self._seek_to, None
                return "seek", k
            if self._roi_requests:
                return "roi", self._roi_requests.pop(0)
            last = len(self._frames) - 1
            if self._steps:
                self._steps -= 1
                if self.index < last:
                    return "show", self.index + 1
                continue
            if self.playing:
                if self.index >= last:
                    self.playing = False
                    continue
                k = self.index + 1
                t_rec = int(self._frames.t_ns[k])
                if self._anchor is None:
                    self._anchor = (time.monotonic(), t_rec)
                due = self._anchor[0] + (t_rec - self._anchor[1]) / 1e9 / self.speed
                delay = due - time.monotonic()
                if delay <= 0:
                    return "show", k
                c.wait(delay)  # pacing to the recorded clock; any command wakes it
                continue
            c.notify_all()
            c.wait()


class ReplayMeasurement:
    """The live engine a replay's frames are measured by, the camera views that show them, and
    how far the recorded timeline has been applied (the next entry, the last GPS fix); a seek
    starts a fresh engine (worker thread only)."""

    def __init__(self, f: SessionFile, inputs: RecordedInputs, predictor: Predictor | None):
        self._file, self._inputs = f, inputs
        self.engine, self._feeder = self._build(predictor)
        self.views: dict[str, ReplayCamera] = {}
        for name, cam in f.cameras.items():
            span = (cam.t_host_ns[-1] - cam.t_host_ns[0]) / 1e9 if cam.n_frames > 1 else 0.0
            fps = (cam.n_frames - 1) / span if span > 0 else 0.0
            self.views[name] = ReplayCamera(name, self.engine.cameras[name], fps)
        self._next_k = 0  # the next timeline entry to apply
        self._last_shown_k = int(ShownFrames(inputs.timeline).entries[-1])  # the last frame's
        self.last_fix: GpsFix | None = None

    def _build(self, predictor: Predictor | None) -> tuple[SessionEngine, Feeder]:
        f, inputs = self._file, self._inputs
        engine, feeder = engine_for(
            f,
            inputs,
            cameras=inputs.cameras,
            track=inputs.track,
            measurement=None,
            calibrations=None,
            predictor=predictor,
            redetect_stops=False,
            display=True,
        )
        feeder.keep = False
        return engine, feeder

    def seek(self, k: int, predictor: Predictor | None) -> None:
        """A fresh engine, readings, stops and references up to timeline entry ``k`` (a shown
        frame), then it. The fresh engine is prepared before the console sees it: swapped in
        first, a status or stop table read meanwhile (the console's thread) held the stops and
        ranges of a half-applied timeline, an empty table for a moment after a step back."""
        engine, feeder = self._build(predictor)
        feeder.skip_to(k)
        self.engine, self._feeder = engine, feeder
        for name, view in self.views.items():
            view.rebind(engine.cameras[name])
        self._next_k = k
        self.last_fix = self._fix_before(k)
        self.show_through(k)

    def _fix_before(self, k: int) -> GpsFix | None:
        tl = self._inputs.timeline
        fixes = np.flatnonzero(tl["kind"][:k] == FIX)
        return fix_from_row(self._file.gps[int(tl["row"][fixes[-1]])]) if fixes.size else None

    def show_through(self, k: int) -> None:
        """Apply the timeline up to and including entry ``k`` (a shown frame); at the last
        shown frame, the entries after it too (the session's end: its open rows made final)."""
        tl = self._inputs.timeline
        if k >= self._last_shown_k:
            k = len(tl) - 1
        while self._next_k <= k:
            j = self._next_k
            self._next_k += 1
            out = self._feeder.apply(j)
            kind = int(tl["kind"][j])
            if kind == FIX:
                self.last_fix = fix_from_row(self._file.gps[int(tl["row"][j])])
            if out is not None and int(tl["frame"][j]) >= 0:
                self._show_frame(out[0], int(tl["frame"][j]), int(tl["t_ns"][j]))

    def _show_frame(self, name: str, i: int, t: int) -> None:
        cam = self._file.cameras[name]
        pixels = np.asarray(cam.frames[i])
        self.views[name].show(RingFrame(pixels, i, int(cam.counter[i]), t, None, name))

    def remeasure(self, name: str, x: int | None, y: int | None) -> None:
        """A click in replay: measure the shown frame of ``name`` again around (x, y) (None:
        the track released, the shown frame is not measured)."""
        engine = self.engine
        engine.cameras[name].post(ClearRoi() if x is None or y is None else SetRoi(x, y))
        frame = self.views[name].latest_frame()
        if frame is not None:
            engine.on_frame(frame)


class ReplayPlayer:
    """A recorded session played into the console (see the module docstring): the recording's
    :class:`ShownFrames`, the :class:`ReplayTransport` the controls command, and the
    :class:`ReplayMeasurement` its worker thread drives.

    Args:
        path: the session file.
        predictor: the model's ``predictor(camera, range_m)`` for the stop table, or None.
        model_from_config: without ``predictor``, the model the recording's config names
            (its sensors and target: :func:`snrmon.acquisition.prediction.config_predictor`).
        speed: initial speed (x real time).
    """

    def __init__(
        self,
        path: str | Path,
        *,
        predictor: Predictor | None = None,
        model_from_config: bool = False,
        speed: float = 1.0,
    ) -> None:
        self.path = Path(path)
        self._file = open_session(self.path)
        f = self._file
        if not f.cameras or not any(c.n_frames for c in f.cameras.values()):
            f.close()
            raise ValueError(f"replay: {self.path} holds no camera frames")
        inputs = recorded_inputs(f)
        self.config = inputs.config
        if predictor is None and model_from_config:
            predictor = config_predictor(self.config)  # the recorded sensors and target
        self.track = inputs.track
        self._met_readings: Weather | None = None
        self._measured_noise: dict[str, MeasuredNoise] = {}
        self._predictor = predictor
        self._reference_predictor: Predictor | None = None  # set_model's, kept across a seek
        self._frames = ShownFrames(inputs.timeline)
        self._measurement = ReplayMeasurement(f, inputs, predictor)
        self.pipelines: dict[str, ReplayCamera] = self._measurement.views
        self._transport = ReplayTransport(self._frames, speed)
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------------ lifetime
    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="replay", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._transport.stop()
        if self._thread is not None:
            self._thread.join(10.0)
        self._file.close()

    def __enter__(self) -> ReplayPlayer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ------------------------------------------------------------------ controls
    def play(self) -> None:
        self._transport.play()

    def pause(self) -> None:
        self._transport.pause()

    def toggle_play(self) -> None:
        (self.pause if self._transport.playing else self.play)()

    def step(self, n: int = 1) -> None:
        """Show the next ``n`` recorded frames (pauses playback)."""
        self._transport.step(n)

    def seek(self, index: int) -> None:
        """Show recorded frame ``index`` (0 .. length-1), measuring afresh from there."""
        if not 0 <= int(index) < len(self._frames):
            raise ValueError(f"replay: frame index {index} is outside 0..{len(self._frames) - 1}")
        self._transport.seek(index)

    def set_speed(self, speed: float) -> None:
        self._transport.set_speed(speed)

    def wait_idle(self, timeout: float = 10.0) -> bool:
        """Wait until every step, seek and ROI asked for has been shown (tests, scripts)."""
        return self._transport.wait_idle(timeout)

    def wait_end(self, timeout: float = 60.0) -> bool:
        """Wait until the last recorded frame has been shown (tests, scripts)."""
        return self._transport.wait_end(timeout)

    @property
    def predictor(self) -> Predictor | None:
        return self._predictor

    @predictor.setter
    def predictor(self, predictor: Predictor | None) -> None:
        self.set_predictor(predictor)

    def model_sky_temp_k(self, camera: str) -> float | None:
        """The sky temperature (K) ``camera``'s model background follows in the replay (the
        recorded changes applied so far; None: the model's own)."""
        return self._measurement.engine.model_sky_temp_k(camera)

    def set_predictor(self, predictor: Predictor | None) -> None:
        """The model for the stop table's model column (from the next row computed)."""
        self._predictor = predictor
        self._measurement.engine.predictor = predictor

    @property
    def reference_predictor(self) -> Predictor | None:
        """The model at its own background beside :attr:`predictor` (set with it by
        :meth:`set_model`; kept across a seek, which builds a new engine)."""
        return self._reference_predictor

    def set_model(self, request: ModelRequest, *, reference_only: bool = False) -> None:
        """The model the analyst asked for, built by the replay's engine
        (:meth:`SessionEngine.set_model`); a ValueError changes nothing."""
        engine = self._measurement.engine
        engine.set_model(request, reference_only=reference_only)
        self._predictor, self._reference_predictor = engine.predictor, engine.reference_predictor

    @property
    def stop_table(self):
        return self._measurement.engine.stop_table

    def position(self) -> ReplayPosition:
        t = self._transport
        with t.cond:
            i, playing, speed = t.index, t.playing, t.speed
        frames = self._frames
        return ReplayPosition(i, len(frames), frames.t_s(i), frames.duration_s, playing, speed)

    def now_ns(self) -> int:
        """The recorded time of the last shown frame (the replay's 'now' for charts)."""
        with self._transport.cond:
            i = self._transport.index
        return int(self._frames.t_ns[max(i, 0)])

    # ------------------------------------------------------------------ the Session surface
    def set_roi(self, camera: str, x: int, y: int) -> None:
        """Measure ``camera`` around (x, y) from its shown frame on (re-measured at once)."""
        pipe = self.pipelines.get(camera)
        if pipe is None:
            raise ValueError(f"replay: no camera {camera!r} in {self.path.name}")
        h, w = pipe.shape
        if not (0 <= x < w and 0 <= y < h):
            raise ValueError(f"ROI ({x}, {y}) is outside the {camera} image ({w} x {h})")
        self._transport.click(camera, int(x), int(y))

    def clear_roi(self, camera: str) -> None:
        """Stop measuring ``camera`` from its shown frame on (until the next click)."""
        if camera not in self.pipelines:
            raise ValueError(f"replay: no camera {camera!r} in {self.path.name}")
        self._transport.click(camera, None, None)

    def stops(self) -> list[StopRow]:
        return self._measurement.engine.stops()

    def status(self) -> SessionStatus:
        now = self.now_ns()
        engine = self._measurement.engine
        lrf = engine.lrf_range.latest()
        gps = engine.gps_range.latest()
        return SessionStatus(
            cameras={n: p.status() for n, p in self.pipelines.items()},
            lrf=None,
            lrf_range_m=lrf[1] if lrf else None,
            lrf_age_s=(now - lrf[0]) / 1e9 if lrf else None,
            gps=None,
            gps_fix=self._measurement.last_fix,
            gps_range_m=gps[1] if gps else None,
            recording=RecordingStatus(state="replay", path=str(self.path)),
            extra={"replay": self.position()},
        )

    def start_recording(self, path: str | Path) -> None:
        raise ValueError(NOT_IN_REPLAY)

    def stop_recording(self) -> None:
        return None

    def mark_stop(self) -> None:
        raise ValueError(NOT_IN_REPLAY)

    def capture_reference(self, camera: str, n_frames: int = 64) -> None:
        raise ValueError(NOT_IN_REPLAY)

    def add_note(self, text: str) -> None:
        raise ValueError(NOT_IN_REPLAY)

    @property
    def met_readings(self) -> Weather | None:
        """The met readings the operator gave this replay's model (None: the recording's)."""
        return self._met_readings

    def set_met_readings(self, weather: Weather) -> None:
        """Re-analyse with other met readings: the model's atmosphere from now on (a replay
        records nothing)."""
        self._met_readings = weather
        predictor = self._measurement.engine.predictor
        if predictor is not None:
            predictor.set_weather(weather)

    @property
    def measured_noise(self) -> dict[str, MeasuredNoise]:
        """The measured noise the operator gave this replay's model, per camera (the
        recording's ``model_noise`` events apply at their times besides)."""
        return self._measured_noise

    def set_measured_noise(self, camera: str, noise: MeasuredNoise | None) -> None:
        """Re-analyse with ``camera``'s measured noise in place of the model's (None: the
        model's own) from now on (a replay records nothing)."""
        if camera not in self.pipelines:
            raise ValueError(f"replay: no camera {camera!r} in {self.path.name}")
        others = {c: n for c, n in self._measured_noise.items() if c != camera}
        self._measured_noise = others if noise is None else {**others, camera: noise}
        predictor = self._measurement.engine.predictor
        if predictor is not None:
            predictor.set_measured_noise(camera, noise)

    # ------------------------------------------------------------------ worker
    def _run(self) -> None:
        measurement, frames = self._measurement, self._frames
        while True:
            job = self._transport.take_job()
            if job is None:
                return
            kind, arg = job
            k = None
            try:
                if kind == "seek":
                    k = int(arg)
                    measurement.seek(int(frames.entries[k]), self._predictor)
                elif kind == "show":
                    k = int(arg)
                    measurement.show_through(int(frames.entries[k]))
                else:
                    name, x, y = arg
                    measurement.remeasure(name, x, y)
            finally:
                self._transport.done(k)
