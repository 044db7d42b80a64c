"""The session's engine: every camera's :class:`CameraEngine`, the range at each frame, the stops
and the SNR-versus-range table. The live :class:`snrmon.acquisition.runtime.session.Session` feeds
it from its device threads; a replay feeds it the recorded streams on the recorded clock. No
devices, no threads of its own, no files.

Inputs (any thread; each camera's frames from one thread, in order):

- :meth:`on_range`, :meth:`on_fix`: rangefinder readings and GPS fixes, into short histories on
  the common monotonic clock from which a frame's range is interpolated (the rangefinder while its
  reading is fresh, else the GPS slant range from the site; docs/architecture.md, "Time"), and into
  the stop detector; a fix is projected into every pointed camera and cues its tracker (paper
  section 4);
- :meth:`on_frame`: one frame of one camera (the ring's record as it is) through its engine,
  then into the stop table;
- :meth:`on_recorded`: a frame measured live but missing from a recording (replay only);
- :meth:`mark_stop`: the operator's stop mark.

What the live session must record goes to a :class:`EngineSink` (stop events, final rows, the
model's background following the measured sky temperature), so a replay can apply the same.
"""

from __future__ import annotations

import functools
import logging
import threading
from collections.abc import Callable, Mapping
from typing import Protocol

import numpy as np

from snrmon.acquisition.config import SessionConfig
from snrmon.acquisition.engine.camera_engine import CameraEngine
from snrmon.acquisition.engine.fix_cues import FixCues
from snrmon.acquisition.engine.inputs import FrameOutput, Measurement
from snrmon.acquisition.engine.lazy_frame import plain
from snrmon.acquisition.engine.range_history import RangeHistory
from snrmon.acquisition.engine.sky_following import SkyFollower
from snrmon.acquisition.prediction import ModelRequest, Predictor
from snrmon.acquisition.stage_clock import HANDOVER, STATISTICS, enter
from snrmon.acquisition.stops.detector import Stop, StopConfig, StopDetector
from snrmon.acquisition.stops.table import StopRow, StopSource, StopTable
from snrmon.acquisition.streams.history import ScalarHistory
from snrmon.acquisition.streams.ring import RingFrame
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.rangefinder.reading import RangeReading

log = logging.getLogger(__name__)

HISTORY_FRAMES = 4000  # measurements kept per camera to seed a backdated stop (live and replay)


class EngineSink(Protocol):
    """What the live session records of the engine's decisions (a replay applies them back)."""

    def stop_changed(self, kind: str, stop: Stop) -> None: ...

    def row_final(self, row: StopRow) -> None: ...

    def model_changed(self, camera: str, kind: str, payload: dict, t_host_ns: int) -> None:
        """One of the model's inputs changed: "model_background" {"temp_k"} (the measured
        sky), "model_psf" (a PSF measured from the flight, ``PsfEstimate.as_dict``) or
        "met_readings" (the day's met readings, ``Weather.as_dict``) or "model_noise" (the
        camera's measured 3D noise in place of the model's, ``temporal_dn`` and ``spatial_dn``;
        {}: the model's own)."""


class SessionEngine:
    """See the module docstring.

    Args:
        config: the session configuration (cameras, site, measurement, window).
        shapes: (rows, columns) of each camera's frames.
        track: follow the drone from the click.
        stop_config: the stop detector's rules (ignored when ``stops`` is given).
        stops: a stop source in place of a detector fed by :meth:`on_range` (a replay's
            recorded stops).
        predictor: the model's ``predictor(camera, range_m)`` for the stop table.
        cue_from_gps: cue the trackers with each fix (a replay of a recording that holds the
            cues applied live turns this off and applies those).
        project_gps: project each fix into the cameras for display even when it does not cue
            (off for a batch replay, which has no display).
        follow_sky: with a calibration, the model's background follows the measured sky
            temperature (a replay that applies the recorded changes turns this off).
    """

    def __init__(
        self,
        config: SessionConfig,
        shapes: Mapping[str, tuple[int, int]],
        *,
        track: bool = True,
        stop_config: StopConfig | None = None,
        stops: StopSource | None = None,
        predictor: Predictor | None = None,
        cue_from_gps: bool = True,
        follow_sky: bool = True,
        project_gps: bool = True,
        series_length: int = 2000,
    ) -> None:
        self.config = config
        self.follow_sky = follow_sky
        self.sink: EngineSink | None = None
        self._lock = threading.RLock()
        self.cameras: dict[str, CameraEngine] = {
            name: CameraEngine(
                name,
                shape,
                config.measurement,
                window=config.window_frames,
                track=track,
                series_length=series_length,
            )
            for name, shape in shapes.items()
        }
        self.ranges = RangeHistory(config.site, config.lrf_fresh_s)
        self.fix_cues = FixCues(config, cue=cue_from_gps, show=project_gps)
        self.stop_detector = StopDetector(stop_config)
        self.stop_table = StopTable(
            stops if stops is not None else self.stop_detector,
            list(self.cameras),
            frames_per_stop=100,
            history_frames=HISTORY_FRAMES,
            predictor=predictor,
            on_final=self._row_final,
        )
        for name, camera in self.cameras.items():
            camera.predictor = predictor
            camera.stop_progress = functools.partial(self.stop_table.progress, name)
        self.sky_follower = SkyFollower()  # the one owner of the sky the model's background follows
        # The model at its own background, beside ``predictor`` (a display draws both): built
        # with it from the operator's request (set_model), never following the sky.
        self.reference_predictor: Predictor | None = None
        # per camera, the host time of the last frame the stop table has seen (model_input_ns)
        self._table_frame_ns: dict[str, int] = {}
        self._finalized = False  # finalize() has made every row final
        self._listeners: list[Callable[[Measurement, np.ndarray | None], None]] = []

    @property
    def stop_source(self) -> StopSource:
        """Where the stop table takes its stops from: the live detector, or a replay's
        recorded stops."""
        return self.stop_table.detector

    # ------------------------------------------------------------------ the model
    @property
    def predictor(self) -> Predictor | None:
        return self.stop_table.predictor

    @predictor.setter
    def predictor(self, predictor: Predictor | None) -> None:
        """A new model (the console's options): it takes over the sky followed so far. Set
        from the console's thread while the measurement threads follow the sky: under the
        engine's lock, as :meth:`_follow_sky`, so no sky they follow meanwhile goes to the old
        model only."""
        with self._lock:
            self.sky_follower.apply_to(predictor)
            self.stop_table.predictor = predictor
            for camera in self.cameras.values():
                camera.predictor = predictor

    def set_model(self, request: ModelRequest, *, reference_only: bool = False) -> None:
        """The model the operator asked for, built here on the session's sensors: the stop
        table's and the cameras' predictor (it takes over the sky followed so far) and the
        reference at the request's own background, which never follows the sky. With
        ``reference_only`` the reference alone (a display's first model beside the predictor
        the session started with). A ValueError from the model (an unknown target) leaves the
        current ones in place."""
        sensors = {c.name: c.sensor for c in self.config.cameras}
        footprint = self.config.footprint  # the session's, which the request leaves as it is
        reference = request.predictor(sensors, footprint=footprint)
        if not reference_only:
            # as the one it replaces computes a new sky's curves: in the worker process live
            asynchronous = bool(getattr(self.predictor, "asynchronous", False))
            self.predictor = request.predictor(
                sensors, footprint=footprint, asynchronous=asynchronous
            )
        self.reference_predictor = reference

    def set_background(self, camera: str, temp_k: float | None) -> None:
        """The model's background temperature for ``camera`` (the measured sky; None: the
        model's own): the paper's path-radiance correction (sections 8-9)."""
        self.sky_follower.set(camera, temp_k, self.predictor)

    def model_sky_temp_k(self, camera: str) -> float | None:
        """The measured sky temperature ``camera``'s model background follows (None: the
        model's own); a display reads it, only the engine sets it."""
        return self.sky_follower.temp_k(camera)

    def adopt_psf(self, camera: str, estimate: dict, t_host_ns: int) -> None:
        """The corrected curves and the expected Eq. (4) use the PSF measured from the flight
        (``acquisition.calibrate.psf_estimate.PsfEstimate.as_dict``), recorded so a replay
        uses it from the same time on."""
        self.apply_model_input(camera, "model_psf", estimate)
        if self.sink is not None:
            self.sink.model_changed(camera, "model_psf", estimate, int(t_host_ns))

    def model_input_ns(self, camera: str) -> int | None:
        """The time to record a change of ``camera``'s model inputs made now at: the host time
        of the last frame the stop table has seen (the frames after it see the new model, as a
        replay applying the change after that frame does); None before the first frame and
        after :meth:`finalize` (no frame sees it then, and the rows made final there did not: a
        replay, which applies it after its recorded frame, must not apply it before them)."""
        if self._finalized:
            return None
        return self._table_frame_ns.get(camera)

    def apply_model_input(self, camera: str, kind: str, payload: dict) -> None:
        """A change of the model's inputs as :meth:`EngineSink.model_changed` records it."""
        if kind == "model_background":
            self.set_background(camera, float(payload["temp_k"]))
        elif kind == "model_psf" and self.predictor is not None:
            from snrmon.acquisition.calibrate.psf_estimate import psf_from_record

            self.predictor.set_psf(camera, psf_from_record(payload))
        elif kind == "met_readings" and self.predictor is not None:
            from snrmon.acquisition.prediction import weather_from_record

            self.predictor.set_weather(weather_from_record(payload), camera)
        elif kind == "model_noise" and self.predictor is not None:
            from snrmon.acquisition.prediction import measured_noise_from_record

            self.predictor.set_measured_noise(camera, measured_noise_from_record(payload))

    # ------------------------------------------------------------------ commands
    def camera(self, name: str) -> CameraEngine:
        try:
            return self.cameras[name]
        except KeyError:
            raise ValueError(
                f"no camera {name!r} in this session (have: {', '.join(self.cameras)})"
            ) from None

    def mark_stop(self, t_ns: int) -> Stop:
        """The operator says the drone is hovering at a stop from ``t_ns`` on."""
        with self._lock:
            before = self.stop_detector.current
            stop = self.stop_detector.mark_stop(int(t_ns))
            ended = None
            if before is not None:
                ended = self.stop_detector.stops[before.index]
            if self.sink is not None:  # in the detector's order (see _feed_stops)
                if ended is not None:
                    self.sink.stop_changed("stop_ended", ended)
                self.sink.stop_changed("stop_marked", stop)
        return stop

    def with_stops_held(self, fn: Callable[[], None]) -> None:
        """``fn()`` with the stop detector held: no stop changes while it runs, and every change
        after it reaches the sink after it (a recording attaches its sink and records the stops
        so far this way, so none falls between the two)."""
        with self._lock:
            fn()

    def add_listener(self, callback: Callable[[Measurement, np.ndarray | None], None]) -> None:
        """``callback(measurement, pixels)`` after every measured frame, on the frame's thread;
        ``pixels`` (the raw frame, valid during the call only) is None for a frame a replay has
        only the recorded measurement of."""
        with self._lock:
            self._listeners.append(callback)

    # ------------------------------------------------------------------ readings
    def on_range(self, reading: RangeReading) -> None:
        if self.ranges.add_range(reading):
            self._feed_stops(lambda d: d.add_reading(reading))

    def on_fix(self, fix: GpsFix) -> None:
        if self.config.site is None:
            return
        if self.stop_source is self.stop_detector:
            r = self.ranges.add_fix(fix)  # the stop detector takes it now
            if r is not None:
                self._feed_stops(lambda d: d.add_gps_range(fix.t_host_ns, r))
        else:
            self.ranges.defer_fix(fix)  # its slant range when it is read (gps_range), in order
        self.fix_cues.apply(fix, self.cameras)

    @property
    def lrf_range(self) -> ScalarHistory:
        """The rangefinder's ranges, reading by reading (fresh for ``lrf_fresh_s``)."""
        return self.ranges.lrf

    @property
    def gps_range(self) -> ScalarHistory:
        """The GPS slant ranges from the site, fix by fix (:attr:`RangeHistory.gps`)."""
        return self.ranges.gps

    def _feed_stops(self, feed: Callable[[StopDetector], Stop | None]) -> None:
        if self.stop_source is not self.stop_detector:
            return  # a replay's recorded stops: nobody reads a detector's
        with self._lock:
            try:
                stop = feed(self.stop_detector)
            except ValueError as exc:
                log.warning("stop detector refused a reading: %s", exc)
                return
            # Under the lock: the rangefinder's and the GPS's threads record their stop changes
            # in the order the detector made them.
            if stop is not None and self.sink is not None:
                self.sink.stop_changed(
                    "stop_ended" if stop.t_end_ns is not None else "stop_detected", stop
                )

    def range_at(self, t_host_ns: int) -> tuple[float | None, str]:
        """The range for a frame received at ``t_host_ns``: the rangefinder if its reading is
        fresh (within ``lrf_fresh_s``), else the GPS slant range, else None."""
        return self.ranges.range_at(t_host_ns)

    # ------------------------------------------------------------------ frames
    def on_frame(self, frame: RingFrame) -> FrameOutput:
        """One frame of camera ``frame.camera``, as the ring gave it, through that camera's
        engine, then the stop table and the listeners."""
        out = self.cameras[frame.camera].process(frame, self.range_at)
        self._after_frame(frame.camera, frame.t_host_ns, out.measurement, frame.pixels)
        return out

    def on_recorded(self, m: Measurement) -> None:
        """A frame measured live whose pixels the recording does not hold (replay)."""
        self.cameras[m.camera].publish_recorded(m)
        self._after_frame(m.camera, m.t_host_ns, m, None)

    def _after_frame(
        self, camera: str, t_ns: int, m: Measurement | None, pixels: np.ndarray | None
    ) -> None:
        enter(STATISTICS)
        if m is None:
            self.stop_table.tick(camera, t_ns)
            self._table_frame_ns[camera] = t_ns
            return
        self.stop_table.add(camera, t_ns, m.result)
        self._table_frame_ns[camera] = t_ns  # after the table read the model for this frame
        if self.follow_sky:
            self._follow_sky(camera, t_ns)
        enter(HANDOVER)
        with self._lock:
            listeners = list(self._listeners)
        if listeners and pixels is not None:
            pixels = plain(pixels)  # a listener may read any pixel (a recording keeps them all)
        for cb in listeners:
            try:
                cb(m, pixels)
            except Exception:
                log.exception("%s: measurement listener failed", camera)

    def _follow_sky(self, camera: str, t_ns: int) -> None:
        """With a calibration, the model's background input follows the measured sky
        temperature (:class:`~snrmon.acquisition.engine.sky_following.SkyFollower`); a change is
        recorded at this frame."""
        sky = self.cameras[camera].sky
        if sky is None:
            return
        with self._lock:  # the model is not swapped between reading it and following on it
            predictor = self.predictor
            if predictor is None:
                return
            temp = self.sky_follower.follow(camera, t_ns, sky, predictor)
        if temp is not None and self.sink is not None:
            self.sink.model_changed(camera, "model_background", {"temp_k": temp}, t_ns)

    # ------------------------------------------------------------------ the table
    def stops(self) -> list[StopRow]:
        """The SNR-versus-range table so far (one row per stop and camera)."""
        return self.stop_table.rows()

    def finalize(self) -> list[StopRow]:
        """The session ends: every row final as it stands (an open stop with its ranges as
        they stand, which the sink records first so a replay finalizes with the same)."""
        with self._lock:
            self._finalized = True
            current = self.stop_detector.current if self.stop_source is self.stop_detector else None
        if current is not None and self.sink is not None:
            self.sink.stop_changed("stop_open_at_end", current)
        return self.stop_table.finalize()

    def _row_final(self, row: StopRow) -> None:
        if self.sink is not None:
            self.sink.row_final(row)
