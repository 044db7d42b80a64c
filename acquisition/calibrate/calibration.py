"""Radiometric calibration of one camera from extended-blackbody captures.

Owns the per-pixel response model, its fit, the bad-pixel map, the conversion of frames to
in-band radiance and apparent (brightness) temperature, the one-point offset update and the
quality report. The physics is the model's (``model.radiometry``): the camera is taken to be
linear in the in-band PHOTON radiance of the scene (the model's photon-counting convention, used
for the bolometer too, docs/model.md), QE-weighted when the sensor has a QE curve:

    DN_ij = offset_ij + responsivity_ij * L(T)           L in photons s^-1 m^-2 sr^-1

Two temperatures give the classic two-point NUC; more give the per-pixel least-squares line and
its residual. Radiance -> temperature inverts L(T) by interpolation on a dense monotonic table.
NETD measured = temporal noise [DN] / (responsivity dL/dT) [DN/K] (paper Table 1's figure is the
sensor preset's ``netd_mk``). Bad input (saturated captures, fewer than two temperatures, a
response that does not rise with temperature) is one ValueError; nothing is returned then.
"""

from __future__ import annotations

import datetime as _dt
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from snrmon.model.constants import ZERO_C_K
from snrmon.model.radiometry import (
    band_nodes,
    spectral_photon_radiance,
    spectral_photon_radiance_dt,
)

RADIANCE_UNIT = "photons s^-1 m^-2 sr^-1 (in-band, QE-weighted)"
DEAD, HOT, NOISY = 1, 2, 4
BAD_NAMES = {DEAD: "dead", HOT: "hot", NOISY: "noisy"}
ROBUST_Z = 6.0  # robust z beyond which a pixel is bad: ~2e-9 false rate per pixel if Gaussian
DEAD_FRACTION = 0.25  # responsivity below this share of the median: dead whatever the spread
SATURATED_SHARE = 1e-3  # more pixels than this at a rail: the capture is unusable
_T_GRID_K = (150.0, 700.0, 0.025)
Window = tuple[int, int, int, int]


# ------------------------------------------------------------------------------ radiance scale
@functools.lru_cache(maxsize=16)
def temperature_table(
    band_um: tuple[float, float], qe_curve: tuple
) -> tuple[np.ndarray, np.ndarray]:
    """(temperatures [K], band photon radiances) on the 0.025 K grid that
    :func:`temperature_of` inverts (the sky temperature's compiled lookup reads it too)."""
    t = np.arange(_T_GRID_K[0], _T_GRID_K[1] + _T_GRID_K[2], _T_GRID_K[2])
    wl, w = band_nodes(band_um, 64)
    return t, np.sum((w * _qe(wl, qe_curve))[:, None] * spectral_photon_radiance(wl, t), axis=0)


def _qe(wl_um: np.ndarray, qe_curve: tuple) -> np.ndarray:
    if not qe_curve:
        return np.ones_like(wl_um)
    c = np.asarray(qe_curve, float)
    return np.interp(wl_um, c[:, 0], c[:, 1], left=0.0, right=0.0) / c[:, 1].max()


def radiance_of(band_um: Sequence[float], temp_k, qe_curve: tuple = ()) -> np.ndarray:
    """In-band photon radiance of a blackbody at ``temp_k`` (array ok), QE-weighted (relative
    to the curve's peak) when ``qe_curve`` is given; same quadrature as ``model.radiometry``."""
    t = np.asarray(temp_k, float)
    if not np.all(t > 0):
        raise ValueError(f"temperature must be > 0 K, got {temp_k!r}")
    wl, w = band_nodes(tuple(map(float, band_um)), 64)
    out = np.sum((w * _qe(wl, qe_curve))[:, None] * spectral_photon_radiance(wl, t.ravel()), 0)
    return out.reshape(t.shape)


def radiance_dt_of(band_um: Sequence[float], temp_k: float, qe_curve: tuple = ()) -> float:
    """dL/dT [photons s^-1 m^-2 sr^-1 K^-1] of :func:`radiance_of`."""
    wl, w = band_nodes(tuple(map(float, band_um)), 64)
    return float(np.sum(w * _qe(wl, qe_curve) * spectral_photon_radiance_dt(wl, float(temp_k))))


def temperature_of(band_um: Sequence[float], radiance, qe_curve: tuple = ()) -> np.ndarray:
    """Brightness temperature [K] of an in-band radiance (inverse of :func:`radiance_of` by
    interpolation on a 0.025 K table, 150-700 K; outside it NaN)."""
    t, lq = temperature_table(tuple(map(float, band_um)), tuple(qe_curve))
    r = np.asarray(radiance, float)
    return np.interp(r, lq, t, left=np.nan, right=np.nan)


# ------------------------------------------------------------------------------ data
@dataclass(frozen=True)
class BlackbodyCapture:
    """A stack (N, H, W) of raw frames looking into an extended blackbody at ``temp_k``."""

    temp_k: float
    frames: np.ndarray


@dataclass(frozen=True, eq=False)
class Calibration:
    """Per-pixel response of one camera. Maps are (H, W) float32; ``bad`` a uint8 bit mask of
    DEAD | HOT | NOISY. ``responsivity`` in DN per radiance unit, ``offset_dn`` the DN at zero
    in-band radiance, ``fit_rms_dn`` the per-pixel RMS residual of the line (0 with two points),
    ``temporal_noise_dn`` the per-pixel temporal std averaged over the captures."""

    camera: str
    band_um: tuple[float, float]
    t_int_s: float
    temps_k: tuple[float, ...]
    responsivity: np.ndarray
    offset_dn: np.ndarray
    bad: np.ndarray
    fit_rms_dn: np.ndarray
    temporal_noise_dn: np.ndarray
    qe_curve: tuple = ()
    date: str = ""
    frames_per_temp: tuple[int, ...] = ()
    offset_updates: tuple[str, ...] = field(default=())

    @property
    def shape(self) -> tuple[int, int]:
        return self.responsivity.shape

    @property
    def good(self) -> np.ndarray:
        return self.bad == 0

    @functools.cached_property
    def mean_responsivity(self) -> float:
        return float(np.mean(self.responsivity[self.good]))

    @functools.cached_property
    def mean_offset_dn(self) -> float:
        return float(np.mean(self.offset_dn[self.good]))

    @functools.cached_property
    def safe_responsivity(self) -> np.ndarray:
        """The responsivity map divided by in :meth:`correct`: dead pixels' (~0) replaced by
        the mean (their values are replaced after the division anyway)."""
        r = self.responsivity
        return np.where(self.good & (r > 0), r, np.float32(self.mean_responsivity))

    def _check_shape(self, frame: np.ndarray) -> None:
        if frame.shape[-2:] != self.shape:
            raise ValueError(
                f"calibration of {self.camera!r} is for {self.shape[1]}x{self.shape[0]} frames, "
                f"got {frame.shape[-1]}x{frame.shape[-2]}"
            )

    def radiance(self, frame: np.ndarray, window: Window | None = None) -> np.ndarray:
        """In-band radiance per pixel (bad pixels: the median of their 3x3 neighbourhood).
        ``window`` (row0, row1, col0, col1), half-open, computes only that part of the frame."""
        self._check_shape(frame)
        sl = np.s_[:, :] if window is None else np.s_[window[0] : window[1], window[2] : window[3]]
        lq = (np.asarray(frame[sl], np.float32) - self.offset_dn[sl]) / self.safe_responsivity[sl]
        return _fill_bad(lq.astype(np.float32), self.bad[sl])

    def correct(self, frame: np.ndarray, window: Window | None = None) -> np.ndarray:
        """Two-point non-uniformity-corrected frame (float32 DN): every pixel mapped to the
        array's mean response, bad pixels replaced."""
        return self.mean_offset_dn + self.mean_responsivity * self.radiance(frame, window)

    def temperature_k(self, frame: np.ndarray, window: Window | None = None) -> np.ndarray:
        """Apparent (brightness) temperature per pixel [K]."""
        return temperature_of(self.band_um, self.radiance(frame, window), self.qe_curve)

    def pixels_temperature_k(self, values_dn, rows, cols) -> np.ndarray:
        """Apparent temperature of raw values at (rows, cols), without touching the frame."""
        v = np.asarray(values_dn, float)
        lq = (v - self.offset_dn[rows, cols]) / self.responsivity[rows, cols]
        return temperature_of(self.band_um, lq, self.qe_curve)

    def dn_per_k(self, temp_k: float) -> float:
        """Mean responsivity to scene temperature [DN/K] at ``temp_k``."""
        return self.mean_responsivity * radiance_dt_of(self.band_um, temp_k, self.qe_curve)

    def with_offset_update(self, frames: np.ndarray, temp_k: float | None = None) -> Calibration:
        """One-point offset update for drift (shutter or sky frame(s), (H, W) or (N, H, W)).

        With ``temp_k`` (a shutter at a known temperature) every offset is solved so the pixel
        reads L(temp_k). Without it (a uniform clear-sky patch) only the non-uniformity is
        removed: each pixel is made to read the array's median radiance of that frame, so the
        absolute level is kept from the blackbody fit. Responsivity is kept."""
        stack = np.asarray(frames, np.float32)
        mean = stack if stack.ndim == 2 else stack.mean(axis=0)
        self._check_shape(mean)
        if temp_k is not None:
            level = float(radiance_of(self.band_um, temp_k, self.qe_curve))
            note = f"shutter {temp_k:.2f} K"
        else:
            level = float(np.median(((mean - self.offset_dn) / self.responsivity)[self.good]))
            note = "sky (uniform scene)"
        offset = (mean - self.responsivity * np.float32(level)).astype(np.float32)
        stamp = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
        return replace(
            self, offset_dn=offset, offset_updates=(*self.offset_updates, f"{stamp} {note}")
        )


def _fill_bad(img: np.ndarray, bad: np.ndarray) -> np.ndarray:
    if not bad.any():
        return img
    med = cv2.medianBlur(np.where(bad == 0, img, np.float32(np.median(img))), 3)
    return np.where(bad == 0, img, med).astype(np.float32)


# ------------------------------------------------------------------------------ fit
def _robust_z(x: np.ndarray) -> np.ndarray:
    med = np.median(x)
    mad = 1.4826 * np.median(np.abs(x - med))
    return (x - med) / (mad if mad > 0 else max(abs(med) * 1e-9, 1e-30))


def _check_captures(captures: Sequence[BlackbodyCapture], full_scale_dn: int) -> None:
    temps = sorted({round(float(c.temp_k), 6) for c in captures})
    if len(temps) < 2:
        raise ValueError(
            f"calibration needs blackbody captures at >= 2 distinct temperatures, got "
            f"{[round(t - ZERO_C_K, 3) for t in temps]} C"
        )
    shapes = {np.shape(c.frames)[-2:] for c in captures}
    if len(shapes) != 1:
        raise ValueError(f"blackbody captures differ in frame size: {sorted(shapes)}")
    for c in captures:
        f = np.asarray(c.frames)
        if f.ndim != 3 or f.shape[0] < 2:
            raise ValueError(
                f"blackbody capture at {c.temp_k - ZERO_C_K:.2f} C needs a stack of >= 2 frames "
                f"(the temporal noise), got shape {f.shape}"
            )
        for rail, what in ((full_scale_dn, f"full scale {full_scale_dn} DN"), (0, "0 DN")):
            share = float(np.mean(f == rail) if rail == 0 else np.mean(f >= rail))
            if share > SATURATED_SHARE:
                raise ValueError(
                    f"blackbody capture at {c.temp_k - ZERO_C_K:.2f} C saturates: "
                    f"{100 * share:.2f}% of pixel values at {what}"
                )


def calibrate(
    captures: Sequence[BlackbodyCapture],
    *,
    camera: str,
    band_um: tuple[float, float],
    t_int_s: float,
    full_scale_dn: int,
    qe_curve: tuple = (),
) -> Calibration:
    """Per-pixel gain/offset (least squares over >= 2 temperatures) and the bad-pixel map.

    Use :func:`calibrate_sensor` to take camera, band, t_int and full scale from a sensor."""
    _check_captures(captures, full_scale_dn)
    captures = sorted(captures, key=lambda c: c.temp_k)
    means, stds = [], []
    for c in captures:
        f = np.asarray(c.frames, np.float32)
        means.append(f.mean(axis=0, dtype=np.float64).astype(np.float32))
        stds.append(f.std(axis=0, ddof=1, dtype=np.float64).astype(np.float32))
    counts = [int(np.shape(c.frames)[0]) for c in captures]
    return calibrate_means(
        [c.temp_k for c in captures],
        means,
        stds,
        counts,
        camera=camera,
        band_um=band_um,
        t_int_s=t_int_s,
        qe_curve=qe_curve,
    )


def calibrate_means(
    temps_k: Sequence[float],
    means: Sequence[np.ndarray],
    stds: Sequence[np.ndarray],
    counts: Sequence[int],
    *,
    camera: str,
    band_um: tuple[float, float],
    t_int_s: float,
    qe_curve: tuple = (),
) -> Calibration:
    """:func:`calibrate` from each capture's per-pixel mean and temporal std (ddof=1) over
    ``counts`` frames, in increasing temperature (a long capture accumulated frame by frame)."""
    m = np.stack(means)  # (K, H, W)
    x = radiance_of(band_um, list(temps_k), qe_curve).astype(np.float64)
    levels = np.median(m.reshape(len(m), -1), axis=1)
    if np.any(np.diff(levels) <= 0):
        pairs = ", ".join(
            f"{t - ZERO_C_K:.2f} C: {lv:.1f} DN" for t, lv in zip(temps_k, levels, strict=True)
        )
        raise ValueError(
            f"non-monotonic response: median DN does not rise with temperature ({pairs})"
        )
    xc = x - x.mean()
    resp = np.tensordot(xc, m - m.mean(axis=0), axes=1) / float(xc @ xc)
    offset = m.mean(axis=0) - resp * x.mean()
    resid = m - (offset[None] + resp[None] * x[:, None, None])
    dof = max(len(x) - 2, 1)
    fit_rms = np.sqrt(np.sum(resid**2, axis=0) / dof) if len(x) > 2 else np.zeros_like(resp)
    noise = np.sqrt(np.mean(np.stack(stds) ** 2, axis=0))
    bad = _bad_pixels(resp, m[0], noise)
    return Calibration(
        camera=camera,
        band_um=(float(band_um[0]), float(band_um[1])),
        t_int_s=float(t_int_s),
        temps_k=tuple(float(t) for t in temps_k),
        responsivity=resp.astype(np.float32),
        offset_dn=offset.astype(np.float32),
        bad=bad,
        fit_rms_dn=fit_rms.astype(np.float32),
        temporal_noise_dn=noise.astype(np.float32),
        qe_curve=tuple(qe_curve),
        date=_dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        frames_per_temp=tuple(int(n) for n in counts),
    )


def calibrate_sensor(captures: Sequence[BlackbodyCapture], sensor) -> Calibration:
    """:func:`calibrate` for a ``model.sensor.Sensor`` (``model.presets.load_sensor``)."""
    return calibrate(
        captures,
        camera=sensor.name,
        band_um=tuple(sensor.band_um),
        t_int_s=sensor.t_int_s,
        full_scale_dn=sensor.full_scale_dn,
        qe_curve=tuple(sensor.qe_curve),
    )


def _bad_pixels(resp: np.ndarray, cold_level: np.ndarray, noise: np.ndarray) -> np.ndarray:
    """Dead: responsivity below DEAD_FRACTION of the median or robust z < -6; hot: level at the
    coldest capture robust z > +6 or over-responsive z > +6; noisy: temporal std robust z > +6.
    Median/MAD so that the bad pixels themselves do not widen the threshold."""
    bad = np.zeros(resp.shape, np.uint8)
    zr = _robust_z(resp)
    bad[(resp < DEAD_FRACTION * np.median(resp)) | (zr < -ROBUST_Z)] |= DEAD
    bad[(_robust_z(cold_level) > ROBUST_Z) | (zr > ROBUST_Z)] |= HOT
    bad[_robust_z(noise) > ROBUST_Z] |= NOISY
    return bad


def check_matches_sensor(cal: Calibration, sensor, *, source: str = "calibration") -> None:
    """ValueError unless ``cal`` was made for ``sensor``'s camera, band and integration time."""
    if cal.camera != sensor.name:
        raise ValueError(f"{source} is for camera {cal.camera!r}, not {sensor.name!r}")
    if not np.allclose(cal.band_um, sensor.band_um, rtol=0, atol=1e-6):
        raise ValueError(
            f"{source} is for band {cal.band_um[0]}-{cal.band_um[1]} um, not the sensor's "
            f"{sensor.band_um[0]}-{sensor.band_um[1]} um"
        )
    if not math.isclose(cal.t_int_s, sensor.t_int_s, rel_tol=1e-6):
        raise ValueError(
            f"{source} was made at integration time {cal.t_int_s * 1e3:g} ms, the sensor runs "
            f"{sensor.t_int_s * 1e3:g} ms"
        )
