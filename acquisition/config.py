"""What a session is made of, from a TOML file: cameras, rangefinder, GPS, site, target, settings.

Example (``session.toml``)::

    target = "uav1"                 # model preset or a target TOML file

    [site]                          # the camera site, for GPS slant range and projection
    lat_deg = 28.5383
    lon_deg = -81.3792
    alt_m = 30.0

    [measurement]                   # paper Eq. (4) settings
    search_px = 11
    box_px = 7
    window = 100

    [cameras.mwir]
    source = "shm"                  # shm | v4l2 | aravis
    address = "snrmon-mwir"         # shm ring name | V4L2 index or path | Aravis camera id
    sensor = "mwir"                 # model preset or a sensor TOML file
    pointing_deg = [40.0, 8.0, 0.0] # azimuth (clockwise from north), elevation, roll
    calibration = "mwir-cal.npz"    # optional: snrmon calibrate output, applied before Eq. 4

    [gps]                           # drivers.config table (nmea | gpsd | mavlink)
    protocol = "nmea"
    port = "/dev/ttyUSB0"
    baud = 38400

    [lrf]                           # drivers.config table (trupulse | ldm)
    protocol = "trupulse"
    port = "/dev/ttyUSB1"

Every key is checked; a wrong one is one error naming the table, the key and the value.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from acquisition.geo.projection import Pointing, Site
from acquisition.measure.peak_snr import PeakSnrConfig

CAMERA_SOURCES = ("shm", "v4l2", "aravis")


@dataclass(frozen=True)
class CameraConfig:
    """One camera: where its frames come from and which sensor model describes it."""

    name: str
    source: str
    address: str
    sensor: str
    width_px: int | None = None
    height_px: int | None = None
    pointing: Pointing | None = None
    calibration: str | None = None  # calibration file (npz + TOML sidecar), issue 9


@dataclass(frozen=True)
class SessionConfig:
    cameras: tuple[CameraConfig, ...]
    target: str = "uav1"
    site: Site | None = None
    gps: dict[str, Any] | None = None
    lrf: dict[str, Any] | None = None
    measurement: PeakSnrConfig = field(default_factory=PeakSnrConfig)
    window: int = 100
    lrf_fresh_s: float = 2.0
    air_temp_k: float | None = None  # [weather] air_temp_c: the model's path temperature
    raw: dict[str, Any] = field(default_factory=dict, compare=False)


def _check_keys(table: dict, allowed: set[str], where: str) -> None:
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise ValueError(
            f"{where}: unknown key {unknown[0]!r} (known: {', '.join(sorted(allowed))})"
        )


def _camera(name: str, table: dict) -> CameraConfig:
    where = f"[cameras.{name}]"
    if not isinstance(table, dict):
        raise ValueError(f"{where} must be a table, got {table!r}")
    _check_keys(
        table,
        {"source", "address", "sensor", "width_px", "height_px", "pointing_deg", "calibration"},
        where,
    )
    source = table.get("source", "shm")
    if source not in CAMERA_SOURCES:
        raise ValueError(f"{where} source = {source!r}: not one of {', '.join(CAMERA_SOURCES)}")
    pointing = None
    if "pointing_deg" in table:
        p = table["pointing_deg"]
        if not (isinstance(p, list) and len(p) in (2, 3)):
            raise ValueError(f"{where} pointing_deg = {p!r}: expected [azimuth, elevation, roll]")
        pointing = Pointing(*(float(v) for v in p))
    return CameraConfig(
        name=name,
        source=source,
        address=str(table.get("address", f"snrmon-{name}")),
        sensor=str(table.get("sensor", name)),
        width_px=table.get("width_px"),
        height_px=table.get("height_px"),
        pointing=pointing,
        calibration=str(table["calibration"]) if "calibration" in table else None,
    )


def session_config_from_dict(data: dict[str, Any]) -> SessionConfig:
    """Validate a parsed TOML document into a :class:`SessionConfig`."""
    _check_keys(
        data,
        {"target", "site", "measurement", "cameras", "gps", "lrf", "weather", "simulation"},
        "session",
    )
    cams = data.get("cameras", {})
    if not cams:
        raise ValueError("session: no [cameras.<name>] table")
    site = None
    if "site" in data:
        s = data["site"]
        _check_keys(s, {"lat_deg", "lon_deg", "alt_m"}, "[site]")
        try:
            site = Site(float(s["lat_deg"]), float(s["lon_deg"]), float(s["alt_m"]))
        except KeyError as exc:
            raise ValueError(f"[site] is missing {exc.args[0]!r}") from None
    air_temp_k = _air_temp_k(data.get("weather"))
    if "simulation" in data and not isinstance(data["simulation"], dict):
        raise ValueError(f"[simulation] must be a table, got {data['simulation']!r}")
    meas = dict(data.get("measurement", {}))
    window = int(meas.pop("window", 100))
    lrf_fresh_s = float(meas.pop("lrf_fresh_s", 2.0))
    try:
        mcfg = PeakSnrConfig(**meas)
    except TypeError as exc:
        raise ValueError(f"[measurement]: {exc}") from None
    return SessionConfig(
        cameras=tuple(_camera(n, t) for n, t in cams.items()),
        target=str(data.get("target", "uav1")),
        site=site,
        gps=data.get("gps"),
        lrf=data.get("lrf"),
        measurement=mcfg,
        window=window,
        lrf_fresh_s=lrf_fresh_s,
        air_temp_k=air_temp_k,
        raw=data,
    )


def _air_temp_k(table) -> float | None:
    if table is None:
        return None
    if not isinstance(table, dict):
        raise ValueError(f"[weather] must be a table, got {table!r}")
    _check_keys(table, {"air_temp_c"}, "[weather]")
    if "air_temp_c" not in table:
        return None
    t = table["air_temp_c"]
    if isinstance(t, bool) or not isinstance(t, int | float) or not -100.0 < t < 100.0:
        raise ValueError(f"[weather] air_temp_c = {t!r}: expected a temperature in C")
    return float(t) + 273.15


def load_session_config(path: str | Path) -> SessionConfig:
    """Read and validate a session TOML file."""
    p = Path(path)
    try:
        data = tomllib.loads(p.read_text())
    except FileNotFoundError:
        raise FileNotFoundError(f"session config {p} does not exist") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"session config {p} is not valid TOML: {exc}") from None
    return session_config_from_dict(data)


def camera_device(cfg: CameraConfig):
    """The camera driver for a camera table (imported lazily: Aravis needs gi)."""
    if cfg.source == "shm":
        from drivers.camera.shm import ShmCamera

        return ShmCamera(cfg.name, cfg.address)
    if cfg.source == "v4l2":
        from drivers.camera.v4l2 import V4l2Camera

        return V4l2Camera(cfg.name, cfg.address)
    from drivers.camera.aravis import AravisCamera

    return AravisCamera(cfg.name, cfg.address)
