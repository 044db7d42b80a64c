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
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from snrmon import config_schema
from snrmon.acquisition.geo.projection import Pointing, Site
from snrmon.acquisition.measure.peak_snr import PeakSnrConfig
from snrmon.config_schema import (
    Key,
    above,
    any_of,
    between,
    dataclass_default,
    int_at_least,
    is_bool,
    is_integer,
    is_number,
    is_table,
    is_text,
    list_of,
    odd_int,
    one_of,
)
from snrmon.drivers.config import DeviceSettings, device_template
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
    address: str
    sensor: str
    source: str = "shm"
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
    gps: DeviceSettings | None = None  # [gps], checked
    lrf: DeviceSettings | None = None  # [lrf], checked
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
# Each key once (snrmon.config_schema): its check, its words, its default read from the
# dataclass that holds the setting. The template (`snrmon doctor --template`) and the docs'
# key tables (docs/operator-guide.md) come from these declarations.
def _peak(name: str) -> Any:
    return dataclass_default(PeakSnrConfig, name)


def _session(name: str) -> Any:
    return dataclass_default(SessionConfig, name)


TOP_FIELDS: dict[str, Key] = {
    "target": Key(
        'a target preset ("uav1", "uav2") or a target TOML file',
        is_text,
        default=_session("target"),
    ),
    "compression": Key(
        f"the frames' filter, one of {', '.join(COMPRESSION_CHOICES)}",
        one_of(COMPRESSION_CHOICES),
        default=_session("compression"),
    ),
    "model_psf": Key(
        "the model's corrected PSF, one of " + ", ".join(PSF_CHOICES),
        one_of(PSF_CHOICES),
        default=_session("model_psf"),
    ),
    "footprint": Key(
        "the model's small target, one of " + ", ".join(FOOTPRINT_CHOICES),
        one_of(FOOTPRINT_CHOICES),
        default=_session("footprint"),
    ),
    "site": Key("a table [site] with lat_deg, lon_deg, alt_m", is_table),
    "measurement": Key("a table [measurement]", is_table),
    "cameras": Key("tables [cameras.<name>]", is_table, required=True),
    "gps": Key("a table [gps] (drivers.config)", is_table),
    "lrf": Key("a table [lrf] (drivers.config)", is_table),
    "weather": Key("a table [weather] with the met readings (air_temp_c, rh_percent...)", is_table),
    "simulation": Key("a table [simulation] (the simulated scenario, recorded with it)", is_table),
}
WEATHER_FIELDS: dict[str, Key] = {
    "air_temp_c": Key(
        "an air temperature in C, -30 to 45", between(*AIR_TEMP_RANGE_C), example=21.5
    ),
    "rh_percent": Key("a relative humidity in %, 0 to 100", between(0, 100), example=60.0),
    "dew_point_c": Key("a dew point in C, -80 to 45", between(-80, AIR_TEMP_RANGE_C[1])),
    "pressure_hpa": Key(
        "an air pressure in hPa, 700 to 1060", between(*PRESSURE_RANGE_HPA), example=1013.25
    ),
    "visibility_km": Key(
        "a visibility in km, 0.5 to 300",
        between(*VISIBILITY_RANGE_KM),
        default=dataclass_default(Weather, "visibility_km"),
    ),
    "aerosol": Key(
        f"one of {', '.join(AEROSOLS)}",
        one_of(AEROSOLS),
        default=dataclass_default(Weather, "aerosol"),
    ),
    "season": Key(
        f"a standard atmosphere: {', '.join(SEASONS)}",
        one_of(SEASONS),
        default=dataclass_default(Weather, "season"),
    ),
}
SITE_FIELDS: dict[str, Key] = {
    "lat_deg": Key(
        "a latitude in degrees, -90 to 90", between(-90, 90), required=True, example=28.5383
    ),
    "lon_deg": Key(
        "a longitude in degrees, -180 to 180", between(-180, 180), required=True, example=-81.3792
    ),
    "alt_m": Key(
        "an altitude in metres above mean sea level", is_number, required=True, example=30.0
    ),
}
_WINDOW_FRAMES = f"an integer from 1 to {MAX_WINDOW_FRAMES} (frames of the running SNR)"
MEASUREMENT_FIELDS: dict[str, Key] = {
    "search_px": Key("an odd integer >= 1 (pixels)", odd_int(1), default=_peak("search_px")),
    "box_px": Key("an odd integer >= 3 (pixels)", odd_int(3), default=_peak("box_px")),
    "background": Key(
        "a clear-sky rectangle [x0, y0, x1, y1] of integer pixels, corners included",
        list_of(is_integer, lengths=(4,)),
        default=_peak("background"),
        convert=tuple,
    ),
    "detrend": Key("true or false", is_bool, default=_peak("detrend")),
    "saturation_dn": Key("a number (DN)", is_number, default=_peak("saturation_dn")),
    "ddof": Key("0 or 1", one_of((0, 1)), default=_peak("ddof")),
    "contamination_std_factor": Key(
        "a positive number", above(0), default=_peak("contamination_std_factor")
    ),
    "contamination_gradient_factor": Key(
        "a positive number", above(0), default=_peak("contamination_gradient_factor")
    ),
    "reference_frames": Key("an integer >= 1", int_at_least(1), default=_peak("reference_frames")),
    "reference_min_frames": Key(
        "an integer >= 1", int_at_least(1), default=_peak("reference_min_frames")
    ),
    "window_frames": Key(
        _WINDOW_FRAMES,
        lambda v: is_integer(v) and 1 <= v <= MAX_WINDOW_FRAMES,
        default=_session("window_frames"),
    ),
    # the old spelling of window_frames (recorded sessions carry it)
    "window": Key(_WINDOW_FRAMES, lambda v: is_integer(v) and 1 <= v <= MAX_WINDOW_FRAMES),
    "lrf_fresh_s": Key("a positive number of seconds", above(0), default=_session("lrf_fresh_s")),
}
CAMERA_FIELDS: dict[str, Key] = {
    "source": Key(
        f"one of {', '.join(CAMERA_SOURCES)}",
        one_of(CAMERA_SOURCES),
        default=dataclass_default(CameraConfig, "source"),
    ),
    "address": Key(
        'a string (shm ring name, V4L2 path, Aravis id) or a V4L2 index (default "snrmon-<name>")',
        any_of(is_text, lambda v: is_integer(v) and v >= 0),
        example="snrmon-mwir",
    ),
    "sensor": Key(
        'a sensor preset ("mwir", "lwir") or a sensor TOML file (default: the camera\'s name)',
        is_text,
        example="mwir",
    ),
    "width_px": Key("a positive integer (pixels)", int_at_least(1)),
    "height_px": Key("a positive integer (pixels)", int_at_least(1)),
    "pointing_deg": Key(
        "[azimuth, elevation] or [azimuth, elevation, roll] in degrees",
        list_of(is_number, lengths=(2, 3)),
    ),
    "calibration": Key("a calibration file (.npz from snrmon calibrate)", is_text),
    "start_timeout_s": Key("a positive number of seconds", above(0)),
}
SCHEMA: dict[str, dict[str, Key]] = {
    "": TOP_FIELDS,
    "site": SITE_FIELDS,
    "measurement": MEASUREMENT_FIELDS,
    "weather": WEATHER_FIELDS,
    "cameras.<name>": CAMERA_FIELDS,
}
"""Every table of a session config, as :func:`snrmon.config_schema.template` writes them."""


def checked(table: Any, fields: dict[str, Key], name: str) -> dict[str, Any]:
    """``table``'s values after checking every key against ``fields``
    (:func:`snrmon.config_schema.checked`, raising :class:`ConfigError`)."""
    return config_schema.checked(table, fields, name, error=ConfigError)


def session_template() -> str:
    """A session TOML with every key, its default or an example, and what it expects: the
    session's tables (:data:`SCHEMA`, the old spelling ``window`` left out), one camera
    ``[cameras.mwir]`` set, the others and the device tables
    (:func:`snrmon.drivers.config.device_template`) commented out to be filled in. As written
    it loads as the defaults with one shared-memory camera."""
    scalars = {k: v for k, v in TOP_FIELDS.items() if v.check is not is_table}
    tables = {name: keys for name, keys in SCHEMA.items() if name}
    text = config_schema.template(
        {"": scalars, **tables}, active=("", "cameras.<name>"), skip=("measurement.window",)
    )
    return text.replace("[cameras.<name>]", "[cameras.mwir]") + "\n" + device_template()


def key_tables_markdown() -> str:
    """The docs' tables of every key of a session config (docs/operator-guide.md holds this
    text; a test compares them): one per session table and one per device protocol."""
    from snrmon.drivers.config import GPS_PROTOCOLS, PROTOCOLS, device_fields

    parts = []
    for name, keys in SCHEMA.items():
        title = "the top level" if name == "" else f"`[{name}]`"
        parts.append(f"Keys of {title}:\n\n{config_schema.markdown_table(keys)}")
    for protocol in PROTOCOLS:
        table = "gps" if protocol in GPS_PROTOCOLS else "lrf"
        keys = device_fields(protocol)
        title = f'`[{table}]` with `protocol = "{protocol}"`'
        parts.append(f"Keys of {title}:\n\n{config_schema.markdown_table(keys)}")
    return "\n\n".join(parts) + "\n"


def _camera(name: str, table: Any) -> CameraConfig:
    v = checked(table, CAMERA_FIELDS, f"cameras.{name}")
    pointing = Pointing(*(float(x) for x in v.pop("pointing_deg"))) if "pointing_deg" in v else None
    v["address"] = str(v.get("address", f"snrmon-{name}"))
    v.setdefault("sensor", name)
    return CameraConfig(name=name, pointing=pointing, **v)


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
    settings = {k: meas.pop(k) for k in ("window_frames", "lrf_fresh_s") if k in meas}
    try:
        mcfg = PeakSnrConfig(**meas)
    except ValueError as exc:  # the combination (e.g. a rectangle too small for ddof)
        raise ConfigError(f"[measurement]: {exc}") from None
    gps, lrf = (DeviceSettings.from_table(top[k], k) if k in top else None for k in ("gps", "lrf"))
    given = {k: top[k] for k in ("target", "compression", "model_psf", "footprint") if k in top}
    return SessionConfig(
        cameras=tuple(_camera(n, t) for n, t in cams.items()),
        site=site,
        measurement=mcfg,
        air_temp_k=air_temp_k,
        weather=met if weather else None,
        raw=data,
        gps=gps,
        lrf=lrf,
        **given,
        **settings,
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
