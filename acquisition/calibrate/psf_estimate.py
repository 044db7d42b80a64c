"""The camera's PSF from the flight itself: fit the pixel patterns of an unresolved drone.

While the drone hovers at an unresolved stop the wind drifts it across sub-pixel phases (paper
section 7), so the 100 frames of a stop sample the PSF at many phases. Per frame, a 13 x 13
crop around the measured peak is taken (non-uniformity corrected with the camera's calibration
when there is one); its background is the median of the outer two rings (radius 5-6 px) and
its noise their robust std; the central 7 x 7 pixels are the data (the box of Eq. 4).

A PSF family with one shape parameter theta is fitted to all frames at once by profile
least squares: for each theta the expected patterns ``model.footprint.pixel_patterns`` of the
PSF convolved with the drone (a square of its small dimension at the stop's range, the model's
geometry) are tabulated on a grid of centroid offsets (+/- 0.75 px, 1/12 px steps); each frame
takes the best offset and a free amplitude, chi^2 = sum over frames of the residual over the
frame's noise^2, minimised over theta (a parabola through the grid's three best points).
Two families:

* ``gaussian``: a Gaussian PSF of sigma = theta (the paper's "Gaussian PSF fit ... sigma of 0.8
  pixels", section 5), reported as ``sigma_px``;
* ``airy+gaussian``: the camera's own diffraction (its F-number over its band, weighted by the
  signal spectrum as the model's uncorrected curves, ``model.sensor.signal_weighted_airy``;
  flat QE) convolved with a Gaussian blur theta: the physical family, whose average
  PVF (``model.pvf.average_pvf``) is reported as ``pvf`` and whose PSF the corrected curves and
  the expected Eq. (4) reading can use.

The spread (``*_std``) is from 200 bootstrap resamples of the frames (seeded), which carries the
noise and any misfit of the family. Stops may be pooled (their chi^2 add; the drone's size is
each stop's own). Refused, with the stop and the reason: a resolved drone (small dimension >= 1
px: its pixels show the drone, not the PSF), fewer than ``min_frames`` frames.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

from snrmon.model.footprint import matmul, pixel_patterns
from snrmon.model.psf import AiryGaussianPsf, GaussianPsf
from snrmon.model.pvf import average_pvf

CROP_HALF = 6
FIT_HALF = 3
_OFFSETS = np.arange(-9, 10) / 12.0  # candidate centroid offsets from the crop centre [px]
_GRIDS = {
    "gaussian": np.arange(0.15, 2.501, 0.1),
    "airy+gaussian": np.arange(0.0, 2.001, 0.1),
}
_GAUSS_BASE_PX = 0.15  # the Gaussian family as this PSF times a Gaussian "target" blur
_BOOTSTRAP = 200


class PsfEstimateError(ValueError):
    """A stop that cannot give a PSF (resolved drone, too few frames): the message says which
    stop and why."""


@dataclass(frozen=True)
class StopCrops:
    """One stop's frames for the fit: ``crops`` (N, 13, 13) float pixel values centred on each
    frame's peak; ``target_px`` the drone's small dimension in pixels at the stop's range."""

    label: str  # e.g. "stop 3 (mwir, 451.0 m)" for messages
    crops: np.ndarray
    target_px: float


@dataclass(frozen=True)
class PsfEstimate:
    """The fitted PSF (module docstring). ``blur_px`` is the Gaussian blur of the Airy (x)
    Gaussian fit, ``pvf`` its point-source average PVF; ``sigma_px`` the Gaussian fit's sigma;
    ``chi2_per_dof`` of each family at its best."""

    sigma_px: float
    sigma_px_std: float
    blur_px: float
    blur_px_std: float
    pvf: float
    pvf_std: float
    n_frames: int
    chi2_per_dof: dict[str, float]
    f_number: float
    pitch_um: float
    band_um: tuple[float, float]
    fill_factor: float

    def psf(self) -> AiryGaussianPsf:
        """The fitted physical PSF, for ``model.snr.predict(corrected_psf=...)``."""
        return psf_from_record(self.as_dict())

    def as_dict(self) -> dict:
        out = asdict(self)
        out["band_um"] = list(self.band_um)
        return out


def psf_from_record(d: dict) -> AiryGaussianPsf:
    """The physical PSF of an estimate as :meth:`PsfEstimate.as_dict` gives it (a session's
    ``model_psf`` event): the camera's Airy pattern blurred by the fitted Gaussian."""
    band = (float(d["band_um"][0]), float(d["band_um"][1]))
    return AiryGaussianPsf(
        _airy(float(d["f_number"]), float(d["pitch_um"]), band), float(d["blur_px"])
    )


@functools.lru_cache(maxsize=8)
def _airy(f_number: float, pitch_um: float, band_um: tuple[float, float]):
    from snrmon.model.sensor import signal_weighted_airy

    return signal_weighted_airy(f_number, pitch_um, band_um)


def crop_frames(frames, peaks_xy, calibration=None) -> np.ndarray:
    """13 x 13 crops (float64) centred on each frame's peak ``(x, y)``, non-uniformity
    corrected by ``calibration`` (``acquisition.calibrate.calibration.Calibration``) if given;
    frames whose crop would leave the image are skipped."""
    out = []
    h = CROP_HALF
    for frame, (x, y) in zip(frames, peaks_xy, strict=True):
        x, y = int(x), int(y)
        rows, cols = frame.shape
        if not (h <= x < cols - h and h <= y < rows - h):
            continue
        win = (y - h, y + h + 1, x - h, x + h + 1)
        if calibration is not None:
            crop = calibration.correct(frame, win)
        else:
            crop = frame[win[0] : win[1], win[2] : win[3]]
        out.append(np.asarray(crop, np.float64))
    return np.asarray(out).reshape(-1, 2 * h + 1, 2 * h + 1)


def _prepare(crops: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(data (N, 49) minus the background, noise (N,)) of 13 x 13 crops."""
    n = crops.shape[-1]
    k = np.arange(n) - n // 2
    ring = np.maximum(np.abs(k)[:, None], np.abs(k)[None, :]) >= CROP_HALF - 1
    bg = crops[:, ring]
    level = np.median(bg, axis=1)
    noise = 1.4826 * np.median(np.abs(bg - level[:, None]), axis=1)
    c = n // 2
    core = crops[:, c - FIT_HALF : c + FIT_HALF + 1, c - FIT_HALF : c + FIT_HALF + 1]
    data = core.reshape(len(crops), -1) - level[:, None]
    return data, np.maximum(noise, 1e-9)


def _frame_chi2(data: np.ndarray, noise: np.ndarray, patterns: np.ndarray) -> np.ndarray:
    """Per frame, the least chi^2 over the offsets with a free amplitude >= 0."""
    p = patterns.reshape(-1, data.shape[1])  # (offsets, 49)
    dots = matmul(data, p.T)  # (N, offsets)
    norms = np.sum(p * p, axis=1)
    gain = np.where(dots > 0, dots * dots / norms[None, :], 0.0)
    return (np.sum(data * data, axis=1) - gain.max(axis=1)) / noise**2


def observed_phases(stop: StopCrops, psf, fill_factor: float) -> np.ndarray:
    """(N, 2) offsets (x, y) in px of the drone's centroid from its peak pixel's centre in each
    of the stop's frames: the best-fitting offset on the fit's grid (1/12 px) with ``psf`` (the
    fitted one, :meth:`PsfEstimate.psf`). The phases the stop's frames actually sampled, for
    ``model.eq4.expected_eq4(phases_xy=...)``."""
    data, _ = _prepare(stop.crops)
    pats = pixel_patterns(
        psf, fill_factor, _OFFSETS, _OFFSETS, half_size_px=FIT_HALF, target_square_px=stop.target_px
    )
    p = pats.reshape(-1, data.shape[1])
    dots = matmul(data, p.T)
    gain = np.where(dots > 0, dots * dots / np.sum(p * p, axis=1)[None, :], 0.0)
    iy, ix = np.divmod(np.argmax(gain, axis=1), len(_OFFSETS))
    return np.stack([_OFFSETS[ix], _OFFSETS[iy]], axis=1)


def _psf_of(family: str, theta: float, airy):
    if family == "gaussian":
        return GaussianPsf(max(theta, 1e-3))
    return AiryGaussianPsf(airy, max(theta, 0.0))


def _chi2_table(stops, family, grid, airy, ff) -> np.ndarray:
    """(n_frames_total, n_theta) chi^2 of every frame at every grid value. A Gaussian blur of
    the PSF is a Gaussian factor of its OTF, the same as a Gaussian target of that sigma, so
    each family is one base PSF (the Airy, a narrow Gaussian) with a blur."""
    base = airy if family == "airy+gaussian" else GaussianPsf(_GAUSS_BASE_PX)
    cols = []
    prepared = [_prepare(s.crops) for s in stops]
    for theta in grid:
        blur = theta
        if family == "gaussian":
            blur = math.sqrt(max(theta**2 - _GAUSS_BASE_PX**2, 0.0))
        per_stop = []
        for s, (data, noise) in zip(stops, prepared, strict=True):
            pats = pixel_patterns(
                base,
                ff,
                _OFFSETS,
                _OFFSETS,
                half_size_px=FIT_HALF,
                target_square_px=s.target_px,
                target_sigma_px=blur,
            )
            per_stop.append(_frame_chi2(data, noise, pats))
        cols.append(np.concatenate(per_stop))
    return np.stack(cols, axis=1)


def _best(grid: np.ndarray, chi2: np.ndarray) -> float:
    """The grid minimum refined by a parabola through it and its neighbours."""
    i = int(np.argmin(chi2))
    if i == 0 or i == len(grid) - 1:
        return float(grid[i])
    y0, y1, y2 = chi2[i - 1], chi2[i], chi2[i + 1]
    den = y0 - 2 * y1 + y2
    shift = 0.5 * (y0 - y2) / den if den > 0 else 0.0
    return float(grid[i] + np.clip(shift, -1, 1) * (grid[1] - grid[0]))


def check_stop(label: str, n_frames: int, target_px: float, min_frames: int) -> None:
    """PsfEstimateError unless the stop can give a PSF (module docstring)."""
    if target_px >= 1.0:
        raise PsfEstimateError(
            f"{label}: the drone is resolved (small dimension {target_px:.2f} px >= 1 px); its "
            "pixels show the drone, not the PSF: use an unresolved stop"
        )
    if n_frames < min_frames:
        raise PsfEstimateError(
            f"{label}: only {n_frames} usable frames, a PSF fit needs at least {min_frames}"
        )


def estimate_psf(
    stops: Sequence[StopCrops], sensor, *, min_frames: int = 50, seed: int = 15
) -> PsfEstimate:
    """Fit both families to the stops' crops (module docstring); ``sensor`` is the camera's
    ``model.sensor.Sensor`` (its F-number, pitch, band and fill factor)."""
    if not stops:
        raise PsfEstimateError("no stop to estimate the PSF from")
    for s in stops:
        check_stop(s.label, len(s.crops), s.target_px, min_frames)
    airy = _airy(float(sensor.f_number), float(sensor.pitch_um), tuple(sensor.band_um))
    ff = float(sensor.fill_factor)
    rng = np.random.default_rng(seed)
    n = sum(len(s.crops) for s in stops)
    boot = rng.integers(0, n, size=(_BOOTSTRAP, n))
    result, chi2_dof = {}, {}
    dof = n * (2 * FIT_HALF + 1) ** 2 - 3 * n - 1  # amplitude and offset per frame, theta
    for family, grid in _GRIDS.items():
        table = _chi2_table(stops, family, grid, airy, ff)
        total = table.sum(axis=0)
        best = _best(grid, total)
        spread = [_best(grid, table[b].sum(axis=0)) for b in boot]
        result[family] = (best, float(np.std(spread, ddof=1)), spread)
        chi2_dof[family] = float(total.min() / max(dof, 1))
    blur, blur_std, blur_boot = result["airy+gaussian"]
    grid = _GRIDS["airy+gaussian"]
    pvf_grid = np.array([average_pvf(_psf_of("airy+gaussian", float(b), airy), ff) for b in grid])
    pvf_boot = np.interp(blur_boot, grid, pvf_grid)
    return PsfEstimate(
        sigma_px=result["gaussian"][0],
        sigma_px_std=result["gaussian"][1],
        blur_px=blur,
        blur_px_std=blur_std,
        pvf=float(np.interp(blur, grid, pvf_grid)),
        pvf_std=float(np.std(pvf_boot, ddof=1)),
        n_frames=n,
        chi2_per_dof=chi2_dof,
        f_number=float(sensor.f_number),
        pitch_um=float(sensor.pitch_um),
        band_um=(float(sensor.band_um[0]), float(sensor.band_um[1])),
        fill_factor=ff,
    )


def target_px(target, range_m: float, ifov_rad: float) -> float:
    """The drone's small dimension in pixels at ``range_m``."""
    if not (range_m and range_m > 0 and math.isfinite(range_m)):
        raise PsfEstimateError(f"no range for the stop ({range_m!r}): the drone's size is unknown")
    return float(target.small_m) / (float(range_m) * float(ifov_rad))
