"""Sensor, target and atmosphere presets: TOML files, validated with one clear error each.

Built-in names are the files in ``model/presets/`` (sensors "mwir", "lwir"; targets "uav1",
"uav2"); anything else is read as a path. Sensor TOML: a ``[sensor]`` table with the fields of
:class:`snrmon.model.sensor.Sensor`; target TOML: ``[target]`` with those of
:class:`snrmon.model.target.Target` (``temp_c`` a table by band or one number for all
bands; ``outline``, rows of "0"/"1", with ``outline_pixel_m``: the segmented outline of a close
stop, as ``snrmon characterize --target-out`` writes it, :class:`snrmon.model.target.Outline`);
atmosphere TOML: ``[atmosphere]`` with ``model`` (the season's standard atmosphere of the
built-in LOWTRAN7 table), the met readings ``air_temp_c``, ``rh_percent`` or ``dew_point_c``,
``pressure_hpa``, ``visibility_km``, ``aerosol`` (:class:`snrmon.model.atmosphere_table.Weather`),
``transmission`` (constant), ``aerosol_beta_per_km``, ``air_temp_k``, and optionally
``modtran_file`` or ``csv_file`` (relative to the TOML) with ``path_length_m`` (the file's
spectrum then replaces the table's), or ``modtran_files`` with ``path_lengths_m``, one tape7
per range of one air (``model.modtran.SpectralPath.at_ranges``); the met readings given are
the air whose curve of growth moves a file's spectrum to other ranges.
"""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path
from typing import Any

from snrmon.config_schema import (
    Key,
    SchemaError,
    above,
    any_of,
    at_least,
    between,
    checked,
    fraction,
    int_at_least,
    is_number,
    is_string,
    list_of,
)
from snrmon.model.constants import ZERO_C_K
from snrmon.model.sensor import DETECTOR_KINDS, REAL_PSF_KINDS, Sensor
from snrmon.model.target import Outline, Target

PRESET_DIR = Path(__file__).with_name("presets")
SENSOR_PRESETS = ("mwir", "lwir")
TARGET_PRESETS = ("uav1", "uav2")


def _qe_row(v: Any) -> bool:
    return isinstance(v, list) and len(v) == 2 and above(0)(v[0]) and between(0, 1)(v[1])


def _band_map(v: Any) -> dict[str, float]:
    if isinstance(v, dict):
        return {str(k): float(x) for k, x in v.items()}
    return {"mwir": float(v), "lwir": float(v)}


# The kinds of value a preset's key takes (snrmon.config_schema: one check, one message form).
_POS = Key("a number > 0", above(0), convert=float)
_NONNEG = Key("a number >= 0", at_least(0), convert=float)
_FRAC = Key("a number in (0, 1]", fraction, convert=float)
_FRAC0 = Key("a number in [0, 1]", between(0, 1), convert=float)
_NUM = Key("a number", is_number, convert=float)
_STR = Key("a string", is_string)
_INT = Key("a positive integer", int_at_least(1))
_PAIR = Key(
    "two positive numbers [lo, hi]",
    list_of(above(0), lengths=(2,)),
    convert=lambda v: (float(v[0]), float(v[1])),
)
_CURVE = Key(
    "a list of at least two [wavelength_um, qe] rows, wavelength > 0 and 0 <= qe <= 1",
    lambda v: list_of(_qe_row)(v) and len(v) >= 2,
    convert=lambda v: tuple((float(w), float(q)) for w, q in v),
)
_STRLIST = Key("a non-empty list of strings", list_of(is_string), convert=list)
_POSLIST = Key(
    "a non-empty list of numbers > 0", list_of(above(0)), convert=lambda v: [float(x) for x in v]
)
_BANDMAP = Key(
    "a temperature in C, or a table of them by band ({ mwir = 30.0, lwir = 31.0 })",
    any_of(
        is_number, lambda v: isinstance(v, dict) and bool(v) and all(map(is_number, v.values()))
    ),
    convert=_band_map,
)


def _required(key: Key) -> Key:
    return dataclasses.replace(key, required=True)


_SENSOR_FIELDS: dict[str, Key] = {
    "name": _required(_STR),
    "band_um": _required(_PAIR),
    "pitch_um": _required(_POS),
    "fill_factor": _required(_FRAC),
    "focal_length_m": _required(_POS),
    "f_number": _required(_POS),
    "width_px": _required(_INT),
    "height_px": _required(_INT),
    "fps": _required(_POS),
    "netd_mk": _required(_POS),
    "t_int_s": _required(_POS),
    "gain_e_per_dn": _required(_POS),
    "dn_offset": _NONNEG,
    "bit_depth": _INT,
    "detector": _STR,
    "qe": _FRAC,
    "qe_curve": _CURVE,
    "tau_optics": _FRAC,
    "tau_cold_filter": _FRAC,
    "read_noise_e": _NONNEG,
    "dark_current_a_per_cm2": _NONNEG,
    "well_capacity_e": _POS,
    "lens_temp_k": _POS,
    "lens_emissivity": _FRAC0,
    "cold_shield_temp_k": _NONNEG,
    "netd_reference_temp_k": _POS,
    "real_psf": _STR,
    "real_psf_sigma_px": _POS,
    "real_psf_average_pvf": _FRAC,
    "fov_deg": _PAIR,
    "description": _STR,
}
_TARGET_FIELDS: dict[str, Key] = {
    "name": _required(_STR),
    "small_m": _required(_POS),
    "large_m": _required(_POS),
    "temp_c": _required(_BANDMAP),
    "rss_delta_t_k": _BANDMAP,
    "description": _STR,
    "outline": _STRLIST,
    "outline_pixel_m": _POS,
}
_ATM_FIELDS: dict[str, Key] = {
    "name": _STR,
    "model": _STR,
    "transmission": _FRAC0,
    "aerosol_beta_per_km": _NONNEG,
    "air_temp_k": _POS,
    "air_temp_c": _NUM,
    "rh_percent": _NUM,
    "dew_point_c": _NUM,
    "pressure_hpa": _NUM,
    "visibility_km": _NUM,
    "aerosol": _STR,
    "modtran_file": _STR,
    "csv_file": _STR,
    "path_length_m": _POS,
    "modtran_files": _STRLIST,
    "path_lengths_m": _POSLIST,
    "source": _STR,
}


def _read_toml(path: Path, table: str) -> dict[str, Any]:
    try:
        with path.open("rb") as fh:
            doc = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: malformed TOML: {exc}") from None
    if table not in doc or not isinstance(doc[table], dict):
        raise ValueError(f"{path}: no [{table}] table")
    return doc[table]


def _check(path: Path, table: str, data: dict, fields: dict[str, Key]) -> dict[str, Any]:
    """``data`` checked against ``fields`` (:func:`snrmon.config_schema.checked`), the one
    error naming the file too."""
    try:
        return checked(data, fields, table)
    except SchemaError as exc:
        raise SchemaError(f"{path}: {exc}") from None


def _resolve(name_or_path: str, known: tuple[str, ...], what: str) -> Path:
    s = str(name_or_path)
    if s.lower() in known:
        return PRESET_DIR / f"{s.lower()}.toml"
    p = Path(s)
    if p.suffix.lower() == ".toml" and p.is_file():
        return p
    if p.suffix.lower() == ".toml":
        raise ValueError(f"{what} file not found: {s}")
    raise ValueError(f"unknown {what} {s!r}; known: {', '.join(known)} (or a .toml file)")


def sensor_from_dict(data: dict[str, Any], path: Path | str = "<sensor>") -> Sensor:
    """A validated :class:`Sensor` from a ``[sensor]`` table."""
    p = Path(path)
    v = _check(p, "sensor", data, _SENSOR_FIELDS)
    if v.get("detector", "photon") not in DETECTOR_KINDS:
        raise ValueError(
            f"{p}: sensor.detector must be one of {DETECTOR_KINDS}, got {v['detector']!r}"
        )
    kind = v.get("real_psf", "airy")
    if kind not in REAL_PSF_KINDS:
        raise ValueError(f"{p}: sensor.real_psf must be one of {REAL_PSF_KINDS}, got {kind!r}")
    if kind != "airy" and "real_psf_sigma_px" not in v and "real_psf_average_pvf" not in v:
        raise ValueError(f"{p}: real_psf {kind!r} needs real_psf_sigma_px or real_psf_average_pvf")
    if not v["band_um"][0] < v["band_um"][1]:
        raise ValueError(f"{p}: sensor.band_um must have lo < hi, got {list(v['band_um'])}")
    if not 1 <= v.get("bit_depth", 14) <= 16:
        raise ValueError(f"{p}: sensor.bit_depth must be 1-16 (data in 16-bit words)")
    return Sensor(**v)


def target_from_dict(data: dict[str, Any], path: Path | str = "<target>") -> Target:
    """A validated :class:`Target` from a ``[target]`` table."""
    p = Path(path)
    v = _check(p, "target", data, _TARGET_FIELDS)
    if v["small_m"] > v["large_m"]:
        raise ValueError(f"{p}: target.small_m ({v['small_m']}) is larger than large_m")
    for band, t in v["temp_c"].items():
        if t <= -ZERO_C_K:
            raise ValueError(f"{p}: target.temp_c.{band} must be above absolute zero, got {t}")
    rows, pixel_m = v.pop("outline", None), v.pop("outline_pixel_m", None)
    if (rows is None) != (pixel_m is None):
        raise ValueError(f"{p}: target.outline and target.outline_pixel_m go together")
    if rows is not None:
        try:
            v["outline"] = Outline(tuple(rows), float(pixel_m))
        except ValueError as exc:
            raise ValueError(f"{p}: target.outline: {exc}") from None
    return Target(**v)


def load_sensor(name_or_path: str) -> Sensor:
    """ "mwir", "lwir" (paper Table 1 presets) or a sensor TOML path."""
    path = _resolve(name_or_path, SENSOR_PRESETS, "sensor")
    return sensor_from_dict(_read_toml(path, "sensor"), path)


def load_target(name_or_path: str) -> Target:
    """ "uav1", "uav2" (paper section 3) or a target TOML path."""
    path = _resolve(name_or_path, TARGET_PRESETS, "target")
    return target_from_dict(_read_toml(path, "target"), path)


_MET_KEYS = ("air_temp_c", "rh_percent", "dew_point_c", "pressure_hpa", "visibility_km", "aerosol")


def load_atmosphere(path_like, band_um: tuple[float, float], path_length_m: float | None = None):
    """An :class:`snrmon.model.atmosphere.Atmosphere` from a TOML, a MODTRAN tape7 or a CSV file.
    tape7 and CSV files describe one path: ``path_length_m`` is required for them."""
    from snrmon.model.atmosphere import Atmosphere, weather_atmosphere
    from snrmon.model.atmosphere_table import Weather
    from snrmon.model.modtran import SpectralPath, read_spectral_csv, read_tape7

    p = Path(path_like)
    if not p.is_file():
        raise ValueError(f"atmosphere must be 'default', 'none' or a file; not found: {p}")
    if p.suffix.lower() == ".toml":
        v = _check(p, "atmosphere", _read_toml(p, "atmosphere"), _ATM_FIELDS)
        met = {k: v[k] for k in _MET_KEYS if k in v}
        base = Atmosphere()
        if "model" in v or met:
            try:
                weather = Weather(season=v.get("model", "us_std_1976"), **met)
            except ValueError as exc:
                raise ValueError(f"{p}: [atmosphere] {exc}") from None
            base = weather_atmosphere(band_um, weather)
        spectral = base.spectral
        # the air whose curve of growth moves a file's spectrum to other ranges: the readings
        # given here, else the model's default
        growth = base.weather
        for key, reader in (("modtran_file", read_tape7), ("csv_file", read_spectral_csv)):
            if key in v:
                if "path_length_m" not in v:
                    raise ValueError(f"{p}: {key} needs path_length_m (the file's path length)")
                spectral = dataclasses.replace(
                    reader(p.parent / v[key], v["path_length_m"]), growth=growth
                )
        if "modtran_files" in v:
            files, lengths = v["modtran_files"], v.get("path_lengths_m")
            if lengths is None or len(lengths) != len(files):
                raise ValueError(
                    f"{p}: modtran_files needs path_lengths_m, one per file (got "
                    f"{len(files)} files, {0 if lengths is None else len(lengths)} lengths)"
                )
            if "modtran_file" in v or "csv_file" in v:
                raise ValueError(f"{p}: give modtran_files or one modtran_file/csv_file, not both")
            spectral = SpectralPath.at_ranges(
                [read_tape7(p.parent / f, L) for f, L in zip(files, lengths, strict=True)],
                growth=growth,
            )
        atm = Atmosphere(
            name=v.get("name", p.stem),
            constant_tau=v.get("transmission", 1.0),
            aerosol_beta_per_km=v.get("aerosol_beta_per_km", 0.0),
            air_temp_k=v.get("air_temp_k", base.air_temp_k),
            spectral=spectral,
            source=v.get("source", base.source or str(p)),
            band_um=(float(band_um[0]), float(band_um[1])),
            weather=base.weather if spectral is base.spectral else None,
        )
    else:
        if path_length_m is None:
            raise ValueError(
                f"{p}: a MODTRAN/CSV spectrum needs its path length (--atmosphere-path-m, or an "
                "atmosphere TOML with path_length_m)"
            )
        reader = read_spectral_csv if p.suffix.lower() == ".csv" else read_tape7
        spectral = reader(p, path_length_m)
        atm = Atmosphere(
            name=p.name,
            spectral=spectral,
            source=str(p),
            band_um=(float(band_um[0]), float(band_um[1])),
        )
    if atm.spectral is not None and not atm.spectral.covers(band_um):
        lo, hi = atm.spectral.wavelength_um[0], atm.spectral.wavelength_um[-1]
        raise ValueError(
            f"{p}: spectrum covers {lo:.3f}-{hi:.3f} um, not the sensor band "
            f"{band_um[0]}-{band_um[1]} um"
        )
    return atm
