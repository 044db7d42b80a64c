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
import math
import tomllib
from pathlib import Path
from typing import Any

from snrmon.model.constants import ZERO_C_K
from snrmon.model.sensor import DETECTOR_KINDS, REAL_PSF_KINDS, Sensor
from snrmon.model.target import Outline, Target

PRESET_DIR = Path(__file__).with_name("presets")
SENSOR_PRESETS = ("mwir", "lwir")
TARGET_PRESETS = ("uav1", "uav2")

_POS, _NONNEG, _FRAC, _STR, _INT, _PAIR = "pos", "nonneg", "frac", "str", "int", "pair"
_SENSOR_FIELDS: dict[str, tuple[str, bool]] = {
    # name: (kind, required)
    "name": (_STR, True),
    "band_um": (_PAIR, True),
    "pitch_um": (_POS, True),
    "fill_factor": (_FRAC, True),
    "focal_length_m": (_POS, True),
    "f_number": (_POS, True),
    "width_px": (_INT, True),
    "height_px": (_INT, True),
    "fps": (_POS, True),
    "netd_mk": (_POS, True),
    "t_int_s": (_POS, True),
    "gain_e_per_dn": (_POS, True),
    "dn_offset": (_NONNEG, False),
    "bit_depth": (_INT, False),
    "detector": (_STR, False),
    "qe": (_FRAC, False),
    "qe_curve": ("curve", False),
    "tau_optics": (_FRAC, False),
    "tau_cold_filter": (_FRAC, False),
    "read_noise_e": (_NONNEG, False),
    "dark_current_a_per_cm2": (_NONNEG, False),
    "well_capacity_e": (_POS, False),
    "lens_temp_k": (_POS, False),
    "lens_emissivity": ("frac0", False),
    "cold_shield_temp_k": (_NONNEG, False),
    "netd_reference_temp_k": (_POS, False),
    "real_psf": (_STR, False),
    "real_psf_sigma_px": (_POS, False),
    "real_psf_average_pvf": (_FRAC, False),
    "fov_deg": (_PAIR, False),
    "description": (_STR, False),
}
_TARGET_FIELDS = {
    "name": (_STR, True),
    "small_m": (_POS, True),
    "large_m": (_POS, True),
    "temp_c": ("bandmap", True),
    "rss_delta_t_k": ("bandmap", False),
    "description": (_STR, False),
    "outline": ("strlist", False),
    "outline_pixel_m": (_POS, False),
}
_ATM_FIELDS = {
    "name": (_STR, False),
    "model": (_STR, False),
    "transmission": ("frac0", False),
    "aerosol_beta_per_km": (_NONNEG, False),
    "air_temp_k": (_POS, False),
    "air_temp_c": ("num", False),
    "rh_percent": ("num", False),
    "dew_point_c": ("num", False),
    "pressure_hpa": ("num", False),
    "visibility_km": ("num", False),
    "aerosol": (_STR, False),
    "modtran_file": (_STR, False),
    "csv_file": (_STR, False),
    "path_length_m": (_POS, False),
    "modtran_files": ("strlist", False),
    "path_lengths_m": ("poslist", False),
    "source": (_STR, False),
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


def _check(path: Path, table: str, data: dict, fields: dict) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key in data:
        if key not in fields:
            raise ValueError(
                f"{path}: unknown key {key!r} in [{table}]; known: {', '.join(fields)}"
            )
    for key, (kind, required) in fields.items():
        if key not in data:
            if required:
                raise ValueError(f"{path}: [{table}] is missing {key!r}")
            continue
        out[key] = _value(path, f"{table}.{key}", kind, data[key])
    return out


def _number(path: Path, where: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise ValueError(f"{path}: {where} must be a number, got {v!r}")
    return float(v)


def _value(path: Path, where: str, kind: str, v: Any) -> Any:
    if kind == _STR:
        if not isinstance(v, str):
            raise ValueError(f"{path}: {where} must be a string, got {v!r}")
        return v
    if kind == _INT:
        if isinstance(v, bool) or not isinstance(v, int) or v <= 0:
            raise ValueError(f"{path}: {where} must be a positive integer, got {v!r}")
        return v
    if kind == _PAIR:
        if not isinstance(v, list) or len(v) != 2:
            raise ValueError(f"{path}: {where} must be a pair [a, b], got {v!r}")
        a, b = (_number(path, where, x) for x in v)
        if not (a > 0 and b > 0):
            raise ValueError(f"{path}: {where} must be two positive numbers, got {v!r}")
        return (a, b)
    if kind == "curve":
        if not isinstance(v, list) or len(v) < 2:
            raise ValueError(
                f"{path}: {where} must be a list of [wavelength_um, qe] pairs, got {v!r}"
            )
        return tuple(tuple(_value(path, where, "pairqe", x)) for x in v)
    if kind == "pairqe":
        if not isinstance(v, list) or len(v) != 2:
            raise ValueError(f"{path}: {where} rows must be [wavelength_um, qe], got {v!r}")
        wl, q = (_number(path, where, x) for x in v)
        if wl <= 0 or not 0 <= q <= 1:
            raise ValueError(f"{path}: {where} row {v!r} needs wavelength > 0 and 0 <= qe <= 1")
        return (wl, q)
    if kind in ("strlist", "poslist"):
        one = _STR if kind == "strlist" else _POS
        if not isinstance(v, list) or not v:
            raise ValueError(f"{path}: {where} must be a non-empty list, got {v!r}")
        return [_value(path, f"{where}[{i}]", one, x) for i, x in enumerate(v)]
    if kind == "bandmap":
        if isinstance(v, dict):
            return {str(k): _number(path, f"{where}.{k}", x) for k, x in v.items()}
        return {"mwir": _number(path, where, v), "lwir": _number(path, where, v)}
    x = _number(path, where, v)
    if kind == "num":
        return x
    ok = {
        _POS: x > 0,
        _NONNEG: x >= 0,
        _FRAC: 0 < x <= 1,
        "frac0": 0 <= x <= 1,
    }[kind]
    if not ok:
        rule = {_POS: "> 0", _NONNEG: ">= 0", _FRAC: "in (0, 1]", "frac0": "in [0, 1]"}[kind]
        raise ValueError(f"{path}: {where} must be {rule}, got {v!r}")
    return x


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
