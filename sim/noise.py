"""Noise of the simulated cameras: temporal noise, fixed pattern, quantisation and saturation.

Owns the three noise ingredients of a rendered frame (see docs/simulation.md):

* temporal noise: Gaussian with the std of the shot plus read ("floor") noise, in DN. Far from
  the drone it is taken from a precomputed :class:`NoiseBank` at a random offset and sign (fresh
  Gaussian noise for a whole 1280x720 frame costs ~10 ms in numpy); near the drone it is always
  drawn fresh (:func:`fresh_noise_dn`) so that what the measurement sees is honest.
* fixed-pattern noise (:class:`FixedPattern`): a seeded per-pixel gain and offset map whose
  spatial std on the sky is a set multiple (2-3x, paper section 7) of the temporal noise.
* quantisation to ``bit_depth`` bits in uint16 words with saturation (:func:`quantize_dn`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def temporal_noise_e(floor_noise_e: float, scene_e: float) -> float:
    """Temporal noise [e-] of a pixel seeing ``scene_e`` electrons: shot noise added in
    quadrature to the floor (read, dark, lens emission) noise (paper Eq. 1)."""
    if floor_noise_e < 0 or scene_e < 0:
        raise ValueError(f"noise terms must be >= 0, got floor={floor_noise_e}, scene={scene_e}")
    return float(np.sqrt(floor_noise_e**2 + scene_e))


def floor_noise_for(temporal_noise_dn: float, gain_e_per_dn: float, scene_e: float) -> float:
    """Floor noise [e-] that makes the total temporal noise equal ``temporal_noise_dn`` on a
    scene of ``scene_e`` electrons (e.g. the paper's 6.6 DN MWIR, 5.8 DN LWIR on clear sky)."""
    total_e = temporal_noise_dn * gain_e_per_dn
    if total_e**2 < scene_e:
        raise ValueError(
            f"temporal noise {temporal_noise_dn} DN x gain {gain_e_per_dn} e-/DN "
            f"= {total_e:.1f} e- is below the shot noise of {scene_e:.3g} e- "
            f"({np.sqrt(scene_e):.1f} e-)"
        )
    return float(np.sqrt(total_e**2 - scene_e))


@dataclass(frozen=True)
class FixedPattern:
    """Per-pixel gain (dimensionless, mean 1) and offset [DN] maps, float32 (H, W)."""

    gain: np.ndarray
    offset_dn: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        return self.gain.shape  # type: ignore[return-value]


def fixed_pattern(
    shape: tuple[int, int],
    *,
    spatial_noise_dn: float,
    gain_fraction: float,
    signal_dn: float,
    seed: int,
) -> FixedPattern:
    """Seeded fixed-pattern maps whose spatial std on a uniform ``signal_dn`` scene is
    ``spatial_noise_dn``: a share ``gain_fraction`` of that variance comes from gain
    non-uniformity (so it scales with the scene), the rest from offsets."""
    if not 0.0 <= gain_fraction <= 1.0:
        raise ValueError(f"fpn gain_fraction must be in [0, 1], got {gain_fraction}")
    if spatial_noise_dn < 0:
        raise ValueError(f"spatial noise must be >= 0 DN, got {spatial_noise_dn}")
    rng = np.random.default_rng([seed, 0xF1])
    gain_std = np.sqrt(gain_fraction) * spatial_noise_dn / signal_dn if signal_dn > 0 else 0.0
    offset_std = np.sqrt(1.0 - gain_fraction) * spatial_noise_dn
    gain = 1.0 + gain_std * rng.standard_normal(shape, dtype=np.float32)
    offset = offset_std * rng.standard_normal(shape, dtype=np.float32)
    return FixedPattern(gain.astype(np.float32), offset.astype(np.float32))


def no_fixed_pattern(shape: tuple[int, int]) -> FixedPattern:
    """Unit gain and zero offset: fixed-pattern noise off."""
    return FixedPattern(np.ones(shape, np.float32), np.zeros(shape, np.float32))


class NoiseBank:
    """Precomputed Gaussian noise [DN] drawn per frame as a random window of a larger plane.

    ``planes`` planes of shape (H + margin, W + margin); a frame takes one plane, a random
    (row, col) offset in [0, margin] and a random sign, i.e. ``2 * planes * (margin + 1)**2``
    distinct fields. Two frames never share a pixel's value unless they drew the same window,
    so frame differences carry sqrt(2) x the temporal noise as real frames do.
    """

    def __init__(
        self, shape: tuple[int, int], sigma_dn: float, *, planes: int, margin_px: int, seed: int
    ):
        if planes < 1 or margin_px < 1:
            raise ValueError(
                f"noise bank needs planes >= 1 and margin >= 1, got {planes}, {margin_px}"
            )
        self.shape = shape
        self.sigma_dn = float(sigma_dn)
        self.margin_px = int(margin_px)
        rng = np.random.default_rng([seed, 0xBA7C])
        h, w = shape
        self.planes = rng.standard_normal((planes, h + margin_px, w + margin_px), np.float32)
        self.planes *= np.float32(sigma_dn)

    def draw(self, rng: np.random.Generator) -> tuple[np.ndarray, float]:
        """A (H, W) view of the bank and the sign (+1 or -1) to apply it with."""
        p = int(rng.integers(self.planes.shape[0]))
        oy, ox = (int(v) for v in rng.integers(0, self.margin_px + 1, size=2))
        h, w = self.shape
        sign = 1.0 if rng.random() < 0.5 else -1.0
        return self.planes[p, oy : oy + h, ox : ox + w], sign


def fresh_noise_dn(rng: np.random.Generator, shape: tuple[int, int], sigma_dn) -> np.ndarray:
    """Fresh Gaussian noise [DN], float32; ``sigma_dn`` may be a scalar or a per-pixel array
    (the drone's own shot noise makes it vary across the window)."""
    return rng.standard_normal(shape, np.float32) * np.asarray(sigma_dn, np.float32)


def max_dn(bit_depth: int) -> int:
    """Largest code of a ``bit_depth``-bit converter (saturation level)."""
    if not 1 <= bit_depth <= 16:
        raise ValueError(f"bit depth must be 1..16 for uint16 words, got {bit_depth}")
    return (1 << bit_depth) - 1


def quantize_dn(buf: np.ndarray, bit_depth: int) -> np.ndarray:
    """Round a float DN image to integers, clip to [0, 2**bit_depth - 1] and return uint16.

    ``buf`` must already hold value + 0.5 (the renderer folds the 0.5 into its static
    background) so that truncation rounds to nearest; ``buf`` is clipped in place.
    """
    np.clip(buf, 0.0, float(max_dn(bit_depth)), out=buf)
    return buf.astype(np.uint16)
