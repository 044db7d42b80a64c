"""The settings of a re-analysis (``analysis.toml``), recorded in every output of a campaign.

Example::

    [measurement]              # paper Eq. (4); absent keys keep each session's recorded value
    box_px = 7
    search_px = 11
    background = "rim"         # "rim" (the box's 24 rim pixels) or [x0, y0, x1, y1] (clear sky)
    detrend = false            # plane fit of the background pixels before the std

    [calibration]              # per camera: a `snrmon calibrate` file, replacing the recorded one
    mwir = "/data/cal/mwir-2019-05-14.npz"

    [model]                    # the model curves beside each stop (paper Eqs. 1-3)
    target = "uav1"            # default: each session's own target
    background_temp_k = 265.0  # sky temperature for the path-radiance correction (sections 8-9)
    atmosphere = "default"     # "default" | "none" | a transmission | a MODTRAN file
    spatial_noise = 0.0        # see model.noise.spatial_noise_e
    [model.sensors]            # default: each session's own sensor presets
    mwir = "mwir"

    [replay]
    track = "recorded"         # recorded | on | off
    fast = true                # read only the pixels around the track (same results)
    stops = "recorded"         # recorded (the live detector's) | redetect (from the streams);
                               # a session with imported GPS is always redetected

Every key is checked: a wrong one is one error naming the table, the key and the value.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from snrmon.acquisition.measure.peak_snr import PeakSnrConfig

MEASUREMENT_KEYS = {"box_px", "search_px", "background", "detrend"}
MODEL_KEYS = {"target", "background_temp_k", "atmosphere", "spatial_noise", "sensors"}
REPLAY_KEYS = {"track", "fast", "stops"}
STOPS = ("recorded", "redetect")
TRACK = {"recorded": None, "on": True, "off": False}


@dataclass(frozen=True)
class AnalysisSettings:
    """A re-analysis's settings; every field None/empty means "as the session recorded it"."""

    measurement: dict[str, Any] = field(default_factory=dict)  # PeakSnrConfig overrides
    calibrations: dict[str, str] = field(default_factory=dict)
    target: str | None = None
    sensors: dict[str, str] = field(default_factory=dict)
    model_options: dict[str, Any] = field(default_factory=dict)  # model.snr.predict keywords
    track: str = "recorded"
    fast: bool = True
    stops: str = "recorded"
    source: str | None = None  # the analysis.toml it came from

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)

    def measurement_config(self, recorded: PeakSnrConfig) -> PeakSnrConfig:
        """The session's recorded Eq. (4) settings with this analysis's overrides."""
        return replace(recorded, **self.measurement) if self.measurement else recorded

    @property
    def track_flag(self) -> bool | None:
        return TRACK[self.track]


def _check(table: Any, allowed: set[str], where: str) -> dict:
    if not isinstance(table, dict):
        raise ValueError(f"{where} must be a table, got {table!r}")
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise ValueError(
            f"{where}: unknown key {unknown[0]!r} (known: {', '.join(sorted(allowed))})"
        )
    return table


def _measurement(table: dict) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in _check(table, MEASUREMENT_KEYS, "[measurement]").items():
        if k == "background":
            if v == "rim":
                out[k] = None
            elif isinstance(v, list) and len(v) == 4 and all(isinstance(x, int) for x in v):
                out[k] = tuple(v)
            else:
                raise ValueError(
                    f'[measurement] background = {v!r}: expected "rim" or '
                    "[x0, y0, x1, y1] (integers, inclusive)"
                )
        elif k == "detrend":
            if not isinstance(v, bool):
                raise ValueError(f"[measurement] detrend = {v!r}: expected true or false")
            out[k] = v
        else:
            if not isinstance(v, int) or isinstance(v, bool):
                raise ValueError(f"[measurement] {k} = {v!r}: expected an odd integer")
            out[k] = v
    try:  # validated as the measurement itself would (odd sizes, a valid rectangle)
        PeakSnrConfig(
            **{f.name: getattr(PeakSnrConfig(), f.name) for f in fields(PeakSnrConfig)} | out
        )
    except (TypeError, ValueError) as exc:
        raise ValueError(f"[measurement]: {exc}") from None
    return out


def settings_from_dict(data: dict[str, Any], *, source: str | None = None) -> AnalysisSettings:
    """Validate a parsed ``analysis.toml``."""
    _check(data, {"measurement", "calibration", "model", "replay"}, "analysis settings")
    measurement = _measurement(data.get("measurement", {}))
    cal = _check(data.get("calibration", {}), set(data.get("calibration", {})), "[calibration]")
    for cam, path in cal.items():
        if not isinstance(path, str) or not path:
            raise ValueError(f"[calibration] {cam} = {path!r}: expected a calibration file path")
    model = dict(_check(data.get("model", {}), MODEL_KEYS, "[model]"))
    target = model.pop("target", None)
    if target is not None and not isinstance(target, str):
        raise ValueError(f"[model] target = {target!r}: expected a preset name or a TOML file")
    sensors = model.pop("sensors", {})
    if not isinstance(sensors, dict) or not all(isinstance(v, str) for v in sensors.values()):
        raise ValueError(f'[model.sensors] = {sensors!r}: expected camera = "preset" pairs')
    temp = model.get("background_temp_k")
    if temp is not None and not (isinstance(temp, int | float) and 0 < temp < 1000):
        raise ValueError(f"[model] background_temp_k = {temp!r}: expected kelvin in (0, 1000)")
    replay = _check(data.get("replay", {}), REPLAY_KEYS, "[replay]")
    track = replay.get("track", "recorded")
    if track not in TRACK:
        raise ValueError(f"[replay] track = {track!r}: expected one of {', '.join(TRACK)}")
    fast = replay.get("fast", True)
    if not isinstance(fast, bool):
        raise ValueError(f"[replay] fast = {fast!r}: expected true or false")
    stops = replay.get("stops", "recorded")
    if stops not in STOPS:
        raise ValueError(f"[replay] stops = {stops!r}: expected one of {', '.join(STOPS)}")
    return AnalysisSettings(
        stops=stops,
        measurement=measurement,
        calibrations=dict(cal),
        target=target,
        sensors=dict(sensors),
        model_options=model,
        track=track,
        fast=fast,
        source=source,
    )


def load_settings(path: str | Path | None) -> AnalysisSettings:
    """``analysis.toml`` at ``path``; None gives the recorded settings of each session."""
    if path is None:
        return AnalysisSettings()
    from snrmon.acquisition.config import read_toml

    p = Path(path)
    data = read_toml(p, "analysis settings")
    settings = settings_from_dict(data, source=str(p.resolve()))
    # Workers open calibration files by path: a relative one is relative to analysis.toml.
    cals = {c: str((p.parent / f).resolve()) for c, f in settings.calibrations.items()}
    return replace(settings, calibrations=cals)
