"""The sky behind the drone, in electrons per pixel per frame.

Owns the scene background before noise and fixed pattern: a clear sky of uniform apparent
temperature (its electrons come from the model's sensor chain, or are given), a gentle linear
gradient (warmer towards the horizon, i.e. down the image), optional slowly drifting clouds
with a clear-sky hole around the line of sight (paper Figs. 3 and 11), and optional confusers
(a bird or an aircraft crossing: a brighter moving blob) for the tracker.

Clouds are one precomputed texture larger than the frame; a frame takes an integer-pixel window
of it whose offset follows a slow sinusoid, so the hole wanders around the image centre by
``drift_amplitude_px`` but the drone never leaves it. Cloud pixels get the same temporal noise as
clear sky (a shortcut: their extra shot noise is not rendered; docs/simulation.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage


@dataclass(frozen=True)
class CloudConfig:
    """Drifting clouds with a clear hole centred (at zero drift) on the image centre."""

    contrast_e: float  # electrons a fully cloudy pixel adds over clear sky
    hole_radius_px: float = 120.0
    edge_px: float = 25.0  # softness of the hole's and the clouds' edges
    scale_px: float = 60.0  # correlation length of the cloud texture
    cover: float = 0.7  # fraction of the sky outside the hole that is cloud
    drift_amplitude_px: tuple[float, float] = (18.0, 6.0)  # (x, y)
    drift_period_s: tuple[float, float] = (97.0, 61.0)


@dataclass(frozen=True)
class Confuser:
    """A bird or aircraft crossing: a blob of ``total_e`` electrons moving in a straight line."""

    t_start_s: float
    duration_s: float
    x0_px: float
    y0_px: float
    vx_px_per_s: float
    vy_px_per_s: float
    total_e: float
    size_px: float = 2.0

    def position_px(self, t_s: float) -> tuple[float, float] | None:
        """(x, y) at ``t_s``, or None outside its crossing time."""
        dt = t_s - self.t_start_s
        if dt < 0 or dt > self.duration_s:
            return None
        return self.x0_px + self.vx_px_per_s * dt, self.y0_px + self.vy_px_per_s * dt


def sky_electrons(
    shape: tuple[int, int], sky_e: float, gradient_e_per_px: tuple[float, float]
) -> np.ndarray:
    """Clear sky [e-] (H, W) float32: ``sky_e`` at the image centre plus a linear gradient
    (electrons per pixel along x and y; positive y = warmer towards the bottom/horizon)."""
    if sky_e < 0:
        raise ValueError(f"sky electrons must be >= 0, got {sky_e}")
    h, w = shape
    gx, gy = gradient_e_per_px
    x = (np.arange(w, dtype=np.float32) - (w - 1) / 2) * np.float32(gx)
    y = (np.arange(h, dtype=np.float32) - (h - 1) / 2) * np.float32(gy)
    sky = np.float32(sky_e) + y[:, None] + x[None, :]
    if sky.min() < 0:
        raise ValueError(f"sky gradient {gradient_e_per_px} e-/px drives the sky below 0 e-")
    return sky.astype(np.float32)


class CloudField:
    """Precomputed cloud texture [e-] and its slowly drifting window."""

    def __init__(self, shape: tuple[int, int], config: CloudConfig, seed: int):
        self.shape = shape
        self.config = config
        ax, ay = (math.ceil(abs(a)) for a in config.drift_amplitude_px)
        self.pad = (ay, ax)
        h, w = shape
        big_h, big_w = h + 2 * ay, w + 2 * ax
        self.texture = self._texture(big_h, big_w, seed)

    def _texture(self, big_h: int, big_w: int, seed: int) -> np.ndarray:
        c = self.config
        rng = np.random.default_rng([seed, 0xC10D])
        # Smooth the field at 1/8 resolution: same look, ~64x cheaper than full-size filtering.
        step = 8
        small = rng.standard_normal((big_h // step + 3, big_w // step + 3))
        small = ndimage.gaussian_filter(small, c.scale_px / step, mode="wrap")
        field = ndimage.zoom(small, step, order=1)[:big_h, :big_w]
        field = (field - field.mean()) / (field.std() + 1e-12)
        threshold = float(np.quantile(field, 1.0 - c.cover))
        soft = c.edge_px / c.scale_px
        cloud = 1.0 / (1.0 + np.exp(-(field - threshold) / max(soft, 1e-3)))
        yy, xx = np.mgrid[0:big_h, 0:big_w]
        r = np.hypot(xx - (big_w - 1) / 2, yy - (big_h - 1) / 2)
        clear = 1.0 / (1.0 + np.exp(-(r - c.hole_radius_px) / max(c.edge_px / 4, 1e-3)))
        return (c.contrast_e * cloud * clear).astype(np.float32)

    def offset_px(self, t_s: float) -> tuple[int, int]:
        """Integer (row, col) offset of the window into the texture at ``t_s``."""
        c = self.config
        ay, ax = self.pad
        dx = c.drift_amplitude_px[0] * math.sin(2 * math.pi * t_s / c.drift_period_s[0])
        dy = c.drift_amplitude_px[1] * math.sin(2 * math.pi * t_s / c.drift_period_s[1])
        return ay - round(dy), ax - round(dx)

    def at(self, t_s: float) -> np.ndarray:
        """(H, W) view of the cloud electrons at ``t_s``."""
        oy, ox = self.offset_px(t_s)
        h, w = self.shape
        return self.texture[oy : oy + h, ox : ox + w]

    def hole_centre_px(self, t_s: float) -> tuple[float, float]:
        """(x, y) of the clear-sky hole's centre in the image at ``t_s``."""
        oy, ox = self.offset_px(t_s)
        big_h, big_w = self.texture.shape
        return (big_w - 1) / 2 - ox, (big_h - 1) / 2 - oy
