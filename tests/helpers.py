"""Shared test helpers: picklable render callables for camera processes, event waits."""

from __future__ import annotations

import json
import threading
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

H, W = 96, 128
SPOT_X, SPOT_Y = 64.3, 40.6
AMPLITUDE_DN = 120.0
NOISE_DN = 6.0


class SpotOnNoise:
    """Picklable render callable: a Gaussian spot (``sigma_px``, peak ``amplitude_dn``) at
    (``spot_x``, ``spot_y``) on ``sky_dn`` of white noise (``noise_dn``), ``height`` x ``width``,
    optionally over a fixed pattern of ``fpn_dn`` and appearing only from frame ``spot_from``.

    It lives here, in a module that imports only NumPy, because a camera process (spawned)
    unpickles it by importing its module: a render defined in a GUI test module made every
    camera process import Qt and the console first."""

    def __init__(
        self,
        seed: int,
        *,
        fpn_dn: float = 0.0,
        spot_from: int = 0,
        width: int = W,
        height: int = H,
        spot_x: float = SPOT_X,
        spot_y: float = SPOT_Y,
        amplitude_dn: float = AMPLITUDE_DN,
        sigma_px: float = 0.7,
        sky_dn: float = 1000.0,
        noise_dn: float = NOISE_DN,
    ) -> None:
        self.seed = seed
        self.spot_from = spot_from
        self.sky_dn, self.noise_dn = sky_dn, noise_dn
        yy, xx = np.mgrid[0:height, 0:width]
        r2 = (xx - spot_x) ** 2 + (yy - spot_y) ** 2
        self.spot = amplitude_dn * np.exp(-r2 / (2 * sigma_px**2))
        # A fixed per-pixel offset pattern (fixed-pattern noise), the same in every frame.
        self.fpn = (
            np.random.default_rng([seed, 999]).normal(0.0, fpn_dn, (height, width)) if fpn_dn else 0
        )

    def __call__(self, counter: int) -> np.ndarray:
        rng = np.random.default_rng([self.seed, counter])
        spot = self.spot if counter >= self.spot_from else 0.0
        noise = rng.normal(0.0, self.noise_dn, self.spot.shape)
        frame = self.sky_dn + self.fpn + spot + noise
        return np.clip(np.rint(frame), 0, 65535).astype(np.uint16)


def shm_camera_config(
    address: str,
    *,
    camera: str = "mwir",
    width_px: int = W,
    height_px: int = H,
    **tables,
):
    """The session configuration of one camera (preset ``camera``) reading the shared-memory
    ring ``address``; ``tables`` are more of the camera's keys (``calibration=...``) or, given
    as dicts, top-level tables (``lrf={...}``)."""
    from snrmon.acquisition.config import session_config_from_dict

    top = {k: v for k, v in tables.items() if isinstance(v, dict)}
    extra = {k: v for k, v in tables.items() if not isinstance(v, dict)}
    cam = {"source": "shm", "address": address, "sensor": camera, "width_px": width_px}
    cam.update(height_px=height_px, **extra)
    return session_config_from_dict({"cameras": {camera: cam}, **top})


def wait_until(predicate, timeout_s: float, what: str) -> None:
    cond = threading.Condition()
    deadline = time.monotonic() + timeout_s
    with cond:
        while not predicate():
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out waiting for {what}")
            cond.wait(0.02)


def sensor_toml(path: Path, fps: float = 60.0, *, width_px: int = W, height_px: int = H) -> Path:
    """The LWIR preset, resized to the test cameras' format (W x H unless given) at ``fps``: a
    sensor the model accepts for a simulated camera of this size."""
    from snrmon.model.presets import PRESET_DIR

    lines = []
    for line in (PRESET_DIR / "lwir.toml").read_text().splitlines():
        key = line.split("=")[0].strip()
        value = {"width_px": width_px, "height_px": height_px, "fps": fps}.get(key)
        lines.append(f"{key} = {value}" if value is not None else line)
    path.write_text("\n".join(lines) + "\n")
    return path


def strict_json(text: str):
    """Parse like a strict RFC 8259 parser: NaN and Infinity are errors (Python's json module
    accepts them by default), and so is anything but one document."""

    def refuse(name: str):
        raise ValueError(f"{name} is not JSON")

    return json.loads(text, parse_constant=refuse)


@contextmanager
def field_devices(
    ring: str,
    *,
    gps_utc=None,
    fps: float = 60.0,
    seed: int = 3,
    range_m: float = 200.0,
    lrf_hz: float = 10.0,
):
    """The simulated field kit, started: a shared-memory camera writing ``ring`` (a spot on
    noise seeded ``seed``, W x H at ``fps``), an LDM rangefinder reading ``range_m`` at
    ``lrf_hz`` and an NMEA GPS at a fixed point (its clock starting at ``gps_utc``; the
    simulator's fixed 2019 date by default). Yields (camera, rangefinder, gps); all are stopped
    on exit."""
    from snrmon.sim.devices.ldm_sim import LdmSimulator
    from snrmon.sim.devices.nmea_sim import NmeaSimulator
    from snrmon.sim.devices.shm_camera import ShmProducer

    producer = ShmProducer(ring, W, H, SpotOnNoise(seed), fps=fps, slots=16)
    producer.start()
    lrf = LdmSimulator(lambda t: range_m, rate_hz=lrf_hz, tracking=True).start()
    gps = NmeaSimulator(
        lambda t: (32.3810, -106.4790, 1250.0), rate_hz=10.0, start_utc=gps_utc
    ).start()
    try:
        yield producer, lrf, gps
    finally:
        producer.stop()
        lrf.stop()
        gps.stop()


def field_config(
    path: Path,
    ring: str,
    gps_port: str,
    lrf_port: str,
    camera: str,
    *,
    start_timeout_s: float | None = None,
) -> Path:
    """A session config naming the field kit (``camera``: extra lines of [cameras.cam]);
    ``start_timeout_s`` in every device's table when given."""
    timeout = "" if start_timeout_s is None else f"start_timeout_s = {start_timeout_s}\n"
    path.write_text(
        "[site]\nlat_deg = 32.38\nlon_deg = -106.48\nalt_m = 1200.0\n\n"
        f'[cameras.cam]\nsource = "shm"\naddress = "{ring}"\n{camera}\n{timeout}\n'
        f'[lrf]\nprotocol = "ldm"\nport = "{lrf_port}"\n{timeout}\n'
        f'[gps]\nprotocol = "nmea"\nport = "{gps_port}"\nbaud = 38400\n{timeout}'
    )
    return path


def twin_recording(
    path: Path,
    *,
    stops: str,
    speed: float,
    hover_s: float = 4.0,
    transit_mps: float = 8.0,
    seed: int = 0,
) -> Path:
    """``snrmon hil --seed SEED --out path`` (both cameras, calibrated): the digital twin's
    flight over ``stops`` (metres, comma-separated) as a session file."""
    from snrmon.cli import main

    argv = [
        "hil",
        "--seed",
        str(seed),
        "--stops",
        stops,
        "--hover-s",
        str(hover_s),
        "--transit-mps",
        str(transit_mps),
        "--speed",
        str(speed),
        "--out",
        str(path),
        "--json",
        "--quiet",
    ]
    assert main(argv) == 0
    return path


def running_n(status, camera: str) -> int:
    """Frames in ``camera``'s running statistics in a session status (0 before its first
    measured frame)."""
    last = status.cameras[camera].last
    return last.snr_n if last is not None else 0


def replay_frames_text(replay, camera: str) -> list[str]:
    """Each frame's Eq. (4) result, track and running statistics of a replay's camera, as text
    (NaN equals NaN): what two replays that must agree are compared on."""
    return [
        repr((m.counter, m.t_host_ns, m.result, m.track_state, m.window_xy, m.snr_mean, m.snr_std))
        for m in replay.cameras[camera].tally.measurements
    ]


def replay_rows_text(replay) -> list[str]:
    """A replay's stop rows (their times, frame counts and statistics) as text."""
    return [
        repr(
            (
                r.stop,
                r.camera,
                r.place.t_start_ns,
                r.place.t_end_ns,
                r.reading.n_frames,
                r.reading.snr_mean,
                r.reading.snr_std,
            )
        )
        for r in replay.stops
    ]


def field_session_config(ring: str, lrf, gps):
    """The session config of :func:`field_devices`' kit: one shared-memory camera ``cam`` on
    ``ring`` (W x H), the LDM rangefinder and the NMEA GPS at their pty paths, at a site."""
    from snrmon.acquisition.config import session_config_from_dict

    return session_config_from_dict(
        {
            "site": {"lat_deg": 32.38, "lon_deg": -106.48, "alt_m": 1200.0},
            "cameras": {"cam": {"source": "shm", "address": ring, "width_px": W, "height_px": H}},
            "lrf": {"protocol": "ldm", "port": lrf.path, "baud": 9600},
            "gps": {"protocol": "nmea", "port": gps.path, "baud": 38400},
        }
    )


class SpotOnSky:
    """Picklable render callable of a camera's full frame: ``width`` x ``height`` pixels of
    1000 DN sky with white noise (:data:`NOISE_DN`) and the drone, a Gaussian spot (sigma
    0.8 px, ``amplitude_dn``) centred on pixel (``x``, ``y``). The noise of :data:`FRAMES`
    frames is drawn once (seeded) and taken in turn: a 1280 x 720 frame drawn afresh each time
    took a loaded machine longer than the frame's interval (the camera then dropped frames)."""

    FRAMES = 8

    def __init__(
        self, width: int, height: int, x: int, y: int, seed: int, amplitude_dn: float = 240.0
    ) -> None:
        self.width, self.height, self.x, self.y, self.seed = width, height, x, y, seed
        yy, xx = np.mgrid[-7:8, -7:8]
        self.spot = amplitude_dn * np.exp(-(xx**2 + yy**2) / (2 * 0.8**2))
        self._frames: list[np.ndarray] = []

    def __call__(self, counter: int) -> np.ndarray:
        if not self._frames:  # in the camera's process (the callable is pickled before)
            for i in range(self.FRAMES):
                rng = np.random.default_rng([self.seed, i])
                frame = rng.normal(1000.0, NOISE_DN, (self.height, self.width))
                frame[self.y - 7 : self.y + 8, self.x - 7 : self.x + 8] += self.spot
                self._frames.append(np.rint(frame).astype(np.uint16))
        return self._frames[counter % self.FRAMES]
