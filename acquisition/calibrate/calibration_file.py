"""Calibration files: the per-pixel maps in ``NAME.npz`` and their metadata in ``NAME.toml``.

The npz holds ``responsivity`` (DN per in-band photon radiance), ``offset_dn``, ``bad`` (uint8
bits dead=1, hot=2, noisy=4), ``fit_rms_dn`` and ``temporal_noise_dn``, all (H, W). The TOML
sidecar (readable and editable by a person) holds a ``[calibration]`` table: ``format``,
``camera``, ``band_um``, ``t_int_s``, ``date`` (UTC ISO 8601), ``blackbody_temps_c``,
``frames_per_temp``, ``width_px``/``height_px``, ``radiance_unit``, ``qe_curve`` and the one-point
``offset_updates``. On load, a sensor given is checked: a file for another camera, band or
integration time is one ValueError and nothing is returned.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import tomli_w

from snrmon.acquisition.calibrate.calibration import (
    RADIANCE_UNIT,
    Calibration,
    check_matches_sensor,
)
from snrmon.model.constants import ZERO_C_K

FORMAT = "snrmon-calibration-1"
_MAPS = ("responsivity", "offset_dn", "bad", "fit_rms_dn", "temporal_noise_dn")


def sidecar_path(path: str | Path) -> Path:
    """The TOML beside ``path`` (same stem)."""
    return Path(path).with_suffix(".toml")


def calibration_metadata(cal: Calibration) -> dict:
    """The sidecar's fields (also what a session records as its calibration event)."""
    return {
        "format": FORMAT,
        "camera": cal.camera,
        "band_um": list(cal.band_um),
        "t_int_s": cal.t_int_s,
        "date": cal.date,
        "blackbody_temps_c": [round(t - ZERO_C_K, 6) for t in cal.temps_k],
        "frames_per_temp": list(cal.frames_per_temp),
        "width_px": int(cal.shape[1]),
        "height_px": int(cal.shape[0]),
        "radiance_unit": RADIANCE_UNIT,
        "qe_curve": [list(p) for p in cal.qe_curve],
        "offset_updates": list(cal.offset_updates),
        "bad_pixels": int(np.count_nonzero(cal.bad)),
    }


def save_calibration(cal: Calibration, path: str | Path) -> Path:
    """Write ``path`` (.npz) and its TOML sidecar; returns the npz path."""
    p = Path(path)
    if p.suffix.lower() != ".npz":
        raise ValueError(f"calibration file must end in .npz, got {p}")
    np.savez(p, **{k: getattr(cal, k) for k in _MAPS})
    meta = calibration_metadata(cal)
    if not meta["qe_curve"]:
        del meta["qe_curve"]  # absent: flat QE
    header = "# snrmon radiometric calibration (maps in the .npz beside this file)\n"
    sidecar_path(p).write_text(header + tomli_w.dumps({"calibration": meta}))
    return p


def load_calibration(
    path: str | Path, sensor=None, *, frame_shape: tuple[int, int] | None = None
) -> Calibration:
    """Read a calibration; with ``sensor`` (``model.presets.load_sensor``) check it is this
    camera's, band's and integration time's, and that the maps fit ``frame_shape`` (rows,
    columns; e.g. a recording's) or, without it, the sensor's format."""
    p = Path(path)
    side = sidecar_path(p)
    for f in (p, side):
        if not f.is_file():
            raise FileNotFoundError(f"calibration file {f} not found")
    try:
        meta = tomllib.loads(side.read_text()).get("calibration")
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{side}: malformed TOML: {exc}") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise ValueError(f"{side}: not a snrmon calibration sidecar (format {FORMAT!r} expected)")
    try:
        with np.load(p, allow_pickle=False) as z:
            maps = {k: z[k] for k in _MAPS}
    except KeyError as exc:
        raise ValueError(f"{p}: calibration map {exc} missing") from None
    except (ValueError, OSError) as exc:
        raise ValueError(f"{p}: not a readable calibration npz ({exc})") from None
    cal = calibration_from_record(meta, maps, source=str(p))
    if sensor is not None:
        check_matches_sensor(cal, sensor, source=f"calibration {p.name}")
    expect = frame_shape or (sensor and (sensor.height_px, sensor.width_px))
    if expect and cal.shape != tuple(expect):
        raise ValueError(
            f"calibration {p.name} is for {cal.shape[1]}x{cal.shape[0]} frames, the frames are "
            f"{expect[1]}x{expect[0]}"
        )
    return cal


def calibration_record(cal: Calibration) -> tuple[dict, dict[str, np.ndarray]]:
    """``(metadata, maps)`` of ``cal``: what a session file keeps of the calibration it was
    measured with (:func:`calibration_from_record` reads it back)."""
    return calibration_metadata(cal), {k: getattr(cal, k) for k in _MAPS}


def calibration_from_record(meta: dict, maps: dict[str, np.ndarray], *, source: str) -> Calibration:
    """The :class:`Calibration` of its metadata (the sidecar's ``[calibration]`` table) and
    per-pixel maps; ``source`` names where they came from in an error."""
    missing = [k for k in _MAPS if k not in maps]
    if missing:
        raise ValueError(f"{source}: calibration map {missing[0]!r} missing")
    try:
        shape = (int(meta["height_px"]), int(meta["width_px"]))
        for k in _MAPS:
            if maps[k].shape != shape:
                raise ValueError(f"{source}: map {k} is {maps[k].shape}, the metadata says {shape}")
        return Calibration(
            camera=str(meta["camera"]),
            band_um=(float(meta["band_um"][0]), float(meta["band_um"][1])),
            t_int_s=float(meta["t_int_s"]),
            temps_k=tuple(float(t) + ZERO_C_K for t in meta["blackbody_temps_c"]),
            responsivity=maps["responsivity"].astype(np.float32, copy=False),
            offset_dn=maps["offset_dn"].astype(np.float32, copy=False),
            bad=maps["bad"].astype(np.uint8, copy=False),
            fit_rms_dn=maps["fit_rms_dn"].astype(np.float32, copy=False),
            temporal_noise_dn=maps["temporal_noise_dn"].astype(np.float32, copy=False),
            qe_curve=tuple(tuple(float(x) for x in row) for row in meta.get("qe_curve", [])),
            date=str(meta.get("date", "")),
            frames_per_temp=tuple(int(n) for n in meta.get("frames_per_temp", [])),
            offset_updates=tuple(str(s) for s in meta.get("offset_updates", [])),
        )
    except KeyError as exc:
        raise ValueError(f"{source}: calibration metadata {exc} missing") from None
    except (TypeError, IndexError) as exc:
        raise ValueError(f"{source}: malformed calibration metadata ({exc})") from None
