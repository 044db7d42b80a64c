"""The quality of a radiometric calibration: residual non-uniformity, fit residual,
bad pixels and the measured NETD, on the calibration's own captures or held-out ones.

Each blackbody capture's 3D noise (:mod:`snrmon.acquisition.measure.noise3d`: raw frames, the
whole frame, bias-corrected components with 95 % intervals) gives the NETD as infrared engineers
quote it: sigma_tvh / SiTF, the SiTF [DN/K] being the mean responsivity at the blackbody's
temperature. The per-pixel figure beside it (the median per-pixel temporal std over the SiTF)
also holds the frame flicker and the row and column noise that change every frame."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from snrmon.acquisition.calibrate.calibration import BAD_NAMES, BlackbodyCapture, Calibration
from snrmon.acquisition.measure.noise3d import noise_3d


@dataclass(frozen=True)
class TemperatureQuality:
    """Quality at one blackbody temperature (spatial figures over good pixels, one frame)."""

    temp_k: float
    raw_spatial_dn: float  # total spatial std of a raw frame
    corrected_spatial_dn: float  # the same after correction (temporal noise + residual)
    temporal_noise_dn: float  # median per-pixel temporal std
    residual_fpn_dn: float  # sqrt(corrected^2 - temporal^2): non-uniformity left
    residual_fpn_mk: float
    dn_per_k: float
    netd_mk: float  # temporal noise / (dDN/dT): measured NETD
    apparent_temp_k: float  # median apparent temperature of the mean frame
    sigma_tvh_dn: float = math.nan  # 3D noise: random spatio-temporal, bias-corrected
    netd_tvh_mk: float = math.nan  # sigma_tvh / (dDN/dT): NETD from the 3D noise
    netd_tvh_ci95_mk: tuple[float, float] = (math.nan, math.nan)
    # the capture's 3D noise: frames, rows, cols, mean_dn, sigma_dn, sigma_corrected_dn, ci95_dn
    noise_3d: dict = field(default_factory=dict)


@dataclass(frozen=True)
class CalibrationQuality:
    camera: str
    netd_table_mk: float | None
    temperatures: tuple[TemperatureQuality, ...]
    fit_rms_median_dn: float
    fit_rms_max_dn: float
    bad_counts: dict[str, int]

    def as_dict(self) -> dict:
        return {
            "camera": self.camera,
            "netd_table_mk": self.netd_table_mk,
            "fit_rms_median_dn": self.fit_rms_median_dn,
            "fit_rms_max_dn": self.fit_rms_max_dn,
            "bad_pixels": dict(self.bad_counts),
            "temperatures": [q.__dict__.copy() for q in self.temperatures],
        }


def _spatial_std(img: np.ndarray, good: np.ndarray) -> float:
    return float(np.std(img[good], dtype=np.float64, ddof=1))


def calibration_quality(
    cal: Calibration, captures: Sequence[BlackbodyCapture], netd_table_mk: float | None = None
) -> CalibrationQuality:
    """Residual non-uniformity, fit residual and measured NETD on ``captures`` (the
    calibration's own, or better, captures held out from the fit)."""
    good = cal.good
    rows = []
    for c in sorted(captures, key=lambda c: c.temp_k):
        f = np.asarray(c.frames)
        cal._check_shape(f)
        last = np.asarray(f[-1], np.float32)
        raw = _spatial_std(last, good)
        corr = _spatial_std(cal.correct(last), good)
        temporal = float(np.median(np.asarray(f, np.float32).std(axis=0, ddof=1)[good]))
        dndk = cal.dn_per_k(c.temp_k)
        resid = math.sqrt(max(corr**2 - temporal**2, 0.0))
        t_app = float(np.median(cal.temperature_k(np.asarray(f, np.float32).mean(0))[good]))
        cube = noise_3d(f)
        tvh = cube.sigma_corrected["tvh"]
        lo, hi = cube.ci95["tvh"]
        rows.append(
            TemperatureQuality(
                float(c.temp_k),
                raw,
                corr,
                temporal,
                resid,
                1e3 * resid / dndk,
                dndk,
                1e3 * temporal / dndk,
                t_app,
                tvh,
                1e3 * tvh / dndk,
                (1e3 * lo / dndk, 1e3 * hi / dndk),
                {
                    "frames": cube.frames,
                    "rows": cube.rows,
                    "cols": cube.cols,
                    "mean_dn": cube.mean,
                    **cube.figures("dn"),
                },
            )
        )
    counts = {name: int(np.count_nonzero(cal.bad & bit)) for bit, name in BAD_NAMES.items()}
    counts["total"] = int(np.count_nonzero(cal.bad))
    return CalibrationQuality(
        camera=cal.camera,
        netd_table_mk=netd_table_mk,
        temperatures=tuple(rows),
        fit_rms_median_dn=float(np.median(cal.fit_rms_dn[good])),
        fit_rms_max_dn=float(np.max(cal.fit_rms_dn[good])),
        bad_counts=counts,
    )
