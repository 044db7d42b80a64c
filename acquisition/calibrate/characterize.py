"""Target characterization from resolved frames at a close stop (paper section 3).

Per frame, in a square ROI around the tracked position:

1. background statistics from the ROI's border ring (``ring_px`` wide): median and robust std
   (1.4826 MAD), so the drone itself does not bias them;
2. threshold: Otsu (OpenCV, on the ROI scaled to 8 bits between the background median and the
   ROI maximum) or k-sigma (median + k robust std). The target is taken to be warmer than its
   background (a drone against the sky, in both bands);
3. morphological opening with an ``open_px`` square (OpenCV) removes what is thinner than it --
   the blades and arms' thin parts, as the paper's outline excluded the blades -- then the
   connected component under the tracked point (else the largest) is kept and its holes filled
   (the outline encloses the body);
4. small dimension = sqrt(segmented area), large = sqrt(area of its bounding box) (upright, or
   the minimum-area rotated box), both times the pixel footprint range x IFOV [m];
5. with a calibration: the target's temperature from its core, the pixels of the outline at
   least ``core_px`` from its edge (``cv2.distanceTransform``), or where no pixel is that far
   in (a drone whose parts are thinner than 2 ``core_px``), those farthest in: a pixel nearer
   the edge mixes sky into its reading through the pixel and the PSF. The temperature of their
   mean radiance is the drone's; sigma_target is the spread of the outline eroded by
   ``erode_px``; the background temperature is the radiance mean of the ROI's border ring,
   outside the dilated outline; RSS delta-T = sqrt((T_target - T_bg)^2 + sigma_target^2).
   The eroded outline's own mean temperature is kept (``outline_temp_k``): it is what the
   paper's outline average reads when the drone is many PSF widths across, and reads low when
   it is not (docs/calibration.md gives the twin's figures);
6. with the camera's PSF (measured from the flight's unresolved stops), the core's contrast
   over the sky is divided by the share of a uniform drone's light the core keeps through that
   PSF (:func:`core_psf_share`): a drone whose parts are only a few PSF widths across (UAV1's
   6-cm bars are 3.2 MWIR pixels at 37 m) still mixes sky into its core, 6-7 % of its contrast
   on the twin. The uncorrected core temperature is kept (``core_seen_temp_k``).

7. with the air between the camera and the drone (:class:`AirPath`: the contrast-weighted
   transmission at the stop's range and the air's temperature, paper sections 8-9), the
   drone's pixels are taken back through it before any of its temperatures is read,
   L = (L_app - (1 - tau) L_air) / tau, and the sky is read as seen: the convention of the
   model's inputs (``model.contrast``: the target's own temperature against the measured,
   apparent sky, which holds the whole path and has none to take out), so the drone's
   temperature, its spread and the RSS delta-T are all of it (``temperature_convention``
   "path_corrected"). Without it all are apparent. The core's apparent temperature is kept
   (``apparent_temp_k``).

Frames are summarised by the mean and sample std of each quantity (:func:`summarise_frames`).
At a close stop only the frames where the drone is at rest count (:func:`at_rest_frames`): its
range steady (within the stop detector's tolerance of the stop's range) and its segmented size
steady (the run of frames whose size varies least), wherever they lie in the stop: a stop's
first or last frames may show a drone still arriving or already leaving, smaller or larger.
:func:`target_toml` writes the result as a target file ``model.presets.load_target`` reads.

What it cannot measure it refuses (:func:`unmeasurable`): fewer than :data:`MIN_FRAMES_AT_REST`
frames at rest (the sample std of a quantity over n frames is itself uncertain by
1 / sqrt(2 (n - 1)): 14 % at 25), or a dimension under ``2 open_px + 1`` pixels (7 px with the
3-px opening): the opening removes a drone's parts thinner than 3 px, and what it leaves of a
drone near that size is no longer its outline. On a synthetic 30-cm cross with 10-cm arms
(docs/calibration.md) the dimensions are within 7 % down to a measured large dimension of
8 px (MWIR 70 m) and off by 14-16 % at 6.3-6.8 px (MWIR 80 m, LWIR 37 m), by 35-50 % below.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import asdict, dataclass, field, fields, is_dataclass
from typing import TypedDict

import cv2
import numpy as np
import tomli_w

from snrmon.acquisition.calibrate.calibration import Calibration, temperature_of
from snrmon.limits import MIN_FRAMES_AT_REST
from snrmon.model.constants import ZERO_C_K
from snrmon.model.target import Outline

METHODS = ("otsu", "ksigma")
BOXES = ("upright", "rotated")
CONVENTIONS = ("path_corrected", "apparent")


@dataclass(frozen=True)
class AirPath:
    """The air between the camera and the drone (paper sections 8-9): a calibrated camera
    sees L_app = tau L + (1 - tau) L_air, band radiances through the calibration's response,
    with ``transmission`` the contrast-weighted band transmission at the stop's range
    (``model.atmosphere.Atmosphere.contrast_transmission``) and L_air the air's radiance."""

    transmission: float
    air_temp_k: float

    def __post_init__(self) -> None:
        if not (0.0 < self.transmission <= 1.0 and self.air_temp_k > 0):
            raise ValueError(
                f"air path needs 0 < tau <= 1 and T_air > 0 K, got {self.transmission}, "
                f"{self.air_temp_k} K"
            )

    def _air(self, band_um, qe_curve: tuple) -> float:
        from snrmon.acquisition.calibrate.calibration import radiance_of

        return float(radiance_of(band_um, self.air_temp_k, qe_curve))

    def own_radiance(self, apparent, band_um, qe_curve: tuple = ()) -> np.ndarray:
        """L = (L_app - (1 - tau) L_air) / tau: the radiance before the air."""
        tau = self.transmission
        return (np.asarray(apparent, float) - (1.0 - tau) * self._air(band_um, qe_curve)) / tau

    def apparent_radiance(self, own, band_um, qe_curve: tuple = ()) -> np.ndarray:
        """L_app = tau L + (1 - tau) L_air: the radiance through the air."""
        tau = self.transmission
        return tau * np.asarray(own, float) + (1.0 - tau) * self._air(band_um, qe_curve)


@dataclass(frozen=True)
class CharacterizeConfig:
    roi_half_px: int = 32
    method: str = "otsu"
    k_sigma: float = 5.0
    open_px: int = 3
    ring_px: int = 3
    erode_px: int = 1
    # 3 px from the outline's edge: beyond a Gaussian PSF of sigma <= 0.85 px (the paper's MWIR
    # fit is 0.8 px) at 3 sigma, plus the half pixel by which a thresholded outline's edge is
    # quantised.
    core_px: float = 3.0
    box: str = "upright"

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"segmentation method must be one of {METHODS}, got {self.method!r}")
        if self.box not in BOXES:
            raise ValueError(f"bounding box must be one of {BOXES}, got {self.box!r}")
        if self.roi_half_px < self.ring_px + 3:
            raise ValueError(f"ROI half size {self.roi_half_px} px is too small")
        if self.open_px < 1 or self.erode_px < 0 or self.k_sigma <= 0 or not self.core_px > 0:
            raise ValueError(
                f"need open_px >= 1, erode_px >= 0, k_sigma > 0, core_px > 0; got "
                f"{self.open_px}, {self.erode_px}, {self.k_sigma}, {self.core_px}"
            )


@dataclass(frozen=True)
class FrameTarget:
    """One frame's segmentation; temperatures None without a calibration."""

    area_px: int
    box_area_px: float
    small_m: float
    large_m: float
    threshold: float
    temp_k: float | None = None
    sigma_target_k: float | None = None
    background_k: float | None = None
    rss_delta_t_k: float | None = None
    outline_temp_k: float | None = None
    core_px: int | None = None  # pixels the temperature was read on
    core_seen_temp_k: float | None = None  # the core before the PSF correction
    core_psf_share: float | None = None  # share of a uniform drone's contrast the core keeps
    apparent_temp_k: float | None = None  # the (PSF-corrected) core through the air
    # the segmented pixels, cropped to their box (1 inside): the outline a target file keeps
    mask: np.ndarray | None = field(default=None, compare=False, repr=False)


class FrameTemperatures(TypedDict, total=False):
    """A calibrated frame's temperature fields of its :class:`FrameTarget` (K)."""

    temp_k: float
    sigma_target_k: float
    background_k: float
    rss_delta_t_k: float
    outline_temp_k: float
    core_px: int
    core_seen_temp_k: float
    core_psf_share: float | None
    apparent_temp_k: float


@dataclass(frozen=True)
class TargetSize:
    """The target's two dimensions (paper section 3), mean and sample std over frames [m]."""

    small_m: float
    small_m_std: float
    large_m: float
    large_m_std: float


@dataclass(frozen=True)
class TargetTemperature:
    """What a target file takes of the temperatures, mean and sample std over frames: the
    drone's and the sky's (C) and the RSS delta-T (K); None without a calibration."""

    mean_temp_c: float | None
    mean_temp_c_std: float | None
    background_temp_c: float | None
    background_temp_c_std: float | None
    rss_delta_t_k: float | None
    rss_delta_t_k_std: float | None


@dataclass(frozen=True)
class CoreReading:
    """How the drone's temperature was read, means over frames (module docstring, steps 5-7):
    the eroded outline's own temperature, the core's pixel count, the core before the PSF
    correction and the share of the contrast it keeps, the core seen through the air."""

    outline_temp_c: float | None = None
    core_pixels: float | None = None  # mean count of core pixels a frame's temperature read
    core_seen_temp_c: float | None = None  # the core's temperature before the PSF correction
    core_psf_share: float | None = None  # mean share of the contrast the core keeps (PSF)
    apparent_temp_c: float | None = None  # the drone's temperature as seen through the air


@dataclass(frozen=True)
class Characterization:
    """A stop's characterization: mean and sample std over frames; temperatures in C as the
    target file. :meth:`as_dict` is flat, each part's fields under their own names."""

    camera: str
    range_m: float
    n_frames: int
    size: TargetSize
    temperature: TargetTemperature
    method: str
    core: CoreReading = field(default_factory=CoreReading)
    temperature_convention: str = "apparent"  # of every temperature but apparent_temp_c

    def as_dict(self) -> dict:
        """``{name: value}``, the parts' fields in place of the parts (``characterize --json``)."""
        out: dict = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if is_dataclass(value) and not isinstance(value, type):
                out.update(asdict(value))
            else:
                out[f.name] = value
        return out


def _window(shape, x: int, y: int, half: int) -> tuple[int, int, int, int]:
    h, w = shape
    r0, r1, c0, c1 = y - half, y + half + 1, x - half, x + half + 1
    if r0 < 0 or c0 < 0 or r1 > h or c1 > w:
        raise ValueError(f"ROI of +-{half} px around ({x}, {y}) leaves the {w}x{h} image")
    return r0, r1, c0, c1


def _ring(shape, width: int) -> np.ndarray:
    m = np.ones(shape, bool)
    m[width:-width, width:-width] = False
    return m


def segment_target(roi: np.ndarray, cfg: CharacterizeConfig, at_rc=None):
    """(mask uint8 0/1, threshold) of the warm target in ``roi`` (values rising with scene
    temperature); mask all zero when nothing survives."""
    v = np.asarray(roi, np.float32)
    bg = v[_ring(v.shape, cfg.ring_px)]
    med = float(np.median(bg))
    sigma = 1.4826 * float(np.median(np.abs(bg - med)))
    if cfg.method == "ksigma":
        thr = med + cfg.k_sigma * sigma
    else:
        top = float(v.max())
        if top <= med:
            return np.zeros(v.shape, np.uint8), math.inf
        u8 = np.clip((v - med) / (top - med) * 255.0, 0, 255).astype(np.uint8)
        t8, _ = cv2.threshold(u8, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
        # the floor of k-sigma still applies: noise alone must not be called target
        thr = max(med + (t8 + 0.5) / 255.0 * (top - med), med + 3.0 * sigma)
    kernel = np.ones((cfg.open_px, cfg.open_px), np.uint8)
    mask = cv2.morphologyEx((v > thr).astype(np.uint8), cv2.MORPH_OPEN, kernel)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    if n <= 1:
        return np.zeros(v.shape, np.uint8), thr
    r, c = at_rc if at_rc is not None else (v.shape[0] // 2, v.shape[1] // 2)
    keep = labels[r, c] or 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    one = (labels == keep).astype(np.uint8)
    contours, _ = cv2.findContours(one, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    filled = np.zeros_like(one)
    cv2.drawContours(filled, contours, -1, 1, thickness=cv2.FILLED)
    return filled, thr


def _box_area(mask: np.ndarray, kind: str) -> float:
    ys, xs = np.nonzero(mask)
    if kind == "upright":
        return float((ys.max() - ys.min() + 1) * (xs.max() - xs.min() + 1))
    pts = np.column_stack([xs, ys]).astype(np.float32)
    (_, (w, h), _) = cv2.minAreaRect(pts)
    return float((w + 1) * (h + 1))  # pixel centres -> pixel extents


def core_psf_share(mask: np.ndarray, core: np.ndarray, psf, fill_factor: float) -> float:
    """The share of a uniform drone's contrast that its ``core`` pixels keep when its outline
    is ``mask`` and the camera's PSF ``psf`` (a ``model.psf`` PSF): the outline's pixels, each
    a uniform full-cell source, through the PSF onto the core's active areas, relative to a
    scene that fills the view (1 far inside a large drone; lower where its parts are a few PSF
    widths across). The outline is the segmented one, whole pixels."""
    from scipy.signal import fftconvolve

    from snrmon.model.footprint import pixel_patterns

    h = _SHARE_HALF_PX
    one = pixel_patterns(psf, fill_factor, [0.0], [0.0], half_size_px=h, target_square_px=1.0)
    kernel = one[0, 0] / fill_factor
    seen = fftconvolve(mask.astype(float), kernel, mode="same")
    return float(np.mean(seen[core]))


_SHARE_HALF_PX = 12  # the PSF's light beyond 12 px (<2 % in the MWIR) is taken as lost


def characterize_frame(
    frame: np.ndarray,
    at_xy: tuple[int, int],
    *,
    range_m: float,
    ifov_rad: float,
    calibration: Calibration | None = None,
    config: CharacterizeConfig | None = None,
    psf=None,
    fill_factor: float | None = None,
    path: AirPath | None = None,
) -> FrameTarget | None:
    """One frame (raw DN); None when nothing is segmented. With a calibration the frame is
    non-uniformity corrected before segmentation and temperatures are measured; with the
    camera's ``psf`` (and its ``fill_factor``) the core's contrast is corrected for the PSF's
    mixing (:func:`core_psf_share`); with the air ``path`` every temperature is read on the
    radiance before the air (module docstring, step 7)."""
    cfg = config or CharacterizeConfig()
    if not (range_m > 0 and ifov_rad > 0):
        raise ValueError(f"range and IFOV must be > 0, got {range_m} m, {ifov_rad} rad")
    x, y = int(at_xy[0]), int(at_xy[1])
    win = _window(frame.shape, x, y, cfg.roi_half_px)
    if calibration is not None:
        values = calibration.radiance(frame, win)
    else:
        values = np.asarray(frame[win[0] : win[1], win[2] : win[3]], np.float32)
    mask, thr = segment_target(values, cfg, (y - win[0], x - win[2]))
    area = int(mask.sum())
    if area == 0:
        return None
    px_m = range_m * ifov_rad
    box = _box_area(mask, cfg.box)
    temperatures: FrameTemperatures = (
        {}
        if calibration is None
        else _frame_temperatures(values, mask, calibration, cfg, psf, fill_factor, path)
    )
    return FrameTarget(
        area,
        box,
        math.sqrt(area) * px_m,
        math.sqrt(box) * px_m,
        float(thr),
        mask=_cropped(mask),
        **temperatures,
    )


def _frame_temperatures(
    sky_lq: np.ndarray,
    mask: np.ndarray,
    calibration: Calibration,
    cfg: CharacterizeConfig,
    psf,
    fill_factor: float | None,
    path: AirPath | None,
) -> FrameTemperatures:
    """The temperature fields of a :class:`FrameTarget` (module docstring, steps 5-7) from the
    ROI's radiance ``sky_lq`` (as seen: the model's sky temperature) and the outline ``mask``."""
    band, qe = calibration.band_um, calibration.qe_curve
    # the drone's pixels before the air
    lq = sky_lq if path is None else path.own_radiance(sky_lq, band, qe)
    inner = mask
    if cfg.erode_px:
        k = np.ones((2 * cfg.erode_px + 1,) * 2, np.uint8)
        eroded = cv2.erode(mask, k)
        inner = eroded if eroded.sum() >= 2 else mask
    temps = temperature_of(band, lq[inner > 0], qe)
    sig = float(np.std(temps, ddof=1)) if temps.size > 1 else 0.0
    # distance of each outline pixel's centre to the nearest sky pixel's centre
    depth = cv2.distanceTransform(mask, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    core = depth >= min(cfg.core_px, float(depth.max()))
    # the border ring, as for the threshold: blades and other parts removed from the
    # outline must not count as sky
    outside = _ring(mask.shape, cfg.ring_px) & (cv2.dilate(mask, np.ones((7, 7), np.uint8)) == 0)
    l_sky = float(np.mean(sky_lq[outside]))
    l_bg = l_sky if path is None else float(path.own_radiance(l_sky, band, qe))
    l_core = float(np.mean(lq[core]))
    l_drone, share = l_core, None
    if psf is not None:
        if fill_factor is None:
            raise ValueError("a PSF correction needs the camera's fill factor")
        share = core_psf_share(mask, core, psf, fill_factor)
        l_drone = l_bg + (l_core - l_bg) / share
    temp = float(temperature_of(band, l_drone, qe))
    l_app = l_drone if path is None else float(path.apparent_radiance(l_drone, band, qe))
    bgk = float(temperature_of(band, l_sky, qe))
    return FrameTemperatures(
        temp_k=temp,
        sigma_target_k=sig,
        background_k=bgk,
        rss_delta_t_k=math.hypot(temp - bgk, sig),
        outline_temp_k=float(np.mean(temps)),
        core_px=int(core.sum()),
        core_seen_temp_k=float(temperature_of(band, l_core, qe)),
        core_psf_share=share,
        apparent_temp_k=float(temperature_of(band, l_app, qe)),
    )


def _cropped(mask: np.ndarray) -> np.ndarray:
    ys, xs = np.nonzero(mask)
    return mask[ys.min() : ys.max() + 1, xs.min() : xs.max() + 1].copy()


def median_outline(rows: Sequence[FrameTarget], pixel_m: float) -> Outline:
    """The outline of the frame whose segmented area is the median of ``rows`` (the first of
    two at the median): one frame's pixels at the stop's ``pixel_m`` (range x IFOV), the
    segmentation the small dimension is the square root of the area of (paper section 3)."""
    kept = [r for r in rows if r.mask is not None]
    if not kept:
        raise ValueError("no segmented frame to take an outline from")
    order = sorted(range(len(kept)), key=lambda k: kept[k].area_px)
    mask = kept[order[(len(order) - 1) // 2]].mask
    assert mask is not None  # kept
    return Outline(tuple("".join("1" if v else "0" for v in row) for row in mask), pixel_m)


def at_rest_frames(
    sizes_px: Sequence[float | None],
    ranges_m: Sequence[float | None],
    n: int,
    *,
    stop_range_m: float,
    range_tolerance_m: float = 1.0,
) -> list[int]:
    """Indices of the ``n`` frames of a stop (in order) where the drone is at rest: a run of
    consecutive frames, each segmented (``sizes_px``: the square root of its segmented area,
    None where nothing was) and at a range within ``range_tolerance_m`` of ``stop_range_m``
    (None: no reading, not held against it), whose sizes have the smallest relative spread
    (std / mean) of all such runs, the earliest of equal spread. A drone arriving or leaving
    changes size frame by frame; one at rest only by the segmentation's noise. Fewer than ``n``
    such frames: the longest run of them."""
    if n < 1:
        raise ValueError(f"need n >= 1 frames, got {n}")
    if len(sizes_px) != len(ranges_m):
        raise ValueError("one size and one range per frame")
    runs: list[list[int]] = [[]]
    for i, (size, rng) in enumerate(zip(sizes_px, ranges_m, strict=True)):
        steady = rng is None or abs(rng - stop_range_m) <= range_tolerance_m
        if size is not None and size > 0 and steady:
            runs[-1].append(i)
        elif runs[-1]:
            runs.append([])
    best: tuple[float, list[int]] | None = None
    for run in runs:
        if len(run) < n:
            continue
        s = np.asarray([sizes_px[i] for i in run], dtype=float)
        windows = np.lib.stride_tricks.sliding_window_view(s, n)
        spread = windows.std(axis=1) / windows.mean(axis=1)
        k = int(np.argmin(spread))
        if best is None or spread[k] < best[0]:
            best = (float(spread[k]), run[k : k + n])
    if best is not None:
        return best[1]
    return max(runs, key=len)


def summarise_frames(
    rows: Sequence[FrameTarget],
    *,
    camera: str,
    range_m: float,
    method: str,
    convention: str = "apparent",
) -> Characterization:
    """The mean and sample std over frames of each quantity (temperatures in C);
    ``convention``: "path_corrected" when the rows were read through an :class:`AirPath`."""
    if convention not in CONVENTIONS:
        raise ValueError(f"temperature convention must be one of {CONVENTIONS}, got {convention!r}")
    if not rows:
        raise ValueError(f"no target segmented in any frame of {camera!r} at {range_m:.1f} m")

    def celsius(kelvin: list[float | None]) -> list[float | None]:
        return [None if k is None else k - ZERO_C_K for k in kelvin]

    small = _mean_std([r.small_m for r in rows])
    large = _mean_std([r.large_m for r in rows])
    temp = _mean_std(celsius([r.temp_k for r in rows]))
    bg = _mean_std(celsius([r.background_k for r in rows]))
    rss = _mean_std([r.rss_delta_t_k for r in rows])
    outline, _ = _mean_std(celsius([r.outline_temp_k for r in rows]))
    n_core, _ = _mean_std([None if r.core_px is None else float(r.core_px) for r in rows])
    seen, _ = _mean_std(celsius([r.core_seen_temp_k for r in rows]))
    share, _ = _mean_std([r.core_psf_share for r in rows])
    apparent, _ = _mean_std(celsius([r.apparent_temp_k for r in rows]))
    (small_m, small_std), (large_m, large_std) = small, large
    assert small_m is not None and large_m is not None  # every row has its dimensions
    return Characterization(
        camera,
        float(range_m),
        len(rows),
        TargetSize(small_m, small_std or 0.0, large_m, large_std or 0.0),
        TargetTemperature(*temp, *bg, *rss),
        method,
        CoreReading(outline, n_core, seen, share, apparent),
        convention,
    )


def unmeasurable(
    result: Characterization,
    *,
    pixel_m: float,
    min_frames: int = MIN_FRAMES_AT_REST,
    min_size_px: float | None = None,
    config: CharacterizeConfig | None = None,
) -> str | None:
    """Why ``result`` cannot be trusted, naming the numbers (None: it can): fewer than
    ``min_frames`` frames, or a dimension under ``min_size_px`` pixels of ``pixel_m`` (default
    2 open_px + 1 of ``config``: module docstring)."""
    cfg = config or CharacterizeConfig()
    need_px = 2 * cfg.open_px + 1 if min_size_px is None else float(min_size_px)
    small_px, large_px = result.size.small_m / pixel_m, result.size.large_m / pixel_m
    why = []
    if result.n_frames < min_frames:
        why.append(f"{result.n_frames} frames at rest (need >= {min_frames})")
    if min(small_px, large_px) < need_px:
        why.append(
            f"small {small_px:.1f} px and large {large_px:.1f} px (need >= {need_px:g} px each: "
            f"the {cfg.open_px}-px opening removes parts thinner than {cfg.open_px} px)"
        )
    if not why:
        return None
    return f"{result.camera} at {result.range_m:.1f} m cannot be characterised: " + "; ".join(why)


def _mean_std(values: list[float | None]) -> tuple[float | None, float | None]:
    v = [x for x in values if x is not None]
    if not v:
        return None, None
    return float(np.mean(v)), float(np.std(v, ddof=1)) if len(v) > 1 else 0.0


def characterize_frames(
    frames: Iterable[tuple[np.ndarray, tuple[int, int]]],
    *,
    camera: str,
    range_m: float,
    ifov_rad: float,
    calibration: Calibration | None = None,
    config: CharacterizeConfig | None = None,
) -> Characterization:
    """Average :func:`characterize_frame` over ``(frame, (x, y))`` pairs (paper section 3:
    "averaged over many frames"); ValueError if no frame gives a segmentation."""
    cfg = config or CharacterizeConfig()
    if calibration is not None and calibration.camera != camera:
        raise ValueError(f"calibration is for camera {calibration.camera!r}, not {camera!r}")
    rows = [
        r
        for f, at in frames
        if (
            r := characterize_frame(
                f, at, range_m=range_m, ifov_rad=ifov_rad, calibration=calibration, config=cfg
            )
        )
        is not None
    ]
    return summarise_frames(rows, camera=camera, range_m=range_m, method=cfg.method)


def target_toml(
    result: Characterization,
    name: str,
    description: str = "",
    band: str | None = None,
    outline: Outline | None = None,
) -> str:
    """A ``[target]`` TOML for ``model.presets.load_target`` with this band's temperature and
    RSS delta-T (``band`` defaults to the camera name: "mwir"/"lwir") and, if given, the
    segmented ``outline`` (the model's "outline" footprint, :func:`median_outline`)."""
    size, temperature = result.size, result.temperature
    if temperature.mean_temp_c is None:
        raise ValueError("a target file needs a temperature: characterize with a calibration")
    key = band or result.camera
    desc = description or (
        f"characterized from {result.n_frames} frames of {result.camera} at "
        f"{result.range_m:.1f} m ({result.method})"
    )
    values = {
        "small_m": size.small_m,
        "large_m": max(size.large_m, size.small_m),
        "temp_c": temperature.mean_temp_c,
        "rss_delta_t_k": temperature.rss_delta_t_k,
    }
    finite = {k: float(v) for k, v in values.items() if v is not None and math.isfinite(v)}
    if len(finite) < len(values):  # TOML has no null; a NaN would only fail later, in the model
        missing = ", ".join(k for k in values if k not in finite)
        raise ValueError(f"a target file needs finite values; not measured: {missing}")
    table = {
        "name": name,
        "description": desc,
        "small_m": round(finite["small_m"], 4),
        "large_m": round(finite["large_m"], 4),
        "temp_c": {key: round(finite["temp_c"], 3)},
        "rss_delta_t_k": {key: round(finite["rss_delta_t_k"], 3)},
    }
    if outline is not None:
        table["outline"] = list(outline.rows)
        table["outline_pixel_m"] = round(float(outline.pixel_m), 6)
    return tomli_w.dumps({"target": table})
