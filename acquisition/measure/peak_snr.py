"""Per-frame peak-pixel SNR of paper Eq. (4), its flags, and the stateful meter.

Eq. (4): ``SNR_peak = (PeakTgtPixVal - mean(BG)) / std(BG)``. The peak is the brightest pixel in a
square search window (default 11x11) centred on the operator's point; the background BG is the 24
rim pixels of the 7x7 box centred on that peak (paper Fig. 4) or an operator-chosen clear-sky
rectangle, optionally detrended by a least-squares plane (section 5-6). The std is the SAMPLE
standard deviation (``ddof=1``, N-1 in the denominator), like MATLAB's ``std``; ``ddof=0`` gives
numpy's default.

Conventions: x = column, y = row, zero-based, integers at pixel centres (a float point is rounded
to the nearest pixel centre, halves up). Ties for the brightest pixel: the first in row-major
order. NaN pixels in a float frame are never the peak. Only the search window and the box (or the
rectangle) are read, so the cost does not depend on the frame size.

Flags (a frozenset of these names; as bits, bit i is ``FLAG_NAMES[i]``):
    saturated         peak >= the saturation level (default: the integer dtype's maximum)
    edge              the search window was clipped by the image border, or the box around the
                      peak leaves the image
    undefined         SNR not defined: rim leaves the image, std zero or not finite, NaN pixels
    rim_contaminated  background std > 2x the recent noise, or its plane gradient times the
                      background's extent (box_px-1 for the rim) > 3x the recent noise (cloud edge)
    lost, gps_cued    set by the tracker (not by this module)
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from snrmon.acquisition.columns import column
from snrmon.acquisition.measure.background import Rect, background_stats, rect_offsets, rim_offsets
from snrmon.acquisition.measure.contamination import NoiseReference, is_contaminated
from snrmon.acquisition.measure.rim_kernel import brightest, rim_background
from snrmon.acquisition.measure.running_stats import RunningSnr

FLAG_SATURATED = "saturated"
FLAG_EDGE = "edge"
FLAG_UNDEFINED = "undefined"
FLAG_RIM_CONTAMINATED = "rim_contaminated"
FLAG_LOST = "lost"
FLAG_GPS_CUED = "gps_cued"
FLAG_NAMES: tuple[str, ...] = (
    FLAG_SATURATED,
    FLAG_EDGE,
    FLAG_UNDEFINED,
    FLAG_RIM_CONTAMINATED,
    FLAG_LOST,
    FLAG_GPS_CUED,
)
_BIT = {name: 1 << i for i, name in enumerate(FLAG_NAMES)}
BACKGROUND_RIM = "rim"
BACKGROUND_EXTENT = "extent_rim"
BACKGROUND_RECT = "rect"
#: The background methods a :class:`PeakSnr` can name (docs/measurement.md).
BACKGROUNDS: tuple[str, ...] = (BACKGROUND_RIM, BACKGROUND_EXTENT, BACKGROUND_RECT)
#: Frames carrying any of these never enter the running statistics or the noise reference.
RUNNING_EXCLUDED: frozenset[str] = frozenset(
    {FLAG_SATURATED, FLAG_EDGE, FLAG_UNDEFINED, FLAG_RIM_CONTAMINATED, FLAG_LOST}
)


def flags_to_bits(flags: Iterable[str]) -> int:
    """Flag names -> bit mask (bit i = ``FLAG_NAMES[i]``); an unknown name is a ValueError."""
    bits = 0
    for name in flags:
        if name not in _BIT:
            raise ValueError(f"unknown flag {name!r}; known: {', '.join(FLAG_NAMES)}")
        bits |= _BIT[name]
    return bits


@functools.lru_cache(maxsize=256)
def flags_from_bits(bits: int) -> frozenset[str]:
    """Bit mask -> frozenset of flag names."""
    return frozenset(name for name, b in _BIT.items() if bits & b)


@dataclass(frozen=True, slots=True)
class PeakSnr:
    """One frame's Eq. (4) measurement. Pixel values in the frame's DN.

    Attributes:
        peak_x, peak_y: column and row (zero-based) of the brightest pixel.
        peak: its value (DN).
        bg_mean: mean of the background pixels (DN).
        bg_std: their std (DN; ddof as configured, detrended if asked).
        snr: (peak - bg_mean) / bg_std; NaN when not defined (flag ``undefined``).
        flags: names from :data:`FLAG_NAMES`.
        background: which background the mean and std are of (:data:`BACKGROUNDS`): ``rim``
            (the 24 rim pixels of Eq. 4's 7x7 box), ``extent_rim`` (the rim of the segmented
            target's box grown by a guard band; :mod:`snrmon.acquisition.measure.target_snr`) or
            ``rect`` (the operator's clear-sky rectangle).
        extent_w_px, extent_h_px: the segmented target's extent (box width and height, px)
            when the tracker segmented it; 0 when not segmented. Metadata of the segmentation:
            not compared by ``==``, which compares the Eq. 4 measurement.
    """

    # Each field's column in every table (session file, API, campaign, CSV, stop table).
    peak_x: int = column("px, column, zero-based", units="px", cf_units="1", dtype="<i4")
    peak_y: int = column("px, row, zero-based", units="px", cf_units="1", dtype="<i4")
    peak: float = column("DN", units="DN", cf_units="1", dtype="<f8")
    bg_mean: float = column("DN", units="DN", cf_units="1", dtype="<f8")
    bg_std: float = column("DN", units="DN", cf_units="1", dtype="<f8")
    snr: float = column("1 (paper Eq. 4; NaN when undefined)", units="1", cf_units="1", dtype="<f8")
    flags: frozenset[str] = column(
        "bit i = flag_names[i]",
        dtype="<u2",
        encode=flags_to_bits,
        decode=lambda bits: flags_from_bits(int(bits)),
    )
    background: str = column(
        "rim | extent_rim | rect: the background bg_mean/bg_std are of",
        default="rim",
        dtype="S32",
    )
    extent_w_px: int = column(
        "px, segmented target's box width (0: not segmented)",
        default=0,
        compare=False,
        units="px",
        cf_units="1",
        dtype="<i2",
    )
    extent_h_px: int = column(
        "px, segmented target's box height (0: not segmented)",
        default=0,
        compare=False,
        units="px",
        cf_units="1",
        dtype="<i2",
    )


def result_with(
    m: PeakSnr,
    *,
    flags: frozenset[str] | None = None,
    extent_px: tuple[int, int] | None = None,
) -> PeakSnr:
    """``m`` with other ``flags`` and/or the segmented target's extent (w, h) in px
    (``dataclasses.replace`` without its per-call field lookup: this is on every tracked
    frame)."""
    w, h = (m.extent_w_px, m.extent_h_px) if extent_px is None else extent_px
    return PeakSnr(
        m.peak_x,
        m.peak_y,
        m.peak,
        m.bg_mean,
        m.bg_std,
        m.snr,
        m.flags if flags is None else flags,
        m.background,
        w,
        h,
    )


@dataclass(frozen=True)
class PeakSnrConfig:
    """Settings of the measurement (see the module docstring for their meaning)."""

    search_px: int = 11
    box_px: int = 7
    background: Rect | None = None  # None = the box rim; else (x0, y0, x1, y1), both inclusive
    detrend: bool = False
    saturation_dn: float | None = None
    ddof: int = 1
    contamination_std_factor: float = 2.0
    contamination_gradient_factor: float = 3.0
    reference_frames: int = 25
    reference_min_frames: int = 5

    def __post_init__(self) -> None:
        if int(self.search_px) != self.search_px or self.search_px < 1 or self.search_px % 2 == 0:
            raise ValueError(f"search window must be an odd integer >= 1, got {self.search_px}")
        rim_offsets(self.box_px)  # validates box_px
        if self.ddof not in (0, 1):
            raise ValueError(f"ddof must be 0 or 1, got {self.ddof}")
        if self.background is not None:
            x0, y0, x1, y1 = self.background
            n = (x1 - x0 + 1) * (y1 - y0 + 1)
            if x1 < x0 or y1 < y0 or n <= self.ddof + (2 if self.detrend else 0):
                raise ValueError(f"background rectangle {self.background} is too small")
        if self.saturation_dn is not None and not math.isfinite(self.saturation_dn):
            raise ValueError(f"saturation level must be finite, got {self.saturation_dn}")

    @functools.cached_property
    def offsets(self) -> tuple[np.ndarray, np.ndarray]:
        """(dy, dx) of the background pixels: rim offsets from the peak, or rectangle offsets."""
        if self.background is None:
            return rim_offsets(self.box_px)
        return rect_offsets(self.background)

    @property
    def extent_px(self) -> int:
        """Distance across the background, scaling the gradient test of ``rim_contaminated``."""
        if self.background is None:
            return self.box_px - 1
        x0, y0, x1, y1 = self.background
        return max(x1 - x0, y1 - y0, 1)


def pixel_of(at_xy: tuple[float, float]) -> tuple[int, int]:
    """Nearest pixel centre (x, y) of a point; a non-finite coordinate is a ValueError."""
    x, y = at_xy
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(f"point {at_xy} is not finite")
    return math.floor(x + 0.5), math.floor(y + 0.5)


@dataclass
class _Core:
    """Struct of arrays for N frames, before the sequential (contamination) pass."""

    peak_x: np.ndarray
    peak_y: np.ndarray
    peak: np.ndarray
    bg_mean: np.ndarray
    bg_std: np.ndarray
    gradient: np.ndarray
    snr: np.ndarray
    bits: np.ndarray


def search_window(
    x: int, y: int, rows: int, cols: int, cfg: PeakSnrConfig
) -> tuple[int, int, int, int, bool]:
    """The peak search window around pixel (x, y) of a ``rows`` x ``cols`` image, inclusive
    bounds (x0, x1, y0, y1), and whether the image's edge clipped it; a point off the image is a
    ValueError naming it."""
    if not (0 <= x < cols and 0 <= y < rows):
        raise ValueError(
            f"point x={x}, y={y} is off the {cols}x{rows} image "
            f"(x must be 0..{cols - 1}, y 0..{rows - 1})"
        )
    hs = cfg.search_px // 2
    x0, x1 = max(x - hs, 0), min(x + hs, cols - 1)
    y0, y1 = max(y - hs, 0), min(y + hs, rows - 1)
    return x0, x1, y0, y1, (x1 - x0 + 1) * (y1 - y0 + 1) < cfg.search_px * cfg.search_px


def measure_core(stack: np.ndarray, x: int, y: int, cfg: PeakSnrConfig) -> _Core:
    """Eq. (4) on every frame of ``stack`` (N, H, W) at pixel (x, y), without the contamination
    flag (which depends on the previous frames). Shared by the per-frame and stack paths so both
    run identical reductions."""
    n, rows, cols = stack.shape
    sx0, sx1, sy0, sy1, clipped = search_window(x, y, rows, cols, cfg)
    win = stack[:, sy0 : sy1 + 1, sx0 : sx1 + 1].reshape(n, -1)
    is_float = stack.dtype.kind == "f"
    if is_float:
        win = np.where(np.isnan(win), -np.inf, win)
    idx = win.argmax(axis=1)
    frames = np.arange(n)
    peak = win[frames, idx].astype(np.float64)
    width = sx1 - sx0 + 1
    peak_y = sy0 + idx // width
    peak_x = sx0 + idx % width

    hb = cfg.box_px // 2
    box_out = (peak_x < hb) | (peak_x > cols - 1 - hb) | (peak_y < hb) | (peak_y > rows - 1 - hb)
    dy, dx = cfg.offsets
    if cfg.background is None:
        r = peak_y[:, None] + dy
        c = peak_x[:, None] + dx
        if box_out.any():  # keep the gather in the image; those frames are undefined anyway
            r = np.clip(r, 0, rows - 1)
            c = np.clip(c, 0, cols - 1)
        values = stack[frames[:, None], r, c].astype(np.float64)
    else:
        x0, y0, x1, y1 = cfg.background
        if x0 < 0 or y0 < 0 or x1 >= cols or y1 >= rows:
            raise ValueError(
                f"background rectangle {cfg.background} leaves the {cols}x{rows} image"
            )
        values = stack[:, y0 : y1 + 1, x0 : x1 + 1].reshape(n, -1).astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        bg_mean, bg_std, gradient = background_stats(
            values, dy, dx, detrend=cfg.detrend, ddof=cfg.ddof
        )
        undefined = ~np.isfinite(bg_std) | (bg_std == 0) | ~np.isfinite(peak)
        if cfg.background is None:
            undefined |= box_out
            bg_mean[box_out] = np.nan
            bg_std[box_out] = np.nan
            gradient[box_out] = np.nan
        snr = np.where(undefined, np.nan, (peak - bg_mean) / bg_std)
    peak[~np.isfinite(peak)] = np.nan
    sat = saturation_level(cfg, stack.dtype)
    bits = np.where(undefined, _BIT[FLAG_UNDEFINED], 0)
    bits |= np.where(box_out, _BIT[FLAG_EDGE], 0) | (_BIT[FLAG_EDGE] if clipped else 0)
    if sat is not None:
        bits |= np.where(peak >= sat, _BIT[FLAG_SATURATED], 0)
    return _Core(peak_x, peak_y, peak, bg_mean, bg_std, gradient, snr, bits.astype(np.uint8))


@functools.lru_cache(maxsize=16)
def _dtype_max(dtype: np.dtype) -> float:
    return float(np.iinfo(dtype).max)


def saturation_level(cfg: PeakSnrConfig, dtype: np.dtype) -> float | None:
    """The ``saturated`` flag's level: the configured one, else an integer dtype's maximum."""
    if cfg.saturation_dn is None and np.dtype(dtype).kind in "ui":
        return _dtype_max(np.dtype(dtype))
    return cfg.saturation_dn


_EXCLUDED_BITS = flags_to_bits(RUNNING_EXCLUDED)
_CONTAMINATED_BIT = _BIT[FLAG_RIM_CONTAMINATED]
_UNDEFINED_BIT = _BIT[FLAG_UNDEFINED]
_EDGE_BIT = _BIT[FLAG_EDGE]
_SATURATED_BIT = _BIT[FLAG_SATURATED]


def sequential_pass(
    core: _Core,
    cfg: PeakSnrConfig,
    *,
    reference: NoiseReference | None = None,
    fixed_reference: float | None = None,
    running: RunningSnr | None = None,
) -> None:
    """Frame by frame, in order: set ``rim_contaminated`` (against ``fixed_reference`` or the
    evolving ``reference``), then feed the noise reference and the running statistics with the
    frames that carry none of :data:`RUNNING_EXCLUDED`. Modifies ``core.bits`` in place."""
    bits = core.bits
    std = core.bg_std.tolist()
    grad = core.gradient.tolist()
    snr = core.snr.tolist()
    for i in range(len(std)):
        b = int(bits[i])
        after = _sequential_step(
            b, std[i], grad[i], snr[i], cfg, reference, fixed_reference, running
        )
        if after != b:
            bits[i] = after


def _sequential_step(
    bits: int,
    std: float,
    gradient: float,
    snr: float,
    cfg: PeakSnrConfig,
    reference: NoiseReference | None,
    fixed_reference: float | None,
    running: RunningSnr | None,
) -> int:
    """One frame of :func:`sequential_pass`: its bits with ``rim_contaminated`` decided."""
    ref = fixed_reference if reference is None else reference.value
    if not bits & _UNDEFINED_BIT and is_contaminated(std, gradient, ref, cfg):
        bits |= _CONTAMINATED_BIT
    remember(bits, std, snr, reference, running)
    return bits


def remember(
    bits: int,
    bg_std: float,
    snr: float,
    reference: NoiseReference | None,
    running: RunningSnr | None,
) -> None:
    """The one rule of what a measured frame (its flag ``bits``, background std and SNR) leaves
    behind for the next ones: a frame carrying none of :data:`RUNNING_EXCLUDED` feeds the
    recent-noise ``reference`` of the ``rim_contaminated`` test and the ``running`` SNR
    statistics (paper section 7); a contaminated one counts against the reference (its
    ``rejected``). Eq. (4) alone and the tracker both keep their memory by it."""
    if reference is not None:
        reference.update(
            bg_std, accepted=not bits & _EXCLUDED_BITS, rejected=bool(bits & _CONTAMINATED_BIT)
        )
    if running is not None and not bits & _EXCLUDED_BITS:
        running.push(snr)


def background_of(cfg: PeakSnrConfig) -> str:
    """The background method Eq. (4) uses with ``cfg``: ``rect`` or ``rim``."""
    return BACKGROUND_RIM if cfg.background is None else BACKGROUND_RECT


def result_at(core: _Core, i: int, background: str = BACKGROUND_RIM) -> PeakSnr:
    """The i-th frame of a core as a :class:`PeakSnr`."""
    return PeakSnr(
        int(core.peak_x[i]),
        int(core.peak_y[i]),
        float(core.peak[i]),
        float(core.bg_mean[i]),
        float(core.bg_std[i]),
        float(core.snr[i]),
        flags_from_bits(int(core.bits[i])),
        background,
    )


def measure_peak_snr(
    pixels: np.ndarray,
    at_xy: tuple[float, float],
    *,
    search_px: int = 11,
    box_px: int = 7,
    background: Rect | None = None,
    detrend: bool = False,
    saturation_dn: float | None = None,
    ddof: int = 1,
    reference_noise: float | None = None,
) -> PeakSnr:
    """Paper Eq. (4) on one frame ``pixels`` (rows, columns) at the operator's point ``at_xy``.

    ``background`` None uses the rim of the ``box_px`` box; a rectangle ``(x0, y0, x1, y1)``
    (both corners included) uses those pixels instead. ``reference_noise`` (DN): the recent
    noise the ``rim_contaminated`` test compares against; None skips that test. The std uses
    ``ddof`` (default 1: the sample std, N-1, like MATLAB). Bad input (a point off the image, a
    rectangle outside it, an even box) is a ValueError; conditions of the data are flags.
    """
    cfg = PeakSnrConfig(search_px, box_px, background, detrend, saturation_dn, ddof)
    return peak_snr_with(pixels, at_xy, cfg, reference_noise=reference_noise)


def peak_snr_with(
    pixels: np.ndarray,
    at_xy: tuple[float, float],
    config: PeakSnrConfig,
    *,
    reference_noise: float | None = None,
) -> PeakSnr:
    """:func:`measure_peak_snr` with every setting from ``config``, the contamination factors
    included: the one entry point for callers that hold a configuration (the tracker)."""
    return _measure_one(pixels, at_xy, config, fixed_reference=reference_noise)


def _measure_one(
    pixels,
    at_xy,
    cfg,
    *,
    extra_bits=0,
    reference: NoiseReference | None = None,
    fixed_reference: float | None = None,
    running: RunningSnr | None = None,
) -> PeakSnr:
    if pixels.ndim != 2:
        raise ValueError(f"a frame must be 2-D (rows, columns), got shape {pixels.shape}")
    x, y = pixel_of(at_xy)
    if cfg.background is None and _compiles(pixels.dtype):
        one = _rim_one(pixels, x, y, cfg)
        if one is not None:
            px, py, peak, mean, std, gradient, snr, bits = one
            bits = _sequential_step(
                bits | extra_bits, std, gradient, snr, cfg, reference, fixed_reference, running
            )
            return PeakSnr(px, py, peak, mean, std, snr, flags_from_bits(bits), BACKGROUND_RIM)
    core = measure_core(pixels[None], x, y, cfg)
    core.bits |= extra_bits
    sequential_pass(
        core, cfg, reference=reference, fixed_reference=fixed_reference, running=running
    )
    return result_at(core, 0, background_of(cfg))


@functools.lru_cache(maxsize=32)
def _compiles(dtype: np.dtype) -> bool:
    """Pixels the compiled Eq. (4) reads as NumPy does: native integers and float32/float64."""
    return dtype.isnative and (dtype.kind in "ui" or dtype in (np.float32, np.float64))


def _rim_one(pixels: np.ndarray, x: int, y: int, cfg: PeakSnrConfig) -> tuple | None:
    """:func:`measure_core` of one frame with the rim background, compiled: (peak_x, peak_y,
    peak, bg_mean, bg_std, gradient, snr, bits) as Python numbers, bit for bit those of the
    NumPy reductions (the brightest pixel of ``rim_kernel.brightest``, the rim's statistics and
    gradient of ``rim_kernel.rim_background``); None where the window holds no finite pixel
    (NumPy's way then). Reads the window and the box by slicing, so a
    lazily corrected frame corrects them first."""
    rows, cols = pixels.shape
    sx0, sx1, sy0, sy1, clipped = search_window(x, y, rows, cols, cfg)
    win = pixels[sy0 : sy1 + 1, sx0 : sx1 + 1]
    idx = brightest(win)
    if idx < 0:
        return None
    width = sx1 - sx0 + 1
    iy, ix = divmod(idx, width)
    px, py = sx0 + ix, sy0 + iy
    peak = float(win[iy, ix])
    bits = _EDGE_BIT if clipped else 0
    hb = cfg.box_px // 2
    if px < hb or px > cols - 1 - hb or py < hb or py > rows - 1 - hb:
        mean = std = gradient = snr = math.nan
        bits |= _EDGE_BIT | _UNDEFINED_BIT
    else:
        box = pixels[py - hb : py + hb + 1, px - hb : px + hb + 1]
        mean, std, gradient, _ = rim_background(box, cfg.detrend, cfg.ddof)
        if math.isfinite(std) and std != 0 and math.isfinite(peak):
            snr = (peak - mean) / std
        else:
            snr = math.nan
            bits |= _UNDEFINED_BIT
    if not math.isfinite(peak):
        peak = math.nan
    sat = saturation_level(cfg, pixels.dtype)
    if sat is not None and peak >= sat:
        bits |= _SATURATED_BIT
    return px, py, peak, mean, std, gradient, snr, bits


class PeakSnrMeter:
    """Eq. (4) frame after frame with memory: the recent-noise reference of the
    ``rim_contaminated`` flag and the running mean/std of the last ``window`` valid SNR values.

    Keyword arguments are the fields of :class:`PeakSnrConfig`, or pass ``config``.
    """

    def __init__(self, config: PeakSnrConfig | None = None, *, window: int = 100, **settings):
        self.config = config if config is not None else PeakSnrConfig(**settings)
        if config is not None and settings:
            raise ValueError("give either config or settings, not both")
        self.running = RunningSnr(window)
        self.reference = NoiseReference(
            self.config.reference_frames, self.config.reference_min_frames
        )

    def measure(
        self, pixels: np.ndarray, at_xy: tuple[float, float], *, extra_flags: Iterable[str] = ()
    ) -> PeakSnr:
        """Measure one frame; ``extra_flags`` (e.g. the tracker's ``lost``) are added before the
        frame is offered to the noise reference and the running statistics."""
        return _measure_one(
            pixels,
            at_xy,
            self.config,
            extra_bits=flags_to_bits(extra_flags),
            reference=self.reference,
            running=self.running,
        )

    @property
    def reference_noise(self) -> float | None:
        """The recent noise (DN) the contamination test uses now; None while warming up."""
        return self.reference.value

    def reset(self) -> None:
        """Forget the history (new ROI, new stop)."""
        self.running.clear()
        self.reference.clear()

    def snapshot(self) -> dict:
        """The running statistics and the noise reference, exactly (JSON-able)."""
        return {"running": self.running.snapshot(), "reference": self.reference.snapshot()}

    def restore(self, state: dict) -> None:
        self.running.restore(state["running"])
        self.reference.restore(state["reference"])
