"""What a session is made of, from a TOML file: cameras, rangefinder, GPS, site, target, settings.

Example (``session.toml``)::

    target = "uav1"                 # model preset or a target TOML file
    compression = "bitshuffle-lz4"  # the frames' lossless filter: none | lz4 | bitshuffle-lz4
                                    # | zstd | gzip (default: bitshuffle-lz4)
    model_psf = "fitted"            # the model's corrected PSF: fitted from the flight's
                                    # unresolved stops as each completes | preset (default:
                                    # fitted)
    footprint = "square"            # the model's small target: the paper's square | outline
                                    # (the target file's, from snrmon characterize
                                    # --target-out; default: square)

    [site]                          # the camera site, for GPS slant range and projection
    lat_deg = 28.5383
    lon_deg = -81.3792
    alt_m = 30.0

    [measurement]                   # paper Eq. (4) settings
    search_px = 11
    box_px = 7
    window_frames = 100             # the running SNR's frames (the old key `window` still works)

    [cameras.mwir]
    source = "shm"                  # shm | v4l2 | aravis
    address = "snrmon-mwir"         # shm ring name | V4L2 index or path | Aravis camera id
    sensor = "mwir"                 # model preset or a sensor TOML file
    pointing_deg = [40.0, 8.0, 0.0] # azimuth (clockwise from north), elevation, roll
    calibration = "mwir-cal.npz"    # optional: snrmon calibrate output, applied before Eq. 4

    [weather]                       # the day's met readings (the model's LOWTRAN7 atmosphere)
    air_temp_c = 21.5
    rh_percent = 60.0               # or dew_point_c
    pressure_hpa = 1008.0
    visibility_km = 20.0            # default: 23 (LOWTRAN7's clear day)
    aerosol = "rural"               # rural | maritime | urban | none (no aerosol); default:
                                    # rural (no [weather] at all: rural at 23 km too)
    season = "midlat_summer"        # standard atmosphere for readings not given

    [gps]                           # drivers.config table (nmea | gpsd | mavlink)
    protocol = "nmea"
    port = "/dev/ttyUSB0"
    baud = 38400

    [lrf]                           # drivers.config table (trupulse | ldm)
    protocol = "trupulse"
    port = "/dev/ttyUSB1"

Every key is checked against the schema below (``TOP_FIELDS``, ``SITE_FIELDS``,
``WEATHER_FIELDS``, ``MEASUREMENT_FIELDS``, ``CAMERA_FIELDS``; the device tables by
:mod:`snrmon.drivers.config`): an unknown key, a missing one, or a value of the wrong type or
range is one :class:`snrmon.drivers.errors.ConfigError` naming the file, the table, the key, the
value and what was expected, e.g. ``session.toml: [site] lat_deg = "north": expected a latitude
in degrees, -90 to 90``.
"""

from __future__ import annotations

import logging
import math
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from snrmon.acquisition.geo.projection import Pointing, Site
from snrmon.acquisition.measure.peak_snr import PeakSnrConfig
from snrmon.drivers.config import check_device_table
from snrmon.drivers.errors import ConfigError, toml_repr
from snrmon.limits import (
    COMPRESSION_CHOICES,
    DEFAULT_COMPRESSION,
    FOOTPRINT_CHOICES,
    MAX_WINDOW_FRAMES,
    PSF_CHOICES,
)
from snrmon.model.atmosphere_table import (
    AEROSOLS,
    AIR_TEMP_RANGE_C,
    PRESSURE_RANGE_HPA,
    SEASONS,
    VISIBILITY_RANGE_KM,
    Weather,
)
from snrmon.model.constants import ZERO_C_K
from snrmon.model.presets import load_target

log = logging.getLogger(__name__)

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
    calibration: str | None = None  # calibration file (npz + TOML sidecar)
    start_timeout_s: float | None = None  # no frame within this long of the start: a failure


@dataclass(frozen=True)
class SessionConfig:
    cameras: tuple[CameraConfig, ...]
    target: str = "uav1"
    site: Site | None = None
    gps: dict[str, Any] | None = None
    lrf: dict[str, Any] | None = None
    measurement: PeakSnrConfig = field(default_factory=PeakSnrConfig)
    window_frames: int = 100  # the running SNR's window (paper Eq. 4's 100-frame average)
    lrf_fresh_s: float = 2.0
    air_temp_k: float | None = None  # [weather] air_temp_c: the model's path temperature
    weather: Weather | None = None  # [weather]: the met readings the model's atmosphere uses
    compression: str = DEFAULT_COMPRESSION  # the recorded frames' filter (COMPRESSION_CHOICES)
    model_psf: str = "fitted"  # the model's corrected PSF: fitted from the flight, or "preset"
    footprint: str = "square"  # the model's small target: square, or the target's outline
    raw: dict[str, Any] = field(default_factory=dict, compare=False)


# --------------------------------------------------------------------------- the schema
@dataclass(frozen=True)
class Field:
    """One key of a table: what a valid value is (``check``), said in words (``expected``)."""

    expected: str
    check: Callable[[Any], bool]
    required: bool = False


def _number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _integer(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _between(lo: float, hi: float) -> Callable[[Any], bool]:
    return lambda v: _number(v) and lo <= v <= hi


def _odd_int(minimum: int) -> Callable[[Any], bool]:
    return lambda v: _integer(v) and v >= minimum and v % 2 == 1


def _int_at_least(minimum: int) -> Callable[[Any], bool]:
    return lambda v: _integer(v) and v >= minimum


def _positive(v: Any) -> bool:
    return _number(v) and v > 0


def _text(v: Any) -> bool:
    return isinstance(v, str) and v != ""


def _table(v: Any) -> bool:
    return isinstance(v, dict)


TOP_FIELDS = {
    "target": Field('a target preset ("uav1", "uav2") or a target TOML file', _text),
    "compression": Field(
        f"the frames' filter, one of {', '.join(COMPRESSION_CHOICES)}",
        lambda v: v in COMPRESSION_CHOICES,
    ),
    "model_psf": Field(
        "the model's corrected PSF, one of " + ", ".join(PSF_CHOICES),
        lambda v: v in PSF_CHOICES,
    ),
    "footprint": Field(
        "the model's small target, one of " + ", ".join(FOOTPRINT_CHOICES),
        lambda v: v in FOOTPRINT_CHOICES,
    ),
    "site": Field("a table [site] with lat_deg, lon_deg, alt_m", _table),
    "measurement": Field("a table [measurement]", _table),
    "cameras": Field("tables [cameras.<name>]", _table, required=True),
    "gps": Field("a table [gps] (drivers.config)", _table),
    "lrf": Field("a table [lrf] (drivers.config)", _table),
    "weather": Field("a table [weather] with the met readings (air_temp_c, rh_percent...)", _table),
    "simulation": Field("a table [simulation] (the simulated scenario, recorded with it)", _table),
}
WEATHER_FIELDS = {
    "air_temp_c": Field("an air temperature in C, -30 to 45", _between(*AIR_TEMP_RANGE_C)),
    "rh_percent": Field("a relative humidity in %, 0 to 100", _between(0, 100)),
    "dew_point_c": Field("a dew point in C, -80 to 45", _between(-80, AIR_TEMP_RANGE_C[1])),
    "pressure_hpa": Field("an air pressure in hPa, 700 to 1060", _between(*PRESSURE_RANGE_HPA)),
    "visibility_km": Field("a visibility in km, 0.5 to 300", _between(*VISIBILITY_RANGE_KM)),
    "aerosol": Field(f"one of {', '.join(AEROSOLS)}", lambda v: v in AEROSOLS),
    "season": Field(f"a standard atmosphere: {', '.join(SEASONS)}", lambda v: v in SEASONS),
}
SITE_FIELDS = {
    "lat_deg": Field("a latitude in degrees, -90 to 90", _between(-90, 90), required=True),
    "lon_deg": Field("a longitude in degrees, -180 to 180", _between(-180, 180), required=True),
    "alt_m": Field("an altitude in metres (a number)", _number, required=True),
}
MEASUREMENT_FIELDS = {
    "search_px": Field("an odd integer >= 1 (pixels)", _odd_int(1)),
    "box_px": Field("an odd integer >= 3 (pixels)", _odd_int(3)),
    "background": Field(
        "a clear-sky rectangle [x0, y0, x1, y1] of integer pixels, corners included",
        lambda v: isinstance(v, list) and len(v) == 4 and all(_integer(x) for x in v),
    ),
    "detrend": Field("true or false", lambda v: isinstance(v, bool)),
    "saturation_dn": Field("a number (DN)", _number),
    "ddof": Field("0 or 1", lambda v: _integer(v) and v in (0, 1)),
    "contamination_std_factor": Field("a positive number", _positive),
    "contamination_gradient_factor": Field("a positive number", _positive),
    "reference_frames": Field("an integer >= 1", _int_at_least(1)),
    "reference_min_frames": Field("an integer >= 1", _int_at_least(1)),
    "window_frames": Field(
        f"an integer from 1 to {MAX_WINDOW_FRAMES} (frames of the running SNR)",
        lambda v: _integer(v) and 1 <= v <= MAX_WINDOW_FRAMES,
    ),
    "window": Field(  # the old spelling of window_frames (recorded sessions carry it)
        f"an integer from 1 to {MAX_WINDOW_FRAMES} (frames of the running SNR)",
        lambda v: _integer(v) and 1 <= v <= MAX_WINDOW_FRAMES,
    ),
    "lrf_fresh_s": Field("a positive number of seconds", _positive),
}
CAMERA_FIELDS = {
    "source": Field(f"one of {', '.join(CAMERA_SOURCES)}", lambda v: v in CAMERA_SOURCES),
    "address": Field(
        "a string (shm ring name, V4L2 path, Aravis id) or a V4L2 index",
        lambda v: _text(v) or (_integer(v) and v >= 0),
    ),
    "sensor": Field('a sensor preset ("mwir", "lwir") or a sensor TOML file', _text),
    "width_px": Field("a positive integer (pixels)", _int_at_least(1)),
    "height_px": Field("a positive integer (pixels)", _int_at_least(1)),
    "pointing_deg": Field(
        "[azimuth, elevation] or [azimuth, elevation, roll] in degrees",
        lambda v: isinstance(v, list) and len(v) in (2, 3) and all(_number(x) for x in v),
    ),
    "calibration": Field("a calibration file (.npz from snrmon calibrate)", _text),
    "start_timeout_s": Field("a positive number of seconds", _positive),
}


def checked(table: Any, fields: dict[str, Field], name: str) -> dict[str, Any]:
    """``table``'s values after checking every key against ``fields``: an unknown key, a missing
    required one or a value of the wrong type or range is one ConfigError naming the table
    (``name``), the key, the value and what was expected."""
    if not isinstance(table, dict):
        raise ConfigError(f"[{name}] = {toml_repr(table)}: expected a table")
    unknown = sorted(set(table) - set(fields))
    if unknown:
        raise ConfigError(
            f"[{name}]: unknown key {unknown[0]!r} (known: {', '.join(sorted(fields))})"
        )
    for key, spec in fields.items():
        if key not in table:
            if spec.required:
                raise ConfigError(f"[{name}] is missing {key!r}: expected {spec.expected}")
        elif not spec.check(table[key]):
            raise ConfigError.expected(name, key, table[key], spec.expected)
    return dict(table)


def _camera(name: str, table: Any) -> CameraConfig:
    v = checked(table, CAMERA_FIELDS, f"cameras.{name}")
    pointing = Pointing(*(float(x) for x in v["pointing_deg"])) if "pointing_deg" in v else None
    return CameraConfig(
        name=name,
        source=v.get("source", "shm"),
        address=str(v.get("address", f"snrmon-{name}")),
        sensor=v.get("sensor", name),
        width_px=v.get("width_px"),
        height_px=v.get("height_px"),
        pointing=pointing,
        calibration=v.get("calibration"),
        start_timeout_s=v.get("start_timeout_s"),
    )


def session_config_from_dict(
    data: dict[str, Any], warn: Callable[[str], None] | None = None
) -> SessionConfig:
    """Validate a parsed TOML document into a :class:`SessionConfig`; ``warn`` is told of each
    deprecated key (None: a recorded session's config, which its operator cannot change)."""
    top = checked(data, TOP_FIELDS, "session")
    cams = top["cameras"]
    site = None
    if "site" in top:
        s = checked(top["site"], SITE_FIELDS, "site")
        site = Site(float(s["lat_deg"]), float(s["lon_deg"]), float(s["alt_m"]))
    weather = checked(top.get("weather", {}), WEATHER_FIELDS, "weather")
    air_temp_k = float(weather["air_temp_c"]) + ZERO_C_K if "air_temp_c" in weather else None
    try:  # the combination (a dew point above the air, RH and dew point both)
        met = Weather.from_dict(
            {k: (v if isinstance(v, str) else float(v)) for k, v in weather.items()}
        )
    except ValueError as exc:
        raise ConfigError(f"[weather]: {exc}") from None
    meas = checked(top.get("measurement", {}), MEASUREMENT_FIELDS, "measurement")
    if "window" in meas:
        if "window_frames" in meas:
            raise ConfigError("[measurement]: give window_frames, not also its old name window")
        if warn is not None:
            warn("[measurement] window is deprecated, use window_frames")
        meas["window_frames"] = meas.pop("window")
    window_frames = meas.pop("window_frames", 100)
    lrf_fresh_s = float(meas.pop("lrf_fresh_s", 2.0))
    if "background" in meas:
        meas["background"] = tuple(meas["background"])
    try:
        mcfg = PeakSnrConfig(**meas)
    except ValueError as exc:  # the combination (e.g. a rectangle too small for ddof)
        raise ConfigError(f"[measurement]: {exc}") from None
    for kind in ("gps", "lrf"):
        if kind in top:
            check_device_table(top[kind], kind)
    return SessionConfig(
        cameras=tuple(_camera(n, t) for n, t in cams.items()),
        target=top.get("target", "uav1"),
        site=site,
        gps=top.get("gps"),
        lrf=top.get("lrf"),
        measurement=mcfg,
        window_frames=window_frames,
        lrf_fresh_s=lrf_fresh_s,
        air_temp_k=air_temp_k,
        weather=met if weather else None,
        compression=top.get("compression", DEFAULT_COMPRESSION),
        model_psf=top.get("model_psf", "fitted"),
        footprint=top.get("footprint", "square"),
        raw=data,
    )


def utf8_text(path: str | Path, what: str) -> str:
    """The text of the file at ``path``, which must be UTF-8 (TOML, JSON and our CSVs are): a
    file that is not is one ValueError naming ``what``, the path and the first bad byte, not
    the codec's bare message."""
    p = Path(path)
    data = p.read_bytes()
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(
            f"{what} {p}: not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start})"
        ) from None


def read_toml(path: str | Path, what: str) -> dict[str, Any]:
    """A TOML file's document; a missing or malformed file is one error naming ``what``."""
    p = Path(path)
    try:
        return tomllib.loads(utf8_text(p, what))
    except FileNotFoundError:
        raise FileNotFoundError(f"{what} {p} does not exist") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{what} {p} is not valid TOML: {exc}") from None


def load_session_config(path: str | Path) -> SessionConfig:
    """Read and validate a session TOML file, its target resolved too (a preset or a target
    TOML file that reads): an operator's typo is refused here, before any device opens. A
    recorded session's config (:func:`session_config_from_dict`) is not resolved: its target
    file may be on another machine."""
    data = read_toml(path, "session config")
    try:
        config = session_config_from_dict(data, warn=lambda text: log.warning("%s: %s", path, text))
        try:
            target = load_target(config.target)
        except ValueError as exc:
            raise ConfigError(f"target = {toml_repr(config.target)}: {exc}") from None
        if config.footprint == "outline" and target.outline is None:
            raise ConfigError(
                f'footprint = "outline": target = {toml_repr(config.target)} has no '
                "outline (snrmon characterize --target-out writes one from a close stop)"
            )
    except ConfigError as exc:
        raise ConfigError(f"{Path(path)}: {exc}") from None
    return config


def camera_device(cfg: CameraConfig):
    """The camera driver for a camera table (imported lazily: Aravis needs gi)."""
    if cfg.source == "shm":
        from snrmon.drivers.camera.shm import ShmCamera

        return ShmCamera(cfg.name, cfg.address)
    if cfg.source == "v4l2":
        from snrmon.drivers.camera.v4l2 import V4l2Camera

        return V4l2Camera(cfg.name, cfg.address)
    from snrmon.drivers.camera.aravis import AravisCamera

    return AravisCamera(cfg.name, cfg.address)
