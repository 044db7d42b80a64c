"""The live Session: the one object the CLI and the GUI drive on real (or simulated) devices. No Qt.

It owns the devices of a :class:`snrmon.acquisition.config.SessionConfig` and feeds the session's
engine (:class:`snrmon.acquisition.engine.session_engine.SessionEngine`, the same engine a replay
feeds from a recording): each camera through a
:class:`snrmon.acquisition.runtime.camera_pipeline.CameraPipeline` (device -> ring -> engine ->
recorder), the rangefinder and GPS readings from their device threads. While recording it writes
everything raw, plus what the engine decided that a replay must apply again (stop events, final
rows, the model background following the sky). Commands: start/stop, set the ROI per camera,
start/stop recording, mark a stop, add a note. Reading: status snapshots and the latest frame per
camera.

Its parts, one job each: the pipelines and the engine, the GPS and rangefinder
(:class:`~snrmon.acquisition.runtime.range_devices.RangeDevices`), every device's health
(:class:`~snrmon.acquisition.runtime.device_watch.DeviceWatch`) and the recording in progress
(:class:`~snrmon.acquisition.runtime.current_recording.CurrentRecording`).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from snrmon.acquisition.calibrate.flight_psf import FlightPsf
from snrmon.acquisition.calibrate.stop_phases import stop_phase_readings
from snrmon.acquisition.compression import stored_compression
from snrmon.acquisition.config import SessionConfig, camera_device
from snrmon.acquisition.engine.inputs import Measurement
from snrmon.acquisition.engine.session_engine import SessionEngine
from snrmon.acquisition.engine.status import (
    CameraStatus,
    RecordingStatus,
    SessionStatus,
    lost_device,
)
from snrmon.acquisition.prediction import (
    MeasuredNoise,
    ModelRequest,
    Predictor,
    Weather,
    config_predictor,
    measured_noise_record,
)
from snrmon.acquisition.protocols import RecordingWriter
from snrmon.acquisition.record.recorder import SessionRecorder
from snrmon.acquisition.record.recorder_status import disk_time_left_s
from snrmon.acquisition.runtime.camera_pipeline import CAMERA_GAP, WRONG_SHAPE, CameraPipeline
from snrmon.acquisition.runtime.current_recording import CurrentRecording
from snrmon.acquisition.runtime.device_watch import DeviceError, DeviceLoss, DeviceWatch
from snrmon.acquisition.runtime.interpreter import LiveInterpreter
from snrmon.acquisition.runtime.range_devices import (
    DEFAULT_START_TIMEOUT_S,
    RangeDevices,
    SerialDeviceSettings,
)
from snrmon.acquisition.stops.detector import Stop, StopConfig
from snrmon.acquisition.stops.table import StopRow, row_fields
from snrmon.acquisition.streams.ring import RING_OVERRUN, RingFrame
from snrmon.acquisition.streams.timebase import ClockMap
from snrmon.drivers.device import Device, DeviceStatus
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.rangefinder.reading import RangeReading

log = logging.getLogger(__name__)
DROP_ALARM_S = 5.0
"""How long (s) the banner keeps a camera's drop alarm after its last lost frame."""
__all__ = [
    "DEFAULT_START_TIMEOUT_S",
    "DeviceError",
    "DeviceLoss",
    "Session",
    "row_payload",
    "stop_payload",
]


def stop_payload(stop: Stop) -> dict:
    """A stop as recorded in its events (format 2: with its times, so a replay can use it)."""
    return {
        "stop": stop.index,
        "t_start_ns": stop.t_start_ns,
        "t_end_ns": stop.t_end_ns,
        "t_confirmed_ns": stop.t_confirmed_ns,
        "manual": stop.manual,
        "lrf_range_m": stop.lrf_range_m,
        "gps_range_m": stop.gps_range_m,
    }


def row_payload(row: StopRow) -> dict:
    """A stop-table row as a JSON object (non-finite numbers as null)."""
    payload = row_fields(row)
    for k, v in payload.items():
        if isinstance(v, float) and not math.isfinite(v):
            payload[k] = None
    payload["model_snr"] = {
        k: (v if math.isfinite(v) else None) for k, v in row.model.model_snr.items()
    }
    if row.reading.frame_means:  # the declared per-frame means (none: the payload as before)
        payload["frame_means"] = {
            k: (v if math.isfinite(v) else None) for k, v in row.reading.frame_means.items()
        }
    else:
        del payload["frame_means"]
    payload["expected_eq4_rule"] = row.expected_eq4_rule  # which model_snr reading applies
    return payload


class Session:
    """A collection session. ``cameras``/``gps``/``lrf`` override what the config would open
    (tests, HIL); ``shapes`` gives frame shapes the config does not. ``lossless``: the cameras
    are sources that can wait (simulated ones): the pipelines and the recorder pace them
    instead of dropping a frame (:class:`CameraPipeline`)."""

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
        model_from_config: bool = False,
        lossless: bool = False,
    ) -> None:
        self.config = config
        if predictor is None and model_from_config:
            # Asynchronous: the measured sky's new curves are computed beside the cameras'
            # measurement threads (0.3 s of model each time), not on them.
            predictor = config_predictor(config, asynchronous=True)
        self.lossless = lossless
        self.track = track
        self.clock = clock or ClockMap()
        self.recording = CurrentRecording()
        all_shapes = {
            cam.name: (shapes or {}).get(cam.name) or self._shape_of(cam) for cam in config.cameras
        }
        self.engine = SessionEngine(
            config, all_shapes, track=track, stop_config=stop_config, predictor=predictor
        )
        self.engine.sink = self
        self.pipelines: dict[str, CameraPipeline] = {}
        for cam in config.cameras:
            device = (cameras or {}).get(cam.name) or camera_device(cam)
            pipe = CameraPipeline(cam.name, device, self.engine, lossless=lossless)
            if cam.calibration:
                pipe.set_calibration(self._calibration(cam, all_shapes[cam.name]))
            self.pipelines[cam.name] = pipe
        # The PSF fitted from the flight's unresolved stops as each is final (the model's
        # corrected PSF from then on, unless the config keeps the preset's: model_psf).
        self.flight_psf = FlightPsf(
            self.engine,
            self.pipelines,
            calibration_of=lambda name: self.pipelines[name].corrector.calibration,
            adopt=config.model_psf == "fitted",
        )
        # A final unresolved row's expected reading over its own frames' sub-pixel phases.
        stop_phase_readings(self.engine, self.flight_psf)
        self.ranges = RangeDevices(
            SerialDeviceSettings.of(config.gps, "gps"),
            SerialDeviceSettings.of(config.lrf, "lrf"),
            gps=gps,
            lrf=lrf,
        )
        if self.ranges.gps is not None:
            self.ranges.gps.subscribe(self._on_fix)
        if self.ranges.lrf is not None:
            self.ranges.lrf.subscribe(self._on_range)
        self._started = False
        # camera -> (frames lost, when that count last grew)
        self._drops_seen: dict[str, tuple[int, float]] = {}
        self.met_readings: Weather | None = config.weather  # the day's met readings the model uses
        # per camera, the measured 3D noise the model uses in place of its own (none: its own)
        self.measured_noise: dict[str, MeasuredNoise] = {}
        self._interpreter = LiveInterpreter()  # switch interval and BLAS threads, while we run
        # Every device's health, watched from start() to stop(): a lost one is never silent.
        self.watch = DeviceWatch(self.clock, self.recording.event)
        for dev in self.devices().values():
            dev.subscribe_status(self.watch.on_status)

    # ------------------------------------------------------------------ construction helpers
    @staticmethod
    def _shape_of(cam) -> tuple[int, int]:
        if cam.width_px and cam.height_px:
            return int(cam.height_px), int(cam.width_px)
        from snrmon.model.presets import load_sensor  # the sensor preset knows the array format

        sensor = load_sensor(cam.sensor)
        return int(sensor.height_px), int(sensor.width_px)

    @staticmethod
    def _calibration(cam, shape: tuple[int, int]):
        from snrmon.acquisition.calibrate.calibration_file import load_calibration
        from snrmon.model.presets import load_sensor

        # Checked against the camera's sensor (camera, band, integration time) and frame size:
        # a calibration of another camera or band is refused, nothing applied.
        return load_calibration(cam.calibration, load_sensor(cam.sensor), frame_shape=shape)

    @property
    def gps(self) -> Device | None:
        """The GPS receiver (None: the session has none)."""
        return self.ranges.gps

    @property
    def lrf(self) -> Device | None:
        """The laser rangefinder (None: the session has none)."""
        return self.ranges.lrf

    @property
    def last_recording(self):
        """The summary of the last recording closed (None: none yet)."""
        return self.recording.last_summary

    # ------------------------------------------------------------------ the engine's parts
    @property
    def predictor(self) -> Predictor | None:
        return self.engine.predictor

    @predictor.setter
    def predictor(self, predictor: Predictor | None) -> None:
        self.engine.predictor = predictor

    @property
    def reference_predictor(self) -> Predictor | None:
        """The model at its own background beside :attr:`predictor` (the engine's)."""
        return self.engine.reference_predictor

    def set_model(self, request: ModelRequest, *, reference_only: bool = False) -> None:
        """The model the operator asked for, built by the engine
        (:meth:`SessionEngine.set_model`); a ValueError changes nothing."""
        self.engine.set_model(request, reference_only=reference_only)

    @property
    def stop_table(self):
        return self.engine.stop_table

    def model_sky_temp_k(self, camera: str) -> float | None:
        """The measured sky temperature (K) ``camera``'s model background follows (None: the
        model's own), as the engine follows it."""
        return self.engine.model_sky_temp_k(camera)

    @property
    def stop_detector(self):
        return self.engine.stop_detector

    def devices(self) -> dict[str, Device]:
        """Every device of the session by its name: the cameras, then the GPS and rangefinder."""
        out: dict[str, Device] = {n: p.device for n, p in self.pipelines.items()}
        out.update((dev.name, dev) for dev in self.ranges.present())
        return out

    def start_timeouts_s(self) -> dict[str, float]:
        """Each device's start-up timeout (s): its table's ``start_timeout_s`` or
        :data:`DEFAULT_START_TIMEOUT_S`."""
        out = {
            c.name: float(c.start_timeout_s or DEFAULT_START_TIMEOUT_S) for c in self.config.cameras
        }
        return {**out, **self.ranges.start_timeouts_s()}

    # ------------------------------------------------------------------ control
    def start(self) -> None:
        """Open every device and start the pipelines; a device that fails is retried (with
        back-off, :class:`snrmon.drivers.device.Device`). From here to :meth:`stop` a device
        that stops delivering is a :class:`DeviceLoss`. The interpreter runs with the live
        settings of :mod:`snrmon.acquisition.runtime.interpreter` until :meth:`stop`."""
        self._interpreter.apply()
        for pipe in self.pipelines.values():
            pipe.warm_up()  # a first run compiles (seconds): before any device's timeout runs
        self.watch.start()
        self.ranges.open()
        for pipe in self.pipelines.values():
            pipe.start()
        self._started = True

    def wait_delivering(self) -> None:
        """Return once every device has delivered a reading; raise :class:`DeviceError`
        naming each device that gave none within its start-up timeout (from its opening in
        :meth:`start`, after the pipelines' warm-up),
        with its last error (a ring or port that does not exist, a link that gives nothing)."""
        self.watch.wait_delivering(self.devices(), self.start_timeouts_s())

    def devices_lost(self) -> list[DeviceLoss]:
        """The devices lost since :meth:`start`, in the order they were lost."""
        return self.watch.losses()

    def check_devices(self) -> None:
        """Raise :class:`DeviceError` naming every device lost since :meth:`start` (a
        command that lost one never ends as if all went well)."""
        lost = self.devices_lost()
        if lost:
            raise DeviceError("; ".join(loss.describe() for loss in lost))

    def stop(self) -> None:
        """Stop recording (if on), the pipelines and the devices."""
        self.watch.stop()  # closing a device is not losing it
        for pipe in self.pipelines.values():
            pipe.stop()
        self.ranges.close()
        self._started = False
        self.stop_recording()
        self._interpreter.restore()

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

    def clear_roi(self, camera: str) -> None:
        """The operator releases ``camera``'s track: it stops measuring until the next click
        (recorded as "roi_cleared" at the frame it takes effect on)."""
        self.pipeline(camera).clear_roi()

    def capture_reference(self, camera: str, n_frames: int = 64) -> None:
        """Average the next ``n_frames`` of ``camera`` (clear sky, no drone in view) into the
        background reference that removes its fixed-pattern noise before Eq. (4)."""
        self.pipeline(camera).capture_reference(n_frames)
        self._event("reference_requested", camera=camera, payload={"n_frames": int(n_frames)})

    def mark_stop(self) -> None:
        """The operator says the drone is hovering at a stop now."""
        self.engine.mark_stop(time.monotonic_ns())

    def stops(self) -> list[StopRow]:
        """The SNR-versus-range table so far (one row per stop and camera)."""
        return self.engine.stops()

    def set_met_readings(self, weather: Weather) -> None:
        """The day's met readings (a ``snrmon.model.atmosphere_table.Weather``, e.g. typed in
        the console's model dialog): the model's atmosphere from now on for every camera, and a
        ``met_readings`` event in the recording that a replay applies at the same time."""
        payload = weather.as_dict()
        self.met_readings = weather
        for name in self.pipelines:
            self.engine.apply_model_input(name, "met_readings", payload)
        # after the last frame any camera measured with the old readings (as model_noise): a
        # replay applies it there, so a stop row frozen after the change uses the new ones
        seen = [t for t in map(self.engine.model_input_ns, self.pipelines) if t is not None]
        t_ns = max(seen) if seen else time.monotonic_ns()
        self._event("met_readings", payload=payload, t_host_ns=t_ns)

    def set_measured_noise(self, camera: str, noise: MeasuredNoise | None) -> None:
        """``camera``'s measured 3D noise (a ``snrmon.model.noise.MeasuredNoise``: sigma_tvh
        and sigma_vh of the background around the target, the console's "measured noise") in
        place of the model's noise from now on; None: the model's own again. Recorded as a
        ``model_noise`` event that a replay applies at the same time."""
        self.pipeline(camera)  # a ValueError naming a camera the session does not have
        if noise is not None and not isinstance(noise, MeasuredNoise):
            raise ValueError(f"{camera}: a measured noise must be a MeasuredNoise, got {noise!r}")
        payload = measured_noise_record(noise)
        others = {c: n for c, n in self.measured_noise.items() if c != camera}
        self.measured_noise = others if noise is None else {**others, camera: noise}
        self.engine.apply_model_input(camera, "model_noise", payload)
        # at the last frame measured with the model as it was: a replay applies it after that
        # frame, so a stop row frozen after the change has the new noise there too
        t_ns = self.engine.model_input_ns(camera)
        t_ns = time.monotonic_ns() if t_ns is None else t_ns
        self._event("model_noise", camera=camera, payload=payload, t_host_ns=t_ns)

    def add_note(self, text: str) -> None:
        self._event("note", payload={"text": text})

    def add_event(self, kind: str, *, camera: str = "", payload: dict | None = None) -> None:
        """Record an event of ``kind`` (nothing when not recording), e.g. the HIL rig's flight."""
        self._event(kind, camera=camera, payload=payload)

    def add_measurement_listener(
        self, cb: Callable[[Measurement, np.ndarray | None], None]
    ) -> None:
        """``cb(measurement, pixels)`` on each camera's measurement thread after every measured
        frame (the raw pixels are valid during the call only)."""
        self.engine.add_listener(cb)

    def start_recording(self, path: str | Path, **recorder_options: Any) -> None:
        """Record everything from now on into one HDF5 session file (a new file);
        ``recorder_options`` go to :class:`SessionRecorder` (backlog limit; compression, else the
        config's ``compression``)."""
        current = self.recording.recorder()
        if current is not None and current.status().state == "recording":
            raise ValueError(f"already recording to {current.path}")
        shapes = {n: p.shape for n, p in self.pipelines.items()}
        recorder_options.setdefault("compression", stored_compression(self.config.compression))
        if self.lossless:
            recorder_options.setdefault("backlog_wait_s", 30.0)
        from snrmon.acquisition.calibrate.calibration_file import calibration_record

        calibrations = {
            name: calibration_record(pipe.corrector.calibration)
            for name, pipe in self.pipelines.items()
            if pipe.corrector.calibration is not None
        }
        rec = SessionRecorder(
            path,
            config=self._config_record(),
            cameras=shapes,
            clock=self.clock,
            calibrations=calibrations,
            **recorder_options,
        )
        self.recording.log_beside(path)
        for pipe in self.pipelines.values():
            if pipe.name in calibrations:
                meta = dict(calibrations[pipe.name][0])
                meta["path"] = next(
                    c.calibration for c in self.config.cameras if c.name == pipe.name
                )
                rec.add_event("calibration", camera=pipe.name, payload=meta)
        if self.met_readings is not None and self.met_readings != self.config.weather:
            # typed before the recording began: the file holds them from its start
            rec.add_event("met_readings", payload=self.met_readings.as_dict())
        for name, noise in self.measured_noise.items():  # likewise the measured noise
            rec.add_event("model_noise", camera=name, payload=measured_noise_record(noise))

        def attach() -> None:
            # With the detector held: the stops so far are part of the record, and every change
            # after them reaches the recorder (none falls between the two).
            self.recording.attach(rec)
            for stop in self.engine.stop_detector.stops:
                self.stop_changed("stop_known", stop, rec)

        self.engine.with_stops_held(attach)
        for pipe in self.pipelines.values():
            # Each pipeline records the stop table's history before its first recorded frame.
            pipe.attach_recorder(rec)

    def stop_recording(self):
        """Finish the file; returns the recorder's summary (None when not recording)."""
        rec = self.recording.recorder()
        if rec is None:
            return None
        if not self._started:  # the session ended: its open rows are final as they stand
            self.engine.finalize()
        else:  # the session goes on: the rows as they stand now are part of the record too
            for row in self.engine.stops():
                if not row.final and row.reading.n_frames:
                    rec.add_event("stop_summary", camera=row.camera, payload=row_payload(row))
        self.recording.detach()
        for pipe in self.pipelines.values():
            pipe.detach_recorder()
        try:
            # Every frame received accounted for in the file: once everything is written.
            self.recording.last_summary = rec.stop(
                accounting=lambda: {
                    n: p.accounting(rec).as_record() for n, p in self.pipelines.items()
                },
                devices_lost=lambda: [x.as_dict() for x in self.devices_lost()],
            )
        finally:
            self.recording.close_log()
        return self.recording.last_summary

    # ------------------------------------------------------------------ the engine's sink
    def stop_changed(self, kind: str, stop: Stop, rec: RecordingWriter | None = None) -> None:
        rec = rec or self._current_recorder()
        if rec is not None:
            rec.add_event(kind, payload=stop_payload(stop))

    def row_final(self, row: StopRow) -> None:
        """A final stop-table row goes into the recording (before the PSF its frames may give)."""
        rec = self._current_recorder()
        if rec is not None:
            rec.add_event("stop_summary", camera=row.camera, payload=row_payload(row))
        self.flight_psf.on_row_final(row)

    def model_changed(self, camera: str, kind: str, payload: dict, t_host_ns: int) -> None:
        rec = self._current_recorder()
        if rec is not None:
            rec.add_event(kind, camera=camera, payload=payload, t_host_ns=t_host_ns)

    def _current_recorder(self) -> RecordingWriter | None:
        return self.recording.recorder()

    # ------------------------------------------------------------------ devices
    def range_at(self, t_host_ns: int) -> tuple[float | None, str]:
        """The range for a frame received at ``t_host_ns`` (the engine's rule)."""
        return self.engine.range_at(t_host_ns)

    def _on_range(self, reading: RangeReading) -> None:
        self.ranges.range_taken(reading)
        rec = self.recording.recorder()
        self.engine.on_range(reading)
        if rec is not None:
            rec.add_range(reading)

    def _on_fix(self, fix: GpsFix) -> None:
        self.ranges.fix_taken(fix)
        rec = self.recording.recorder()
        if fix.utc is not None and fix.has_fix:
            self.clock.update_from_gps(fix.t_host_ns, fix.utc)
        self.engine.on_fix(fix)
        if rec is not None:
            rec.add_gps(fix)

    # ------------------------------------------------------------------ status
    def latest_frame(self, camera: str) -> RingFrame | None:
        return self.pipeline(camera).latest_frame()

    def status(self) -> SessionStatus:
        cams = {n: p.status() for n, p in self.pipelines.items()}
        lrf_last, fix = self.ranges.latest()
        rec = self.recording.recorder()
        now = time.monotonic_ns()
        lrf_age = None if lrf_last is None else (now - lrf_last.t_host_ns) / 1e9
        gps_latest = self.engine.gps_range.latest()
        rec_status = RecordingStatus()
        if rec is not None:
            st = rec.status()
            meter = self.recording.write_rate(rec)
            rate = meter.add(time.monotonic(), st.bytes_written)
            rec_status = RecordingStatus(
                st.state,
                st.path,
                st.bytes_written,
                st.free_bytes,
                st.error or "",
                backlog_bytes=st.backlog_bytes,
                dropped_frames=sum(sum(d.values()) for d in st.dropped.values()),
                compression_ratio=st.compression_ratio,
                elapsed_s=time.monotonic() - meter.t0_s,
                rate_bytes_s=rate,
                time_left_s=disk_time_left_s(st.free_bytes, rate),
            )
        alarms = []
        for dev in (self.lrf, self.gps, *(p.device for p in self.pipelines.values())):
            if dev is None:
                continue
            s = dev.status()
            # lost as the headers say it (connecting again after readings included): the
            # driver's reconnecting is no recovery, the banner must not turn "BACK"
            if self._started and lost_device("", s) is not None:
                alarms.append(
                    f"{s.name}: {s.state}" + (f" ({s.last_error})" if s.last_error else "")
                )
        if rec_status.state == "failed":
            alarms.append(f"recording: {rec_status.message}")
        elif rec_status.dropped_frames:
            alarms.append(
                f"recording: {rec_status.dropped_frames} frames dropped (the disk is not keeping "
                f"up; backlog {rec_status.backlog_bytes / 2**20:.0f} MiB)"
            )
        now_s = time.monotonic()
        for name, pipe in self.pipelines.items():  # frames lost before the recorder: never silent
            drops = pipe.drops()
            gap, ring, wrong = (drops[k] for k in (CAMERA_GAP, RING_OVERRUN, WRONG_SHAPE))
            lost = gap + ring + wrong
            seen, since = self._drops_seen.get(name, (0, -math.inf))
            if lost > seen:
                self._drops_seen[name] = (lost, now_s)
                since = now_s
            # an alarm while frames are being lost (and DROP_ALARM_S after); the count stays
            # in the status panel, the log and the recording
            if lost and now_s - since <= DROP_ALARM_S:
                shape = f", wrong shape {wrong}" if wrong else ""
                alarms.append(
                    f"{name} frames: {lost} dropped (camera {gap}, ring overrun {ring}{shape})"
                )
        lrf_st = self.lrf.status() if self.lrf else None
        gps_st = self.gps.status() if self.gps else None
        if self._started:
            cams = self._with_losses(cams, lrf_st, gps_st)
        return SessionStatus(
            cameras=cams,
            lrf=lrf_st,
            lrf_range_m=lrf_last.range_m if lrf_last else None,
            lrf_age_s=lrf_age,
            gps=gps_st,
            gps_fix=fix,
            gps_range_m=gps_latest[1] if gps_latest else None,
            recording=rec_status,
            alarms=tuple(alarms),
        )

    def _with_losses(
        self,
        cams: dict[str, CameraStatus],
        lrf: DeviceStatus | None,
        gps: DeviceStatus | None,
    ) -> dict[str, CameraStatus]:
        """Each camera's status with the devices its numbers depend on that are lost now (its
        own camera, the rangefinder, the GPS), for its header. The recording's ``device_lost``
        / ``device_back`` events come from the devices' own state changes
        (:meth:`_on_device_status`), once each way, not from whoever asks for a status."""
        shared = tuple(d for d in (lost_device("LRF", lrf), lost_device("GPS", gps)) if d)
        out = {}
        for name, cs in cams.items():
            own = lost_device("camera", cs.device)
            lost = ((own,) if own else ()) + shared
            out[name] = dataclasses.replace(cs, lost=lost) if lost else cs
        return out

    # ------------------------------------------------------------------ record helpers
    def _event(
        self, kind: str, *, camera: str = "", payload: dict | None = None, t_host_ns=None
    ) -> None:
        self.recording.event(kind, camera=camera, payload=payload, t_host_ns=t_host_ns)

    def _config_record(self) -> dict[str, Any]:
        return {
            "session": self.config.raw,
            "stop_detection": dataclasses.asdict(self.engine.stop_detector.config),
            "track": self.track,
            "host_free_bytes": shutil.disk_usage(".").free,
        }
