"""The console's replay of a recorded session: a :class:`ReplayPlayer` that looks like a Session.

The console drives a live :class:`acquisition.runtime.session.Session` through a small surface
(``pipelines[name]`` with ``shape``, ``latest_frame()``, ``series()``, ``status()``; the session's
``status()``, ``stops()``, ``config.measurement``, ``set_roi``); the player offers the same
surface on a recording, so the same window shows a replay. One worker thread reads the recorded
frames of every camera in recorded time order (one merged *timeline*) and analyses each with the
live pipeline's :class:`acquisition.engine.camera_analysis.CameraAnalysis` (Eq. 4 with the track,
the
raw-frame SNR beside a correction, the section 6 noise, the sky temperature), with the recorded
ROI clicks, background references and calibration applied as
:func:`acquisition.replay.batch.replay_session` applies them (the helpers are shared). The recorded
rangefinder and GPS streams feed the stop detector and the per-frame range as the replay reaches
their times, so the stop table fills as it would live; each recorded GPS fix is shown in the
status and projected into the pointed cameras (the GPS cross, and the cue of a lost track).

Controls (any thread): :meth:`play`, :meth:`pause`, :meth:`step` (one timeline entry: one frame
of one camera), :meth:`seek` (a timeline index), :meth:`set_speed` (x real time, paced by the
recorded ``t_host_ns``). A seek restarts the measurement at the target: the track starts at the
recorded peak of the camera's last measured frame before it (else its last recorded click), the
running statistics and the stop table hold what is measured from there on.
Recording, stop marks, references and notes are refused (ValueError "not available in replay").
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from acquisition.config import SessionConfig, session_config_from_dict
from acquisition.engine.status import RecordingStatus
from acquisition.geo.gps_cue import GpsProjector
from acquisition.record.reader import open_session
from acquisition.record.stream_rows import fix_from_row
from acquisition.replay.batch import (
    range_readings,
    recorded_events,
    recorded_stop_detector,
    recorded_track,
)
from acquisition.replay.camera import ReplayCamera, ReplayCameraState
from acquisition.runtime.history import ScalarHistory
from acquisition.runtime.ring import RingFrame
from acquisition.runtime.session import SessionStatus
from acquisition.stops.table import Predictor, StopRow, StopTable
from drivers.gps.fix import GpsFix

NOT_IN_REPLAY = "not available in replay"


@dataclass(frozen=True, slots=True)
class ReplayPosition:
    """Where the replay is: ``index`` of the last shown timeline entry (-1 before the first)
    out of ``length``, its recorded time, and whether it is playing and how fast."""

    index: int
    length: int
    t_s: float  # seconds since the recording's first frame
    duration_s: float
    playing: bool
    speed: float


class ReplayPlayer:
    """A recorded session played into the console (see the module docstring).

    Args:
        path: the session file.
        predictor: the model's ``predictor(camera, range_m)`` for the stop table, or None.
        speed: initial speed (x real time).
        series_length: per-frame rows kept for the strip charts.
    """

    is_replay = True

    def __init__(
        self,
        path: str | Path,
        *,
        predictor: Predictor | None = None,
        speed: float = 1.0,
        series_length: int = 2000,
    ) -> None:
        self.path = Path(path)
        self._file = open_session(self.path)
        f = self._file
        if not f.cameras or not any(c.n_frames for c in f.cameras.values()):
            f.close()
            raise ValueError(f"replay: {self.path} holds no camera frames")
        raw = f.config.get("session") if isinstance(f.config, dict) else None
        self.config: SessionConfig = session_config_from_dict(raw or {})
        self.track = recorded_track(f)
        self.predictor = predictor
        self._events = recorded_events(f)
        self._readings = range_readings(f, self.config.site)
        self._projector = GpsProjector(self.config)
        self._fixes = np.sort(f.gps[:], order="t_host_ns") if len(f.gps) else None
        names = list(f.cameras)
        self.pipelines: dict[str, ReplayCamera] = {}
        for name, cam in f.cameras.items():
            span = (cam.t_host_ns[-1] - cam.t_host_ns[0]) / 1e9 if cam.n_frames > 1 else 0.0
            fps = (cam.n_frames - 1) / span if span > 0 else 0.0
            self.pipelines[name] = ReplayCamera(name, cam, fps, series_length)
        t = np.concatenate([f.cameras[n].t_host_ns for n in names]).astype(np.int64)
        c = np.concatenate([np.full(f.cameras[n].n_frames, k) for k, n in enumerate(names)])
        i = np.concatenate([np.arange(f.cameras[n].n_frames) for n in names])
        order = np.argsort(t, kind="stable")
        self._t, self._cam, self._idx = t[order], c[order].astype(int), i[order]
        self._names = names
        self._t0 = int(self._t[0])
        self._cond = threading.Condition()
        self._playing = False
        self._speed = self._valid_speed(speed)
        self._steps = 0
        self._seek_to: int | None = None
        self._roi_requests: list[tuple[str, int, int]] = []
        self._stopping = False
        self._index = -1
        self._anchor: tuple[float, int] | None = None  # (wall s, recorded ns) for pacing
        self._busy = False
        self._thread: threading.Thread | None = None
        self._reset_state(0)

    # ------------------------------------------------------------------ lifetime
    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="replay", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        with self._cond:
            self._stopping = True
            self._cond.notify_all()
        if self._thread is not None:
            self._thread.join(10.0)
        self._file.close()

    def __enter__(self) -> ReplayPlayer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ------------------------------------------------------------------ controls
    @staticmethod
    def _valid_speed(speed: float) -> float:
        speed = float(speed)
        if not (0.01 <= speed <= 1000.0):
            raise ValueError(f"replay speed must be 0.01 to 1000 x real time, got {speed}")
        return speed

    def play(self) -> None:
        with self._cond:
            if self._index >= len(self._t) - 1:
                return
            self._playing, self._anchor = True, None
            self._cond.notify_all()

    def pause(self) -> None:
        with self._cond:
            self._playing = False
            self._cond.notify_all()

    def toggle_play(self) -> None:
        (self.pause if self._playing else self.play)()

    def step(self, n: int = 1) -> None:
        """Show the next ``n`` timeline entries (pauses playback)."""
        with self._cond:
            self._playing = False
            self._steps += int(n)
            self._cond.notify_all()

    def seek(self, index: int) -> None:
        """Show timeline entry ``index`` (0 .. length-1), measuring afresh from there."""
        if not 0 <= int(index) < len(self._t):
            raise ValueError(f"replay: frame index {index} is outside 0..{len(self._t) - 1}")
        with self._cond:
            self._seek_to, self._steps, self._anchor = int(index), 0, None
            self._cond.notify_all()

    def set_speed(self, speed: float) -> None:
        with self._cond:
            self._speed, self._anchor = self._valid_speed(speed), None

    def wait_idle(self, timeout: float = 10.0) -> bool:
        """Wait until every step, seek and ROI asked for has been shown (tests, scripts)."""
        with self._cond:
            return self._cond.wait_for(
                lambda: not (self._steps or self._seek_to is not None or self._roi_requests
                             or self._busy),
                timeout,
            )  # fmt: skip

    def set_predictor(self, predictor: Predictor | None) -> None:
        """The model for the stop table's model column (from the next row computed)."""
        self.predictor = predictor
        self._table.predictor = predictor

    def position(self) -> ReplayPosition:
        with self._cond:
            i, playing, speed = self._index, self._playing, self._speed
        t_s = (int(self._t[max(i, 0)]) - self._t0) / 1e9 if i >= 0 else 0.0
        return ReplayPosition(i, len(self._t), t_s, (int(self._t[-1]) - self._t0) / 1e9,
                              playing, speed)  # fmt: skip

    def now_ns(self) -> int:
        """The recorded time of the last shown frame (the replay's 'now' for charts)."""
        with self._cond:
            i = self._index
        return int(self._t[max(i, 0)])

    # ------------------------------------------------------------------ the Session surface
    def set_roi(self, camera: str, x: int, y: int) -> None:
        """Measure ``camera`` around (x, y) from its shown frame on (re-measured at once)."""
        pipe = self.pipelines.get(camera)
        if pipe is None:
            raise ValueError(f"replay: no camera {camera!r} in {self.path.name}")
        h, w = pipe.shape
        if not (0 <= x < w and 0 <= y < h):
            raise ValueError(f"ROI ({x}, {y}) is outside the {camera} image ({w} x {h})")
        with self._cond:
            self._roi_requests.append((camera, int(x), int(y)))
            self._cond.notify_all()

    def stops(self) -> list[StopRow]:
        return self._table.rows()

    def status(self) -> SessionStatus:
        now = self.now_ns()
        lrf = self._lrf_history.latest()
        gps = self._gps_history.latest()
        return SessionStatus(
            cameras={n: p.status() for n, p in self.pipelines.items()},
            lrf=None,
            lrf_range_m=lrf[1] if lrf else None,
            lrf_age_s=(now - lrf[0]) / 1e9 if lrf else None,
            gps=None,
            gps_fix=self._last_fix,
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

    # ------------------------------------------------------------------ worker
    def _reset_state(self, target: int) -> None:
        """Fresh measurement, stop table and range histories for a replay from ``target``."""
        f = self._file
        self._states = {
            n: ReplayCameraState(f, n, self.config, self.track, self._events) for n in self._names
        }
        self._detector = recorded_stop_detector(f)
        self._table = StopTable(self._detector, self._names, history_frames=10**6,
                                predictor=self.predictor)  # fmt: skip
        gap = int(self.config.lrf_fresh_s * 1e9)
        self._lrf_history = ScalarHistory(maxlen=4096, max_gap_ns=gap)
        self._gps_history = ScalarHistory(maxlen=4096)
        self._reading_pos = 0
        self._fix_pos = 0
        self._last_fix: GpsFix | None = None
        t_target = int(self._t[target])
        self._feed_ranges(t_target - 1)
        for name, st in self._states.items():
            meas = st.record.measurements
            last_click = st.apply_events(t_target, before=True)
            if last_click is not None:
                x, y = last_click[1], last_click[2]
                before = meas[(meas["t_host_ns"] >= last_click[0]) & (meas["t_host_ns"] < t_target)]
                if before.size:  # where the recorded track was when the seek cut it
                    x, y = int(before["peak_x"][-1]), int(before["peak_y"][-1])
                st.analysis.set_roi(x, y)
            self.pipelines[name].clear()

    def _feed_ranges(self, t_ns: int) -> None:
        """The recorded ranges and GPS fixes up to ``t_ns``, as they arrived live."""
        readings = self._readings
        while self._reading_pos < len(readings) and readings[self._reading_pos][0] <= t_ns:
            t, rng, source = readings[self._reading_pos]
            self._reading_pos += 1
            self._detector.add_range(t, rng, source)
            (self._lrf_history if source == "lrf" else self._gps_history).append(t, rng)
        fixes = self._fixes
        fix = None
        while fixes is not None and self._fix_pos < len(fixes):
            if int(fixes["t_host_ns"][self._fix_pos]) > t_ns:
                break
            fix = fix_from_row(fixes[self._fix_pos])
            self._fix_pos += 1
        if fix is not None:  # only the newest cues: the tracker uses the latest position
            self._last_fix = fix
            where = self._projector.pixels(fix)
            for name, st in self._states.items():
                st.cue(where.get(name))

    def _range_at(self, t_ns: int) -> tuple[float | None, str]:
        r = self._lrf_history.value_at(t_ns)
        if r is not None:
            return r, "lrf"
        g = self._gps_history.value_at(t_ns)
        return (g, "gps") if g is not None else (None, "")

    def _show(self, k: int) -> None:
        """Read and measure timeline entry ``k`` (worker thread)."""
        t, name, i = int(self._t[k]), self._names[self._cam[k]], int(self._idx[k])
        self._feed_ranges(t)
        st = self._states[name]
        click = st.apply_events(t)
        if click is not None:
            st.analysis.set_roi(click[1], click[2])
        cam = st.record
        frame = RingFrame(np.asarray(cam.frames[i]), i, int(cam.counter[i]), t, None, name)
        st.read += 1
        self.pipelines[name].show(frame)
        self._measure(name, frame)

    def _measure(self, name: str, frame: RingFrame) -> None:
        st, pipe = self._states[name], self.pipelines[name]
        range_m, source = self._range_at(frame.t_host_ns)
        status, row, result = st.measure(frame, range_m, source, pipe.fps)
        if result is not None:
            self._table.add(name, frame.t_host_ns, result)
        pipe.publish(status, row)

    def _next_job(self) -> tuple[str, object] | None:
        """Wait for something to do; returns the job (under the condition's lock)."""
        c = self._cond
        while True:
            if self._stopping:
                return None
            if self._seek_to is not None:
                k, self._seek_to = self._seek_to, None
                return "seek", k
            if self._roi_requests:
                return "roi", self._roi_requests.pop(0)
            last = len(self._t) - 1
            if self._steps:
                self._steps -= 1
                if self._index < last:
                    return "show", self._index + 1
                continue
            if self._playing:
                if self._index >= last:
                    self._playing = False
                    continue
                k = self._index + 1
                t_rec = int(self._t[k])
                if self._anchor is None:
                    self._anchor = (time.monotonic(), t_rec)
                due = self._anchor[0] + (t_rec - self._anchor[1]) / 1e9 / self._speed
                delay = due - time.monotonic()
                if delay <= 0:
                    return "show", k
                c.wait(delay)  # pacing to the recorded clock; any command wakes it
                continue
            c.notify_all()
            c.wait()

    def _run(self) -> None:
        while True:
            with self._cond:
                job = self._next_job()
                if job is None:
                    return
                self._busy = True
            kind, arg = job
            k = None
            try:
                if kind == "seek":
                    self._reset_state(arg)
                    self._show(arg)
                    k = arg
                elif kind == "show":
                    self._show(arg)
                    k = arg
                else:
                    name, x, y = arg
                    self._states[name].analysis.set_roi(x, y)
                    frame = self.pipelines[name].latest_frame()
                    if frame is not None:
                        self._measure(name, frame)
            finally:
                with self._cond:
                    if k is not None:
                        self._index = k
                    self._busy = False
                    self._cond.notify_all()
