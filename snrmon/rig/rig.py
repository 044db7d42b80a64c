"""Hardware-in-loop wiring: simulated devices on real interfaces feeding a real Session.

The CLI's job is to wire packages together; this module does it for ``snrmon hil`` and
``snrmon demo``. The simulators come from :mod:`snrmon.sim` (camera processes writing shared-memory
frame rings, NMEA GPS and an LDM rangefinder on pseudo-terminals); the console side is the
ordinary :class:`snrmon.acquisition.runtime.session.Session`, which opens those devices by name and
path exactly as it would open real ones. The flight clock is the day's own
(:class:`snrmon.rig.flight_clock.FlightClock`): ``speed`` x the host clock, held back by the
console's pace; each camera process publishes frame ``n`` when it reads ``n / fps`` and the serial
simulators report the flight at its time, and the session is lossless (its pipelines and
recorder wait rather than drop): a simulated day never drops a frame, it slows down.
"""

from __future__ import annotations

import functools
import logging
import math
import os
import tempfile
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.runtime.session import Session
from snrmon.acquisition.stops.detector import StopConfig
from snrmon.acquisition.track.config import TrackState
from snrmon.drivers.lifetime import die_with_parent
from snrmon.model.constants import ZERO_C_K
from snrmon.rig.flight_clock import MAX_SPEED, FlightClock
from snrmon.rig.twin_day import calibrate_cameras, camera_feeds

log = logging.getLogger(__name__)


@dataclass
class HilOptions:
    seed: int = 0
    speed: float = 1.0
    stops_m: tuple[float, ...] = (37.0, 126.0, 199.0, 336.0, 393.0, 451.0, 508.0)
    cameras: tuple[str, ...] = ("mwir", "lwir")
    target: str = "uav1"
    size: str = "small"
    hover_s: float = 7.0
    transit_mps: float = 8.0
    start_range_m: float = 10.0
    preroll_s: float = 5.0  # empty sky before launch (with fpn: the background reference)
    reference_frames: int = 64
    sky_temp_k: float = 280.0  # the scenario's clear sky (apparent temperature)
    air_temp_k: float = 288.15  # the scenario's air along the path
    rh_percent: float | None = None  # the scenario's met readings (None: the season's)
    pressure_hpa: float | None = None
    visibility_km: float | None = 23.0  # the rural aerosol's (None: no aerosol)
    aerosol: str = "rural"  # "none": no aerosol
    calibrate: bool = True  # blackbody frames and a calibration before the flight
    speed_max: bool = False  # --speed max: ``speed`` is the cap, the console's pace the rest
    window_px: tuple[int, int] | None = None  # a sub-array (width, height) around the sight line
    fpn: bool = False
    track: bool = True
    out: str | None = None
    compression: str | None = None  # the recording's frame filter (None: the config's default)
    adopt_psf: bool = True  # the model takes the PSF fitted as each unresolved stop is final
    footprint: str = "square"  # the model's small target: the paper's square, or "outline"

    def __post_init__(self) -> None:
        self.weather  # a bad met reading is refused here, before any device starts  # noqa: B018

    @property
    def weather(self):
        """The day's met readings, what the field team reads and tells the model (and the
        twin's atmosphere)."""
        from snrmon.model.atmosphere_table import Weather

        return Weather(
            air_temp_c=round(self.air_temp_k - ZERO_C_K, 6),
            rh_percent=self.rh_percent,
            pressure_hpa=self.pressure_hpa,
            visibility_km=self.visibility_km,
            aerosol=self.aerosol,
        )

    def flight_config(self):
        """The simulated flight (:class:`snrmon.sim.flight.FlightConfig`) of these options."""
        from snrmon.sim.flight import FlightConfig

        return FlightConfig(
            stops_m=tuple(self.stops_m),
            hover_s=self.hover_s,
            speed_mps=self.transit_mps,
            start_range_m=self.start_range_m,
            seed=self.seed,
        )

    @property
    def scenario(self):
        from snrmon.sim.twin import Scenario

        return Scenario(
            sky_temp_k=self.sky_temp_k, air_temp_k=self.air_temp_k, weather=self.weather
        )


ADAPT_S = 2.0
"""How often (host seconds) the day's free speed follows what the console held over the last
``ADAPT_S``: down to 1.1 x that where it held less than 80% of it, up by a quarter (never past
the speed asked, 8 for max) where it held all of it. The stop detector's "steady for 3 s of
flight" follows the speed, so the rate the readings come at and the detector's window agree."""
SPEAK_FRACTION = 0.8
"""A serial simulator speaks once the day's clock moved at least this fraction of what one of
its ticks (0.1 s) covers at the current speed: a drone that crawls because the console is slow
never reads as a hover (three readings span at least 0.24 s of flight at speed 1)."""

HELD_SILENCE_S = 15.0
"""How long (host s) a simulated device may be silent before it is stale (lost): the day's
clock, held back by a busy console, holds every simulator with it."""

LOG_S = 120.0
"""Host seconds of measurements the rig keeps per camera for its truth bookkeeping. A stop's
row is summarised the moment the console freezes it (within a step of the rig), long before its
frames leave this window, so a long hover (the hour of ``snrmon bench``'s soak) costs no more
memory than a short one."""


@dataclass
class CameraRig:
    name: str
    sensor: object
    feed: object
    producer: object
    fps: float
    log: deque  # (t_host_ns, counter, raw running mean, raw running std), LOG_S long


class SerialSimulators:
    """The day's GPS receiver (NMEA) and rangefinder (LDM) on pseudo-terminals: they report the
    flight at the day's clock, and speak only when it moves (while the console holds the clock
    the drone is frozen in time: a device that kept reading would show a hover where there is
    none)."""

    def __init__(self, clock: FlightClock, plan, preroll_s: float) -> None:
        from snrmon.sim.devices.ldm_sim import LdmSimulator
        from snrmon.sim.devices.nmea_sim import NmeaSimulator

        self.clock = clock
        self.plan = plan
        self.preroll_s = preroll_s
        self.gps = NmeaSimulator(self._gps_position, rate_hz=10.0, baud=38400)
        self.lrf = LdmSimulator(self._lrf_range, rate_hz=10.0, tracking=True)
        self._gate_tau: dict[str, float] = {}
        self.gps.gate = lambda: self._clock_moved("gps")
        self.lrf.gate = lambda: self._clock_moved("lrf")

    def session_tables(self) -> dict:
        """The session config's ``gps`` and ``lrf`` tables that open them."""
        return {
            "gps": {"protocol": "nmea", "port": self.gps.path, "baud": 38400},
            "lrf": {"protocol": "ldm", "port": self.lrf.path, "baud": 9600},
        }

    def start(self) -> None:
        self.gps.start()
        self.lrf.start()

    def stop(self) -> None:
        self.gps.stop()
        self.lrf.stop()

    def _gps_position(self, t_s: float):
        # A receiver reports where the drone was at the epoch its sentence is labelled with
        # (``t_s`` on the simulator's clock), not where it is when the simulator's thread gets
        # to run: on a loaded machine that is milliseconds later (0.1 m at 4x in a transit).
        due_ns = round((self.gps.started_monotonic_s + t_s) * 1e9)
        t = self.clock.at(due_ns) - self.preroll_s
        return None if t < 0 else self.plan.position(t)  # no fix before launch

    def _lrf_range(self, _t_s: float) -> float | None:
        t = self.clock.now() - self.preroll_s
        return None if t < 0 else self.plan.range_m(t)  # no target before launch

    def _clock_moved(self, device: str, tick_s: float = 0.1) -> bool:
        """True when the day's clock moved enough since ``device`` last spoke
        (:data:`SPEAK_FRACTION` of one of its ticks at the current speed)."""
        tau = self.clock.now()
        last = self._gate_tau.get(device)
        if last is not None and tau - last < SPEAK_FRACTION * tick_s * self.clock.speed:
            return False
        self._gate_tau[device] = tau
        return True


def day_predictor(opts: HilOptions):
    """The model as a field team would run it: it knows the met readings (air, humidity,
    pressure, visibility) and the sky it measures (calibrated before the flight); asynchronous,
    since a measurement thread asks for it."""
    from snrmon.acquisition.prediction import ModelPredictor

    return ModelPredictor(
        {c: c for c in opts.cameras},
        opts.target,
        atmosphere=opts.weather,
        asynchronous=True,
        **({} if opts.footprint == "square" else {"footprint": opts.footprint}),
    )


def _calibrations(opts: HilOptions, feeds: dict):
    """(the temporary folder holding them or None, {camera: calibration file}): the blackbody
    calibration of each camera before the flight, when asked. The files are the session's
    inputs, not its output: the recording keeps the calibration it was measured with, so the
    output folder holds only the recording and its log."""
    if not opts.calibrate:
        return None, {}
    tmp = tempfile.TemporaryDirectory(prefix="snrmon-hil-")
    seeds = {c: opts.seed + i for i, c in enumerate(opts.cameras)}
    return tmp, calibrate_cameras(feeds, seeds, Path(tmp.name), "hil")


def _camera_rigs(opts: HilOptions, feeds: dict, clock: FlightClock) -> dict[str, CameraRig]:
    """A camera process per simulated camera, writing its frame ring at the day's clock."""
    from snrmon.sim.devices.shm_camera import ShmProducer

    tag = f"{os.getpid()}-{opts.seed}"
    cameras = {}
    for cam, (sensor, feed) in feeds.items():
        producer = ShmProducer(
            f"snrmon-{cam}-{tag}",
            feed.scene.width_px,
            feed.scene.height_px,
            feed,
            fps=sensor.fps,
            # The day's clock paces the camera; it runs at most LEAD_S ahead of the
            # console's newest frame, far fewer frames than the ring holds.
            slots=max(16, math.ceil(sensor.fps * opts.speed / 2)),
            clock=clock.shared,
            # the camera process ends with this one, however it ends
            initializer=functools.partial(die_with_parent, os.getpid()),
        )
        log_len = math.ceil(LOG_S * sensor.fps * opts.speed)
        cameras[cam] = CameraRig(
            cam, sensor, feed, producer, float(sensor.fps), deque(maxlen=log_len)
        )
    return cameras


def _session_config(opts: HilOptions, flight, cameras: dict, calibrations: dict, serial):
    """The session config that opens the simulated devices by name and path, as a config file
    would name real ones. Written as the tables a TOML file gives and checked by the one
    validator: the recording keeps the config as those tables (``[simulation]`` among them,
    which the twin's truth is rebuilt from), the same as a field day's."""
    site = flight.site
    window = {}
    if opts.window_px is not None:
        window = {"width_px": int(opts.window_px[0]), "height_px": int(opts.window_px[1])}
    camera_tables = {
        c: {
            "source": "shm",
            "address": r.producer.name,
            "sensor": c,
            # The cameras look along the flight's line of sight (boresight offset 0).
            "pointing_deg": [flight.azimuth_deg, flight.elevation_deg, 0.0],
            **window,
            **({"calibration": calibrations[c]} if c in calibrations else {}),
        }
        for c, r in cameras.items()
    }
    return session_config_from_dict(
        {
            "target": opts.target,
            "site": {"lat_deg": site.lat_deg, "lon_deg": site.lon_deg, "alt_m": site.alt_m},
            "cameras": camera_tables,
            "weather": {k: v for k, v in opts.weather.as_dict().items() if v is not None},
            "simulation": {**opts.scenario.record(tuple(opts.cameras)), "seed": opts.seed},
            **serial.session_tables(),
            **({} if opts.compression is None else {"compression": opts.compression}),
            "model_psf": "fitted" if opts.adopt_psf else "preset",
            "footprint": opts.footprint,
        }
    )


def _day_session(opts: HilOptions, predictor, config) -> Session:
    """The ordinary console session on the simulated devices, lossless (its pipelines and
    recorder wait rather than drop: the day slows down instead)."""
    session = Session(
        config,
        track=opts.track,
        predictor=predictor,
        stop_config=StopConfig().at_speed(opts.speed),
        lossless=True,
    )
    for dev in session.devices().values():
        # The simulated devices fall silent while the console holds the day's clock (a busy
        # machine): that pause is the day slowing down, not a device lost; a dead camera
        # process or a closed port still is, at once.
        dev.stale_after_s = HELD_SILENCE_S
    return session


class HilRig:
    """Builds and runs the simulated collection against a Session (context manager): the
    camera processes, the serial simulators and the day's clock it drives, composed."""

    def __init__(self, opts: HilOptions, *, predictor=None) -> None:
        from snrmon.sim.flight import FlightPlan

        if opts.speed <= 0:
            raise ValueError(f"speed must be positive, got {opts.speed}")
        self.opts = opts
        self.predictor = predictor if predictor is not None else day_predictor(opts)
        self.flight_config = opts.flight_config()
        self.plan = FlightPlan(self.flight_config)
        # With fixed-pattern noise the console needs a sky reference before launch.
        self.preroll_s = opts.preroll_s if opts.fpn else 0.0
        self.t0 = time.monotonic()
        self.clock = FlightClock(opts.speed)
        self._clock_k = 0  # table points already recorded as hil_clock events
        self._speed_warned = False
        self._adapt_at: tuple[float, float] | None = None  # (host s, clock s) of the last check
        self.speed_changes: list[tuple[float, float]] = []  # (flight s, speed) as it followed
        self._finished = False
        feeds = camera_feeds(opts, self.flight_config, self.preroll_s)
        self._tmp, calibrations = _calibrations(opts, feeds)
        self.cameras = _camera_rigs(opts, feeds, self.clock)
        self.serial = SerialSimulators(self.clock, self.plan, self.preroll_s)
        config = _session_config(opts, self.flight_config, self.cameras, calibrations, self.serial)
        self.session = _day_session(opts, self.predictor, config)
        for c, r in self.cameras.items():
            self.clock.watch(c, r.fps, functools.partial(self._newest_delivered, c))
        self.session.add_measurement_listener(self._on_measurement)
        self._clicked: set[tuple[str, int]] = set()
        self._final: dict[tuple[str, int], dict] = {}  # (camera, stop) -> its result entry
        self.recording: dict | None = None  # the recording's own accounting, once closed
        self._psf_recorded = False

    # ------------------------------------------------------------------ clock and truth
    def _newest_delivered(self, camera: str) -> int | None:
        """The newest frame counter the console has of ``camera``, which holds the day's clock;
        None once the camera is lost (its process dead): it holds the day no more, and the
        other devices fly on instead of falling silent with it."""
        if any(
            x.device == camera and x.back_t_host_ns is None for x in self.session.devices_lost()
        ):
            return None
        return self.session.pipelines[camera].ring.newest_counter

    def flight_time(self) -> float:
        """Seconds since launch on the flight's clock (negative during the pre-roll)."""
        return self.clock.now() - self.preroll_s

    def _follow_console(self) -> None:
        """The day's free speed follows what the console held (:data:`ADAPT_S`)."""
        now, tau = time.monotonic(), self.clock.now()
        if self._adapt_at is None:
            self._adapt_at = (now, tau)
            return
        t0, tau0 = self._adapt_at
        if now - t0 < ADAPT_S:
            return
        self._adapt_at = (now, tau)
        held = (tau - tau0) / (now - t0)
        speed = self.clock.speed
        cap = MAX_SPEED if self.opts.speed_max else self.opts.speed
        if held < 0.8 * speed:
            new = max(0.1, math.floor(held * 1.1 * 10) / 10)
        elif held > 0.95 * speed and speed < cap:
            new = min(cap, math.ceil(speed * 1.25 * 10) / 10)
        else:
            return
        if new == speed:
            return
        self.clock.set_speed(new)
        self.session.engine.stop_detector.config = StopConfig().at_speed(new)
        self.speed_changes.append((round(self.flight_time(), 3), new))
        log.info("the simulated day follows the console: speed %g (it held %.2f)", new, held)
        self.session.add_event("hil_speed_changed", payload={"speed": new, "held": held})

    def truth_pixel(self, camera: str) -> tuple[float, float] | None:
        """Where the drone is now in ``camera`` (what the operator would click on)."""
        target = self.cameras[camera].feed.target_at(self.flight_time())
        return None if target is None else (target.x_px, target.y_px)

    def _on_measurement(self, m, pixels) -> None:
        rig = self.cameras[m.camera]
        raw = m.raw  # the raw frames' track (None: no correction on)
        mean, std = (raw.mean, raw.std) if raw is not None else (math.nan, math.nan)
        rig.log.append((m.t_host_ns, m.counter, mean, std))

    # ------------------------------------------------------------------ run
    def __enter__(self) -> HilRig:
        for pipe in self.session.pipelines.values():
            pipe.warm_up()  # a first run on a machine compiles: before the flight's clock
        for rig in self.cameras.values():
            rig.producer.start()
        self.serial.start()
        self.t0 = time.monotonic()
        if self.opts.out:
            # The file is created (exclusively) before any device opens.
            self.session.start_recording(self.opts.out)
        self.clock.start()
        self.session.start()
        if self.opts.out:
            self.session.add_event("hil_flight", payload=self.flight_record())
        if self.opts.fpn:
            for cam in self.cameras:
                self.session.capture_reference(cam, self.opts.reference_frames)
        # Every simulated device delivers within its start-up timeout, or the day stops here
        # (with everything started so far stopped: __exit__ does not run for a failed enter).
        try:
            self.session.wait_delivering()
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def flight_record(self) -> dict:
        """The simulated flight's clock and plan, recorded with the session (event
        ``hil_flight``) so the truth can be rebuilt from the file: the day's clock at host time t
        is interpolated in the ``hil_clock`` events' table (``host_ns``, ``clock_s``: camera
        seconds since ``t0_host_ns``), the flight's time is that minus ``preroll_s``; ``speed``
        is the clock's rate where the console did not hold it back; the GPS simulator's epoch k
        is due at ``gps_epoch0_host_ns + k / gps_rate_hz`` s and labelled ``gps_epoch0_utc_ns +
        k / rate``."""
        fc = self.flight_config
        return {
            "t0_host_ns": round(self.t0 * 1e9),
            "clock": "hil_clock",
            "speed": self.opts.speed,
            "preroll_s": self.preroll_s,
            "gps_epoch0_host_ns": round(self.serial.gps.started_monotonic_s * 1e9),
            "gps_epoch0_utc_ns": round(self.serial.gps.start_utc.timestamp() * 1e9),
            "gps_rate_hz": 1.0 / self.serial.gps.tick_period_s,
            "flight": {
                "stops_m": list(fc.stops_m),
                "hover_s": fc.hover_s,
                "speed_mps": fc.speed_mps,
                "start_range_m": fc.start_range_m,
                "seed": fc.seed,
            },
        }

    def finish(self) -> None:
        """The flight is over: stop the session (rows final, the recording closed with its
        accounting) before the post-flight work (the PSF fit of :meth:`result`, a report) takes
        the GIL from cameras still streaming. Once only; ``__exit__`` calls it too."""
        if self._finished:
            return
        self._finished = True
        self._record_clock()
        self._check_speed(final=True)
        self.session.stop()
        summary = getattr(self.session, "last_recording", None)
        if summary is not None:
            self.recording = summary.frames_report()

    def check_failures(self) -> None:
        """Raise the day's failure as an OSError (exit 1, one line) once it is over: a device
        lost (the session's :class:`~snrmon.acquisition.runtime.session.DeviceError`, naming
        each), the recording stopped by its disk."""
        self.session.check_devices()
        error = (self.recording or {}).get("error")
        if error:
            raise OSError(error)

    def __exit__(self, *exc: object) -> None:
        try:
            self.finish()
        finally:
            self.clock.stop()
            for rig in self.cameras.values():
                rig.producer.stop()
            self.serial.stop()
            if self._tmp is not None:
                self._tmp.cleanup()

    def step(self) -> bool:
        """Do what the operator would do now; False once the flight is over.

        The operator clicks the drone once, at the first stop. With tracking on, they click it
        again only when, at a new stop, the console says the track is lost (as the paper's
        operators did: a resolved drone at 37 m fills the 7x7 box and the track cannot hold
        it; the GPS cue usually brings it back first). Without tracking the simulator clicks at
        every stop. Every click is counted in the result.
        """
        self._summarise_final_rows()
        self._record_clock()
        self._follow_console()
        self._check_speed()
        t = self.flight_time()
        stop_idx = self.plan.truth(t).stop_index
        if stop_idx is not None:
            for cam in self.cameras:
                if self.opts.track:
                    lost = self.session.pipelines[cam].status().track_state is TrackState.LOST
                    key = (cam, 0) if (cam, 0) not in self._clicked or not lost else (cam, stop_idx)
                else:
                    key = (cam, stop_idx)
                if key not in self._clicked:
                    xy = self.truth_pixel(cam)
                    if xy is not None:
                        self.session.set_roi(cam, int(np.rint(xy[0])), int(np.rint(xy[1])))
                        self._clicked.add(key)
        return t < self.plan.duration_s

    def run(self, progress=None) -> dict:
        while self.step():
            if progress is not None:
                progress(self)
            time.sleep(0.05)  # the operator's pace, not synchronisation
        self.finish()
        return self.result()

    def _record_clock(self) -> None:
        """The day's clock since the last call, as ``hil_clock`` events (host ns -> camera s),
        in pieces that fit an event's payload."""
        host, taus = self.clock.table_since(self._clock_k)
        for i in range(0, len(host), 100):
            self.session.add_event(
                "hil_clock",
                payload={
                    "host_ns": host[i : i + 100],
                    "clock_s": [round(x, 9) for x in taus[i : i + 100]],
                },
            )
        self._clock_k += len(host)

    def _check_speed(self, *, final: bool = False) -> None:
        """A speed asked (not max) that this machine cannot hold is said once, on stderr, in the
        session's log and as a ``hil_speed`` event, as soon as 2 s of the day show it (or when
        the flight ends): the day slows down instead of dropping frames."""
        a = self.clock.achieved()
        if (
            self.opts.speed_max
            or self._speed_warned
            or not a["achieved"]
            or (not final and a.get("wall_s", 0.0) < 2.0)
        ):
            return
        if a["achieved"] < 0.95 * self.opts.speed:
            self._speed_warned = True
            log.warning(
                "this machine cannot hold speed %g: the simulated day runs at %.2f x (held back "
                "%.1f s of %.1f s by the console, its measurement or its recorder); it slows down "
                "rather than drop frames",
                self.opts.speed,
                a["achieved"],
                a["held_back_s"],
                a["wall_s"],
            )
            self.session.add_event("hil_speed", payload={"asked": self.opts.speed, **a})

    # ------------------------------------------------------------------ results
    def _summarise_final_rows(self) -> None:
        """Summarise each stop row the console has made final (its stop ended and the camera
        passed it, the model's curves current for the inputs in force then) while its frames
        are still in the rig's log. A row with its 100 frames but still open is not yet: its
        model values may still change (a sky measured moments ago, whose curves are being
        computed)."""
        for row in self.session.stops():
            key = (row.camera, row.stop)
            if row.final and key not in self._final:
                self._final[key] = self._stop_result(row)

    def _stop_result(self, row) -> dict:
        """One stop row with the simulator's truth over exactly the frames the console
        summarised and, with fixed-pattern noise, the SNR of the same track on raw frames (no
        background reference) at the last of them: the console reports both."""
        rig = self.cameras[row.camera]
        run = self.session.stop_table.run_of(row.stop, row.camera)
        logged = {t: (c, mean, std) for t, c, mean, std in list(rig.log)}
        used = [logged[t] for t, _ in run if t in logged]
        truths = [rig.feed.truth(c) for c, _, _ in used]
        truths = [v.truth_snr for v in truths if v is not None]
        truth = float(np.mean(truths)) if truths else float("nan")
        raw = {}
        if self.opts.fpn and used:
            _, mean, std = used[-1]
            raw = {"measured_snr_mean_raw": mean, "measured_snr_std_raw": std}
        rng = row.range_m
        planned = np.array(self.opts.stops_m, float)
        plan = float(planned[np.argmin(np.abs(planned - rng))]) if rng else float("nan")
        return {
            "camera": row.camera,
            "planned_range_m": plan,
            "lrf_range_m": row.place.lrf_range_m,
            "gps_range_m": row.place.gps_range_m,
            "n_frames": row.reading.n_frames,
            "measured_snr_mean": row.reading.snr_mean,
            "measured_snr_std": row.reading.snr_std,
            "measured_snr_sem": row.reading.snr_sem,
            **raw,
            "truth_snr": truth,
            "model_snr": row.model.model_snr,
            "resolved": bool(row.model.resolved),
            "_crops": self.session.flight_psf.crops_of(row),
            "background": row.reading.background,
            "expected_eq4_rule": row.expected_eq4_rule,  # which model_snr reading applies
            # the console's own ratio for the row and the PSF its model values used
            "live_over_model": row.agreement.ratio if row.agreement is not None else None,
            "model_psf": row.model_psf_label,
        }

    # ------------------------------------------------------------------ the flight's PSF
    def _unresolved_stops(self, cam: str, finals: dict) -> list:
        from snrmon.acquisition.calibrate.psf_estimate import StopCrops, target_px

        sensor = self.cameras[cam].sensor
        stops = []
        for (c, stop), entry in sorted(finals.items()):
            crops = entry.get("_crops")
            if c != cam or crops is None or entry.get("lrf_range_m") is None:
                continue
            d = target_px(self.predictor.target, entry["lrf_range_m"], sensor.ifov_rad)
            if d < 1.0 and len(crops) >= 50:
                stops.append(StopCrops(_label(stop, cam), crops, d))
        return stops

    def measured_psf(self, finals: dict) -> dict:
        """Per camera, the PSF fitted to the crops of its unresolved stops, pooled, and every
        stop's model values with it: {camera: {"psf": {...} | {"error": ...}}} and, in the stop
        entries of ``finals``, ``"model_measured_psf"`` (:data:`MODEL_VALUES` over the whole cell)
        and, at an unresolved stop, ``"model_stop_phases"`` (the same over the phases its frames
        sampled), ``"measured_over_model"`` (the measured mean over the expected reading of the
        rule its background makes applicable, at those phases) and ``"truth_over_model"`` (the
        twin's noise-free truth over the model's noise-free peak SNR there)."""
        from snrmon.acquisition.calibrate.psf_estimate import (
            PsfEstimateError,
            estimate_psf,
            observed_phases,
        )
        from snrmon.model.snr import predict

        out = {}
        target = self.predictor.target
        for cam, cam_rig in self.cameras.items():
            sensor = cam_rig.sensor
            stops = self._unresolved_stops(cam, finals)
            if not stops:
                out[cam] = {"error": f"{cam}: no unresolved stop with 50 frames to fit a PSF"}
                continue
            try:
                est = estimate_psf(stops, sensor)
            except PsfEstimateError as exc:
                out[cam] = {"error": str(exc)}
                continue
            out[cam] = est.as_dict()
            sky = self.predictor.background_temp_k.get(cam)
            phases = {s.label: observed_phases(s, est.psf(), sensor.fill_factor) for s in stops}
            for (c, stop), entry in finals.items():
                rng = entry.get("lrf_range_m")
                if c != cam or rng is None:
                    continue
                kw = {
                    "corrected_psf": est.psf(),
                    "background_temp_k": sky,
                    "air_temp_k": self.opts.scenario.air_temp_k,
                    "band": False,
                }
                p = predict(sensor, target, [rng], **kw)
                entry["model_measured_psf"] = {v: float(p.snr(v)[0]) for v in MODEL_VALUES}
                sampled = phases.get(_label(stop, cam))
                if sampled is None:  # resolved: no PSF fit, no phases
                    continue
                p = predict(sensor, target, [rng], phases_xy=sampled, **kw)
                d_px = target.small_m / (rng * sensor.ifov_rad)
                at = {v: float(p.snr(v)[0]) for v in MODEL_VALUES[1:]}
                at["small_corrected"] = _peak_snr_at_phases(
                    p, est.psf(), sensor.fill_factor, d_px, sampled
                )
                entry["model_stop_phases"] = at
                rule = entry.get("expected_eq4_rule")
                if rule is not None and math.isfinite(entry["measured_snr_mean"]):
                    entry["measured_over_model"] = (
                        entry["measured_snr_mean"] / at[f"expected_eq4_{rule}"]
                    )
                if math.isfinite(entry.get("truth_snr", math.nan)):
                    entry["truth_over_model"] = entry["truth_snr"] / at["small_corrected"]
        return out

    def _record_psf(self, psf: dict) -> None:
        """The PSF each camera's unresolved stops gave, into the recording (once, after it is
        closed) as ``snrmon psf`` records it: ``snrmon characterize`` corrects the close stop's
        core temperature with it."""
        from snrmon.acquisition.record.reader import append_event

        if not self.opts.out or self._psf_recorded or self.recording is None:
            return
        if self.recording.get("error"):  # a disk that filled: the file keeps what it has
            return
        self._psf_recorded = True
        for cam, est in psf.items():
            if "error" not in est:
                payload = {
                    **est,
                    "estimate": est,  # the fit as the model takes it, as `snrmon psf` writes it
                    "camera": cam,
                    "source": "snrmon hil: the unresolved stops",
                }
                append_event(self.opts.out, "psf_measured", camera=cam, payload=payload)

    def final_stops(self) -> list[dict]:
        """The stop entries frozen so far (their rows are complete or their stop ended), in
        the order they froze; cheap (no PSF fit), for printing rows as they come."""
        self._summarise_final_rows()
        return [{k: v for k, v in e.items() if k != "_crops"} for e in self._final.values()]

    def result(self) -> dict:
        self._summarise_final_rows()
        # A row still open is summarised as it stands now, and again at the next call: only
        # _summarise_final_rows freezes one (a row frozen early stayed short for good).
        entries = {
            (row.camera, row.stop): self._final.get((row.camera, row.stop))
            or self._stop_result(row)
            for row in self.session.stops()
        }
        psf = self.measured_psf(entries)  # the PSF from the flight's own frames
        self._record_psf(psf)
        stops = [{k: v for k, v in e.items() if k != "_crops"} for e in entries.values()]
        # The frame accounting (FrameAccounting, by its names): the recording's, as its file
        # keeps it, or without one the session's (nothing written).
        recorded = (self.recording or {}).get("accounting") or {}
        frames = {
            name: recorded.get(name) or pipe.accounting().as_record()
            for name, pipe in self.session.pipelines.items()
        }
        clicks = {c: sum(1 for k in self._clicked if k[0] == c) for c in self.cameras}
        return {
            "seed": self.opts.seed,
            "scenario": self.opts.scenario.record(tuple(self.cameras)),
            "sky_temp_measured_k": {
                c: self.predictor.background_temp_k.get(c) for c in self.cameras
            },
            "psf": psf,
            "stops": stops,
            "frames": dict(frames),
            "speed": {
                "asked": "max" if self.opts.speed_max else self.opts.speed,
                **self.clock.achieved(),
                "changes": [{"flight_s": t, "speed": v} for t, v in self.speed_changes],
            },
            "operator_clicks": clicks,
            "devices_lost": [x.as_dict() for x in self.session.devices_lost()],
        }


MODEL_VALUES = ("small_corrected", "expected_eq4_rim", "expected_eq4_extent")
"""What the model says of a stop with the flight's PSF: the noise-free peak SNR of the corrected
small curve and the expected Eq. (4) readings of both background rules."""


def _peak_snr_at_phases(p, psf, fill_factor: float, d_px: float, phases_xy) -> float:
    """The corrected small curve's noise-free peak SNR over the sub-pixel phases a stop's frames
    sampled (instead of the whole cell): point signal / noise x the mean centre-pixel share."""
    from snrmon.model.eq4 import observed_phase_weights
    from snrmon.model.footprint import pixel_patterns

    xs, ys, weights = observed_phase_weights(phases_xy)
    pats = pixel_patterns(psf, fill_factor, xs, ys, half_size_px=0, target_square_px=d_px)
    share = float(np.sum(weights * pats[:, :, 0, 0]))
    return float(p.point_contrast_e["small"][0] / p.noise.total * share)


def _label(stop: int, cam: str) -> str:
    return f"stop {stop} ({cam})"
