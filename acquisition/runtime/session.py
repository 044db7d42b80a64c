"""The Session: the one object the CLI and the GUI drive (no Qt).

It owns the devices of a :class:`acquisition.config.SessionConfig` and wires them:
each camera through a :class:`acquisition.runtime.camera_pipeline.CameraPipeline`; the rangefinder
and
GPS readings into short histories on the common monotonic clock (DESIGN "Time"), from which each
frame's range is interpolated (the rangefinder when its last reading is fresh, else the GPS slant
range from the site); everything raw into the recorder while recording. Commands: start/stop,
set the ROI per camera, start/stop recording, mark a stop, add a note. Reading: status snapshots
and the latest frame per camera.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import shutil
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from acquisition.config import SessionConfig, camera_device
from acquisition.engine.status import CameraStatus, RecordingStatus
from acquisition.geo.gps_cue import GpsProjector
from acquisition.geo.projection import gps_slant_range_m
from acquisition.record.recorder import SessionRecorder
from acquisition.runtime.camera_pipeline import CameraPipeline, Measurement
from acquisition.runtime.history import ScalarHistory
from acquisition.runtime.ring import RingFrame
from acquisition.runtime.timebase import ClockMap
from acquisition.stops.detector import StopConfig, StopDetector
from acquisition.stops.table import Predictor, StopRow, StopTable
from drivers.device import Device, DeviceStatus
from drivers.gps.fix import GpsFix
from drivers.rangefinder.reading import RangeReading, RangeStatus

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SessionStatus:
    """Everything the console shows, as one snapshot."""

    cameras: dict[str, CameraStatus]
    lrf: DeviceStatus | None
    lrf_range_m: float | None
    lrf_age_s: float | None
    gps: DeviceStatus | None
    gps_fix: GpsFix | None
    gps_range_m: float | None
    recording: RecordingStatus
    alarms: tuple[str, ...] = ()
    extra: dict[str, Any] = field(default_factory=dict)


class Session:
    """A collection session. ``devices`` overrides what the config would open (tests, HIL)."""

    def __init__(
        self,
        config: SessionConfig,
        *,
        cameras: dict[str, Device] | None = None,
        shapes: dict[str, tuple[int, int]] | None = None,
        gps: Device | None = None,
        lrf: Device | None = None,
        track: bool = True,
        clock: ClockMap | None = None,
        stop_config: StopConfig | None = None,
        predictor: Predictor | None = None,
    ) -> None:
        self.config = config
        self.track = track
        self.clock = clock or ClockMap()
        self._lock = threading.Lock()
        self.lrf_range = ScalarHistory(max_gap_ns=int(config.lrf_fresh_s * 1e9))
        self.gps_range = ScalarHistory()
        self._last_lrf: RangeReading | None = None
        self._last_fix: GpsFix | None = None
        self._recorder: SessionRecorder | None = None
        self._measurement_listeners: list[Callable[[Measurement, RingFrame], None]] = []
        self.pipelines: dict[str, CameraPipeline] = {}
        self.projector = GpsProjector(config)
        for cam in config.cameras:
            device = (cameras or {}).get(cam.name) or camera_device(cam)
            shape = (shapes or {}).get(cam.name) or self._shape_of(cam)
            pipe = CameraPipeline(
                cam.name,
                device,
                shape,
                config=config.measurement,
                window=config.window,
                range_at=self.range_at,
                track=track,
            )
            pipe.add_listener(self._on_measurement)
            if cam.calibration:
                pipe.set_calibration(self._calibration(cam, shape))
            self.pipelines[cam.name] = pipe
        self.predictor = predictor
        self._sky_checked: dict[str, int] = {}
        self._table_checked = 0
        self.stop_detector = StopDetector(stop_config)
        self.stop_table = StopTable(
            self.stop_detector,
            list(self.pipelines),
            frames_per_stop=100,
            predictor=predictor,
            on_final=self._record_row,
        )
        self.gps = gps if gps is not None else self._serial_device(config.gps, "gps")
        self.lrf = lrf if lrf is not None else self._serial_device(config.lrf, "lrf")
        if self.gps is not None:
            self.gps.subscribe(self._on_fix)
        if self.lrf is not None:
            self.lrf.subscribe(self._on_range)
        self._started = False

    # ------------------------------------------------------------------ construction helpers
    @staticmethod
    def _shape_of(cam) -> tuple[int, int]:
        if cam.width_px and cam.height_px:
            return int(cam.height_px), int(cam.width_px)
        from model.presets import load_sensor  # the sensor preset knows the array format

        sensor = load_sensor(cam.sensor)
        return int(sensor.height_px), int(sensor.width_px)

    @staticmethod
    def _calibration(cam, shape: tuple[int, int]):
        from acquisition.calibrate.calibration_file import load_calibration
        from model.presets import load_sensor

        # Checked against the camera's sensor (camera, band, integration time) and frame size:
        # a calibration of another camera or band is refused, nothing applied.
        return load_calibration(cam.calibration, load_sensor(cam.sensor), frame_shape=shape)

    @staticmethod
    def _serial_device(table: dict | None, name: str) -> Device | None:
        if not table:
            return None
        from drivers.config import device_from_config

        return device_from_config(dict(table), name)

    # ------------------------------------------------------------------ control
    def start(self) -> None:
        """Open every device and start the pipelines; a device that fails is retried."""
        for dev in (self.gps, self.lrf):
            if dev is not None:
                dev.open()
        for pipe in self.pipelines.values():
            pipe.start()
        self._started = True

    def stop(self) -> None:
        """Stop recording (if on), the pipelines and the devices."""
        self.stop_recording()
        for pipe in self.pipelines.values():
            pipe.stop()
        for dev in (self.gps, self.lrf):
            if dev is not None:
                dev.close()
        self._started = False

    def __enter__(self) -> Session:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def pipeline(self, camera: str) -> CameraPipeline:
        try:
            return self.pipelines[camera]
        except KeyError:
            raise ValueError(
                f"no camera {camera!r} in this session (have: {', '.join(self.pipelines)})"
            ) from None

    def set_roi(self, camera: str, x: int, y: int) -> None:
        """The operator clicked the drone at column ``x``, row ``y`` of ``camera``."""
        self.pipeline(camera).set_roi(x, y)
        # The pipeline records "roi_set" at the frame the click takes effect on.
        self._event("roi_clicked", camera=camera, payload={"x": int(x), "y": int(y)})

    def capture_reference(self, camera: str, n_frames: int = 64) -> None:
        """Average the next ``n_frames`` of ``camera`` (clear sky, no drone in view) into the
        background reference that removes its fixed-pattern noise before Eq. (4)."""
        self.pipeline(camera).capture_reference(n_frames)
        self._event("reference_requested", camera=camera, payload={"n_frames": int(n_frames)})

    def mark_stop(self) -> None:
        """The operator says the drone is hovering at a stop now."""
        t = time.monotonic_ns()
        with self._lock:
            stop = self.stop_detector.mark_stop(t)
        self._event("stop_marked", payload={"stop": stop.index}, t_host_ns=t)

    def stops(self) -> list[StopRow]:
        """The SNR-versus-range table so far (one row per stop and camera)."""
        with self._lock:
            return self.stop_table.rows()

    def add_note(self, text: str) -> None:
        self._event("note", payload={"text": text})

    def add_measurement_listener(self, cb: Callable[[Measurement, RingFrame], None]) -> None:
        """``cb(measurement, frame)`` on each camera's measurement thread after every frame."""
        with self._lock:
            self._measurement_listeners.append(cb)

    def start_recording(self, path: str | Path) -> None:
        """Record everything from now on into one HDF5 session file (a new file)."""
        with self._lock:
            if self._recorder is not None and self._recorder.status().state == "recording":
                raise ValueError(f"already recording to {self._recorder.path}")
        shapes = {n: p.shape for n, p in self.pipelines.items()}
        rec = SessionRecorder(path, config=self._config_record(), cameras=shapes, clock=self.clock)
        with self._lock:
            self._recorder = rec
        for pipe in self.pipelines.values():
            pipe.attach_recorder(rec)
            cal = pipe.corrector.calibration
            if cal is not None:
                from acquisition.calibrate.calibration_file import calibration_metadata

                meta = calibration_metadata(cal)
                meta["path"] = next(
                    c.calibration for c in self.config.cameras if c.name == pipe.name
                )
                rec.add_event("calibration", camera=pipe.name, payload=meta)
            roi = pipe.status().roi_xy
            if roi is not None:  # the track in force is part of the record (replayed from here)
                rec.add_event(
                    "roi_set", camera=pipe.name, payload={"x": roi[0], "y": roi[1], "resumed": True}
                )

    def stop_recording(self):
        """Finish the file; returns the recorder's summary (None when not recording)."""
        self.stops()  # rows final by now go into the file
        with self._lock:
            rec, self._recorder = self._recorder, None
        if rec is None:
            return None
        for pipe in self.pipelines.values():
            pipe.detach_recorder()
        return rec.stop()

    # ------------------------------------------------------------------ time and range
    def range_at(self, t_host_ns: int) -> tuple[float | None, str]:
        """The range for a frame received at ``t_host_ns``: the rangefinder if its reading is
        fresh (within ``lrf_fresh_s``), else the GPS slant range, else None."""
        r = self.lrf_range.value_at(t_host_ns)
        if r is not None:
            return r, "lrf"
        g = self.gps_range.value_at(t_host_ns)
        if g is not None:
            return g, "gps"
        return None, ""

    def _on_range(self, reading: RangeReading) -> None:
        with self._lock:
            self._last_lrf = reading
            rec = self._recorder
        if reading.status is RangeStatus.OK and reading.range_m is not None:
            try:
                self.lrf_range.append(reading.t_host_ns, reading.range_m)
            except ValueError:
                log.warning("rangefinder reading out of order dropped from the history")
            self._stop_input(lambda: self.stop_detector.add_reading(reading))
        if rec is not None:
            rec.add_range(reading)

    def _on_fix(self, fix: GpsFix) -> None:
        with self._lock:
            self._last_fix = fix
            rec = self._recorder
        if fix.utc is not None and fix.has_fix:
            self.clock.update_from_gps(fix.t_host_ns, fix.utc)
        site = self.config.site
        if site is not None:
            r = gps_slant_range_m(fix, site)
            if r is not None:
                try:
                    self.gps_range.append(fix.t_host_ns, r)
                except ValueError:
                    log.warning("GPS fix out of order dropped from the history")
                self._stop_input(lambda: self.stop_detector.add_fix(fix, site))
            self._cue_cameras(fix)
        if rec is not None:
            rec.add_gps(fix)

    def _cue_cameras(self, fix: GpsFix) -> None:
        """Project the drone's GPS position into every pointed camera: the tracker uses it to
        reacquire a lost drone (paper section 4), the display draws it as a marker."""
        for name, (x, y) in self.projector.pixels(fix).items():
            self.pipelines[name].cue(x, y)

    def _stop_input(self, feed: Callable[[], object]) -> None:
        with self._lock:
            try:
                stop = feed()
            except ValueError as exc:
                log.warning("stop detector refused a reading: %s", exc)
                return
            rec = self._recorder
        if stop is not None and rec is not None:
            kind = "stop_ended" if stop.t_end_ns is not None else "stop_detected"
            rec.add_event(
                kind,
                payload={
                    "stop": stop.index,
                    "lrf_range_m": stop.lrf_range_m,
                    "gps_range_m": stop.gps_range_m,
                },
            )

    def _record_row(self, row: StopRow) -> None:
        """A final stop-table row goes into the recording (called under the session lock)."""
        rec = self._recorder
        if rec is not None:
            payload = dataclasses.asdict(row)
            payload = {
                k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in payload.items()
            }
            rec.add_event("stop_summary", camera=row.camera, payload=payload)

    def _follow_sky(self, camera: str, t_ns: int) -> None:
        """With a calibration, the model's background input follows the measured sky
        temperature (paper sections 8-9), re-evaluated at most every 2 s, on a 0.5 K change."""
        pipe = self.pipelines[camera]
        predictor = self.predictor
        if pipe.sky is None or not hasattr(predictor, "set_background"):
            return
        last = self._sky_checked.get(camera, 0)
        if t_ns - last < 2_000_000_000:
            return
        self._sky_checked[camera] = t_ns
        temp = pipe.sky.mean_temp_k(last=100)
        current = predictor.background_temp_k.get(camera)
        if math.isfinite(temp) and (current is None or abs(temp - current) > 0.5):
            predictor.set_background(camera, temp)

    def _on_measurement(self, m: Measurement, frame: RingFrame) -> None:
        self.stop_table.add(m.camera, m.t_host_ns, m.result)
        self._follow_sky(m.camera, m.t_host_ns)
        if m.t_host_ns - self._table_checked > 1_000_000_000:
            # Rows become final here even when no display asks for the table, so they are
            # recorded as they complete.
            self._table_checked = m.t_host_ns
            self.stops()
        with self._lock:
            listeners = list(self._measurement_listeners)
        for cb in listeners:
            cb(m, frame)

    # ------------------------------------------------------------------ status
    def latest_frame(self, camera: str) -> RingFrame | None:
        return self.pipeline(camera).latest_frame()

    def status(self) -> SessionStatus:
        cams = {n: p.status() for n, p in self.pipelines.items()}
        with self._lock:
            lrf_last, fix, rec = self._last_lrf, self._last_fix, self._recorder
        now = time.monotonic_ns()
        lrf_age = None if lrf_last is None else (now - lrf_last.t_host_ns) / 1e9
        gps_latest = self.gps_range.latest()
        rec_status = RecordingStatus()
        if rec is not None:
            st = rec.status()
            rec_status = RecordingStatus(
                st.state, st.path, st.bytes_written, st.free_bytes, st.error or ""
            )
        alarms = []
        for dev in (self.lrf, self.gps, *(p.device for p in self.pipelines.values())):
            if dev is None:
                continue
            s = dev.status()
            if s.state in ("stale", "disconnected", "failed") and self._started:
                alarms.append(
                    f"{s.name}: {s.state}" + (f" ({s.last_error})" if s.last_error else "")
                )
        if rec_status.state == "failed":
            alarms.append(f"recording: {rec_status.message}")
        return SessionStatus(
            cameras=cams,
            lrf=self.lrf.status() if self.lrf else None,
            lrf_range_m=lrf_last.range_m if lrf_last else None,
            lrf_age_s=lrf_age,
            gps=self.gps.status() if self.gps else None,
            gps_fix=fix,
            gps_range_m=gps_latest[1] if gps_latest else None,
            recording=rec_status,
            alarms=tuple(alarms),
        )

    # ------------------------------------------------------------------ record helpers
    def _event(
        self, kind: str, *, camera: str = "", payload: dict | None = None, t_host_ns=None
    ) -> None:
        with self._lock:
            rec = self._recorder
        if rec is not None:
            rec.add_event(kind, camera=camera, payload=payload or {}, t_host_ns=t_host_ns)

    def _config_record(self) -> dict[str, Any]:
        return {
            "session": self.config.raw,
            "stop_detection": dataclasses.asdict(self.stop_detector.config),
            "track": self.track,
            "host_free_bytes": shutil.disk_usage(".").free,
        }
