"""Raw frames of one simulated camera: sky, fixed pattern, temporal noise, drone, quantisation.

Owns :class:`SceneConfig` (every number of the scene, explicit), :class:`SceneRenderer` (one
frame per call, seeded by (seed, frame_index) so any frame can be re-rendered identically) and
the per-frame ground truth :class:`FrameTruth` (docs/simulation.md):

    DN = dn_offset + offset_map + gain_map * (sky_e + clouds_e + drone_e) / gain_e_per_dn + noise

with noise ~ N(0, sigma) [DN], sigma = sqrt(floor_noise_e**2 + scene_e) / gain_e_per_dn
(shot + floor noise, paper Eq. 1). Far from the drone the noise comes from a bank at a random
offset; in a window of ``fresh_half_px`` around the drone it is always fresh, and there the
drone's own shot noise is added: Gaussian of that variance, or with ``poisson_shot_noise`` the
charge drawn from a Poisson distribution (the scene's and the drone's electrons) plus Gaussian
floor noise. Speed: a static background (offset, gain x sky, the 0.5 of
rounding) is built once; a frame is one add of a bank slice, a few small windows, one clip and
one cast (~3 ms for 1280x720 on one core; benchmarks/bench_scene.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from snrmon.sim.drone import DronePatch, GaussianSpread, TabulatedSpread, drone_patch
from snrmon.sim.noise import (
    FixedPattern,
    NoiseBank,
    fixed_pattern,
    fresh_noise_dn,
    max_dn,
    no_fixed_pattern,
    quantize_dn,
)
from snrmon.sim.sky import CloudConfig, CloudField, Confuser, sky_electrons


@dataclass(frozen=True)
class TargetSignal:
    """Total contrast electrons of the drone versus range (PVF = 1), log-log interpolated.

    Outside the table the signal follows inverse square from the nearest end.
    """

    size_m: float  # characteristic dimension (sqrt of the target area)
    ranges_m: tuple[float, ...]
    electrons: tuple[float, ...]

    def __post_init__(self) -> None:
        r = np.asarray(self.ranges_m, float)
        if len(r) < 2 or len(r) != len(self.electrons) or np.any(np.diff(r) <= 0) or r[0] <= 0:
            raise ValueError(f"target signal table needs >= 2 increasing ranges > 0 m, got {r}")
        if np.any(np.asarray(self.electrons) <= 0):
            raise ValueError("target signal table electrons must be > 0")
        if self.size_m <= 0:
            raise ValueError(f"target size must be > 0 m, got {self.size_m}")

    @classmethod
    def inverse_square(cls, size_m: float, e_ref: float, range_ref_m: float) -> TargetSignal:
        """A vacuum target: ``e_ref`` electrons at ``range_ref_m``, falling as 1/R**2."""
        ranges = (range_ref_m / 100.0, range_ref_m * 100.0)
        return cls(size_m, ranges, tuple(e_ref * (range_ref_m / r) ** 2 for r in ranges))

    def electrons_at(self, range_m: float) -> float:
        if not range_m > 0:
            raise ValueError(f"range must be > 0 m, got {range_m}")
        r = np.asarray(self.ranges_m)
        e = np.asarray(self.electrons)
        if range_m <= r[0]:
            return float(e[0] * (r[0] / range_m) ** 2)
        if range_m >= r[-1]:
            return float(e[-1] * (r[-1] / range_m) ** 2)
        return float(np.exp(np.interp(np.log(range_m), np.log(r), np.log(e))))


@dataclass(frozen=True)
class SceneConfig:
    """Every number of one camera's scene; SI and electrons unless the name says otherwise."""

    width_px: int
    height_px: int
    gain_e_per_dn: float
    dn_offset: float
    sky_e: float  # clear-sky background electrons per pixel per frame at the image centre
    floor_noise_e: float  # read + dark + lens-emission noise, added to sky shot noise
    fill_factor: float
    psf_sigma_px: float
    ifov_rad: float
    target: TargetSignal | None = None
    name: str = "camera"
    bit_depth: int = 14
    sky_gradient_e_per_px: tuple[float, float] = (0.0, 0.0)
    fpn_enabled: bool = True
    fpn_multiple: float = 2.5  # spatial / temporal noise on clear sky (paper: 2-3)
    fpn_gain_fraction: float = 0.3  # share of the FPN variance from gain non-uniformity
    target_shot_noise: bool = True
    poisson_shot_noise: bool = False  # in the fresh window: Poisson charge, not its Gaussian
    fresh_half_px: int = 24  # fresh noise in a (2h+1)^2 window around the drone
    noise_bank_planes: int = 4
    noise_bank_margin_px: int = 64
    clouds: CloudConfig | None = None
    confusers: tuple[Confuser, ...] = ()
    blackbody_e: float | None = None  # uniform source instead of sky and drone
    resolved_above_px: float = 1.0
    spread: GaussianSpread | TabulatedSpread | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        for name in ("width_px", "height_px"):
            if getattr(self, name) < 16:
                raise ValueError(f"{name} must be >= 16, got {getattr(self, name)}")
        for name in ("gain_e_per_dn", "ifov_rad"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.floor_noise_e < 0 or self.sky_e < 0:
            raise ValueError(
                f"sky_e and floor_noise_e must be >= 0, got {self.sky_e}, {self.floor_noise_e}"
            )
        if self.fresh_half_px < 7:
            raise ValueError(f"fresh_half_px must be >= 7 (15x15 window), got {self.fresh_half_px}")
        max_dn(self.bit_depth)

    @property
    def shape(self) -> tuple[int, int]:
        return self.height_px, self.width_px

    @property
    def scene_e(self) -> float:
        """Electrons of the uniform part of the scene (sky, or the blackbody)."""
        return self.sky_e if self.blackbody_e is None else self.blackbody_e

    @property
    def temporal_noise_e(self) -> float:
        return math.sqrt(self.floor_noise_e**2 + self.scene_e)

    @property
    def temporal_noise_dn(self) -> float:
        return self.temporal_noise_e / self.gain_e_per_dn

    def spread_model(self) -> GaussianSpread | TabulatedSpread:
        if self.spread is not None:
            return self.spread
        return GaussianSpread(self.psf_sigma_px, self.fill_factor, self.resolved_above_px)


@dataclass(frozen=True)
class TargetState:
    """Where the drone is in one camera's image and how much signal it has."""

    x_px: float  # column, pixel centres at integers
    y_px: float  # row
    total_e: float  # contrast electrons with PVF = 1
    size_px: float  # characteristic dimension at range, in pixels


@dataclass(frozen=True)
class FrameTruth:
    """What a perfect measurement of this frame would see (noise-free, as rendered)."""

    frame_index: int
    t_s: float
    x_px: float
    y_px: float
    peak_row: int
    peak_col: int
    peak_signal_e: float  # noise-free drone electrons on the brightest pixel
    peak_signal_dn: float  # the same in DN, through that pixel's FPN gain
    temporal_noise_dn: float  # background temporal noise rendered (Gaussian std)
    temporal_noise_e: float
    total_e: float
    size_px: float
    resolved: bool
    saturated: bool  # noise-free peak pixel at or above full scale
    fresh_window: tuple[int, int, int, int]  # row0, row1, col0, col1 (half-open)

    @property
    def truth_snr(self) -> float:
        """Noise-free peak signal / temporal noise (the per-frame truth SNR)."""
        return self.peak_signal_dn / self.temporal_noise_dn

    @property
    def pvf(self) -> float:
        """Fraction of the total signal on the brightest pixel (this frame's PVF)."""
        return self.peak_signal_e / self.total_e if self.total_e > 0 else 0.0


def _clip_box(r0: int, r1: int, c0: int, c1: int, shape) -> tuple[int, int, int, int]:
    return max(r0, 0), min(r1, shape[0]), max(c0, 0), min(c1, shape[1])


class SceneRenderer:
    """Renders frames of ``config`` with ``seed``; picklable (heavy state is rebuilt lazily)."""

    def __init__(self, config: SceneConfig, seed: int):
        self.config = config
        self.seed = int(seed)
        self.spread = config.spread_model()
        self._ready = False

    def __getstate__(self) -> dict:
        return {"config": self.config, "seed": self.seed, "spread": self.spread, "_ready": False}

    def _prepare(self) -> None:
        c = self.config
        shape = c.shape
        if c.blackbody_e is None:
            scene = sky_electrons(shape, c.sky_e, c.sky_gradient_e_per_px)
        else:
            scene = np.full(shape, c.blackbody_e, np.float32)
        sigma = c.temporal_noise_dn
        if c.fpn_enabled:
            # The pattern is the camera's, defined on the clear sky: a blackbody capture goes
            # through the very same gain and offset maps (what a calibration must recover).
            sky_sigma_dn = math.sqrt(c.floor_noise_e**2 + c.sky_e) / c.gain_e_per_dn
            self.fpn: FixedPattern = fixed_pattern(
                shape,
                spatial_noise_dn=c.fpn_multiple * sky_sigma_dn,
                gain_fraction=c.fpn_gain_fraction,
                signal_dn=c.sky_e / c.gain_e_per_dn,
                seed=self.seed,
            )
        else:
            self.fpn = no_fixed_pattern(shape)
        self._dn_per_e = (self.fpn.gain / np.float32(c.gain_e_per_dn)).astype(np.float32)
        self.static_dn = (
            np.float32(c.dn_offset + 0.5) + self.fpn.offset_dn + scene * self._dn_per_e
        ).astype(np.float32)
        self.bank = NoiseBank(
            shape,
            sigma,
            planes=c.noise_bank_planes,
            margin_px=c.noise_bank_margin_px,
            seed=self.seed,
        )
        self.clouds = (
            CloudField(shape, c.clouds, self.seed)
            if c.clouds is not None and c.blackbody_e is None
            else None
        )
        self._buf = np.empty(shape, np.float32)
        self._tmp = np.empty(shape, np.float32)
        self._ready = True

    # -- public -----------------------------------------------------------------------------

    def render(self, frame_index: int, t_s: float, target: TargetState | None) -> np.ndarray:
        """The (H, W) uint16 frame number ``frame_index`` at scene time ``t_s``."""
        return self.render_with_truth(frame_index, t_s, target)[0]

    def truth_for(self, frame_index: int, t_s: float, target: TargetState | None):
        """:class:`FrameTruth` of that frame without rendering it (None without a drone)."""
        if not self._ready:
            self._prepare()
        if target is None or self.config.blackbody_e is not None:
            return None
        patch = drone_patch(self.spread, target.x_px, target.y_px, target.size_px, target.total_e)
        return self._truth(frame_index, t_s, target, patch, self._fresh_box(target, patch))

    def render_with_truth(self, frame_index: int, t_s: float, target: TargetState | None):
        """(frame, truth) in one pass; truth is None without a drone or in blackbody mode."""
        if not self._ready:
            self._prepare()
        c = self.config
        rng = np.random.default_rng([self.seed, int(frame_index)])
        bank, sign = self.bank.draw(rng)
        buf = self._buf
        if sign > 0:
            np.add(self.static_dn, bank, out=buf)
        else:
            np.subtract(self.static_dn, bank, out=buf)
        if self.clouds is not None:
            np.multiply(self.clouds.at(t_s), self._dn_per_e, out=self._tmp)
            buf += self._tmp
        if c.blackbody_e is None:
            for confuser in c.confusers:
                self._add_confuser(buf, confuser, t_s)
        truth = None
        if target is not None and c.blackbody_e is None:
            patch = drone_patch(
                self.spread, target.x_px, target.y_px, target.size_px, target.total_e
            )
            box = self._fresh_box(target, patch)
            self._add_fresh_window(buf, rng, bank, sign, box, patch, t_s)
            truth = self._truth(frame_index, t_s, target, patch, box)
        return quantize_dn(buf, c.bit_depth), truth

    # -- internals --------------------------------------------------------------------------

    def _fresh_box(self, target: TargetState, patch: DronePatch) -> tuple[int, int, int, int]:
        h_patch = (patch.electrons.shape[0] - 1) // 2
        h = max(self.config.fresh_half_px, h_patch + 4)
        cy, cx = round(target.y_px), round(target.x_px)
        return _clip_box(cy - h, cy + h + 1, cx - h, cx + h + 1, self.config.shape)

    def _patch_in_image(self, patch: DronePatch):
        """(image slices, patch slices) of the part of the patch inside the image."""
        ph, pw = patch.electrons.shape
        r0, r1, c0, c1 = _clip_box(
            patch.row0, patch.row0 + ph, patch.col0, patch.col0 + pw, self.config.shape
        )
        if r0 >= r1 or c0 >= c1:
            return None
        img = (slice(r0, r1), slice(c0, c1))
        sub = (slice(r0 - patch.row0, r1 - patch.row0), slice(c0 - patch.col0, c1 - patch.col0))
        return img, sub

    def _add_fresh_window(self, buf, rng, bank, sign, box, patch: DronePatch, t_s) -> None:
        c = self.config
        r0, r1, c0, c1 = box
        if r0 >= r1 or c0 >= c1:
            return
        win = (slice(r0, r1), slice(c0, c1))
        # Take the bank's noise out again and put fresh noise in its place.
        if sign > 0:
            buf[win] -= bank[win]
        else:
            buf[win] += bank[win]
        sigma = np.full((r1 - r0, c1 - c0), c.temporal_noise_dn, np.float32)
        charge = np.full(sigma.shape, c.scene_e)  # the Poisson mean of each pixel [e-]
        placed = self._patch_in_image(patch)
        if placed is not None:
            img, sub = placed
            drone_e = patch.electrons[sub]
            buf[img] += drone_e * self._dn_per_e[img]
            if c.target_shot_noise:
                # Shot noise of the drone's own electrons; clouds' extra shot noise is not
                # rendered (docs/simulation.md, shortcuts).
                scene_e = c.scene_e
                local = (
                    slice(img[0].start - r0, img[0].stop - r0),
                    slice(img[1].start - c0, img[1].stop - c0),
                )
                sigma[local] = np.sqrt(c.floor_noise_e**2 + scene_e + drone_e) / c.gain_e_per_dn
                charge[local] += drone_e
        if c.poisson_shot_noise:
            shot_e = rng.poisson(charge) - charge
            floor_e = c.floor_noise_e * rng.standard_normal(charge.shape)
            buf[win] += ((shot_e + floor_e) / c.gain_e_per_dn).astype(np.float32)
        else:
            buf[win] += fresh_noise_dn(rng, sigma.shape, sigma)

    def _add_confuser(self, buf, confuser: Confuser, t_s: float) -> None:
        pos = confuser.position_px(t_s)
        if pos is None:
            return
        patch = drone_patch(self.spread, pos[0], pos[1], confuser.size_px, confuser.total_e)
        placed = self._patch_in_image(patch)
        if placed is not None:
            img, sub = placed
            buf[img] += patch.electrons[sub] * self._dn_per_e[img]

    def _truth(self, frame_index, t_s, target: TargetState, patch: DronePatch, box) -> FrameTruth:
        c = self.config
        placed = self._patch_in_image(patch)
        if placed is None:
            peak_e = peak_dn = 0.0
            pr, pc = round(target.y_px), round(target.x_px)
            saturated = False
        else:
            img, sub = placed
            signal_dn = patch.electrons[sub] * self._dn_per_e[img]
            k = np.unravel_index(int(np.argmax(signal_dn)), signal_dn.shape)
            pr, pc = img[0].start + int(k[0]), img[1].start + int(k[1])
            peak_dn = float(signal_dn[k])
            peak_e = float(patch.electrons[sub][k])
            background = float(self.static_dn[pr, pc]) - 0.5
            if self.clouds is not None:
                background += float(self.clouds.at(t_s)[pr, pc] * self._dn_per_e[pr, pc])
            saturated = background + peak_dn >= max_dn(c.bit_depth)
        return FrameTruth(
            frame_index=int(frame_index),
            t_s=float(t_s),
            x_px=float(target.x_px),
            y_px=float(target.y_px),
            peak_row=int(pr),
            peak_col=int(pc),
            peak_signal_e=peak_e,
            peak_signal_dn=peak_dn,
            temporal_noise_dn=c.temporal_noise_dn,
            temporal_noise_e=c.temporal_noise_e,
            total_e=float(target.total_e),
            size_px=float(target.size_px),
            resolved=self.spread.is_resolved(target.size_px),
            saturated=bool(saturated),
            fresh_window=box,
        )
