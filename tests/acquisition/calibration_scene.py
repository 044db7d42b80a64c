"""Test scenes for calibration and characterization, built from sim's public pieces.

Why not ``sim.scene.SceneRenderer`` + ``sim.twin.blackbody_scene`` directly: these scenes
need a drone of a set TEMPERATURE and shape (sim renders set contrast electrons in one square),
and they were written when the renderer still derived its fixed pattern from the level it
renders (fixed since: tests/sim/test_scene.py checks blackbody captures share the camera's
maps). Here ONE ``sim.noise.FixedPattern`` (made as the renderer makes it for the sky)
is used for every capture; electrons are the twin camera's (``sim.radiometry.TwinCamera``),
noise is sim's Eq. 1 shot + floor noise, quantisation is ``sim.noise.quantize_dn``. The drone is
a set of pixel-axis-aligned rectangles (a cross) at a set temperature, each a box convolved with
the Gaussian PSF on the active areas (``sim.drone.box_gaussian_fractions_1d``), because sim's
resolved drone is one square box of set contrast electrons (for which small == large).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from snrmon.model.presets import load_sensor, load_target
from snrmon.sim.drone import box_gaussian_fractions_1d
from snrmon.sim.noise import FixedPattern, fixed_pattern, quantize_dn
from snrmon.sim.radiometry import TwinCamera
from snrmon.sim.scene import SceneConfig
from snrmon.sim.twin import Scenario, twin_scene_config


@dataclass
class Camera:
    sensor: object
    config: SceneConfig
    fpn: FixedPattern

    @property
    def shape(self) -> tuple[int, int]:
        return self.fpn.shape

    def electrons(self, temp_k: float) -> float:
        return TwinCamera.from_sensor(self.sensor).pixel_electrons(temp_k)

    def frames(self, scene_e, n: int, seed: int, *, noise_scale=None) -> np.ndarray:
        """(n, H, W) uint16 frames of a scene of ``scene_e`` electrons (scalar or (H, W))."""
        c = self.config
        rng = np.random.default_rng(seed)
        scene = np.broadcast_to(np.asarray(scene_e, np.float32), self.shape)
        static = c.dn_offset + 0.5 + self.fpn.offset_dn + self.fpn.gain * scene / c.gain_e_per_dn
        sigma = np.sqrt(c.floor_noise_e**2 + scene) / c.gain_e_per_dn
        if noise_scale is not None:
            sigma = sigma * noise_scale
        out = np.empty((n, *self.shape), np.uint16)
        for i in range(n):
            buf = (static + sigma * rng.standard_normal(self.shape, np.float32)).astype(np.float32)
            out[i] = quantize_dn(buf, c.bit_depth)
        return out

    def blackbody(self, temp_k: float, n: int, seed: int, **kw) -> np.ndarray:
        return self.frames(self.electrons(temp_k), n, seed, **kw)


def camera(name: str = "mwir", shape=(96, 128), seed: int = 7, sky_temp_k=280.0) -> Camera:
    sensor = load_sensor(name)
    cfg = twin_scene_config(
        sensor, load_target("uav1"), Scenario(sky_temp_k=sky_temp_k), spread=None
    )
    fpn = fixed_pattern(
        shape,
        spatial_noise_dn=cfg.fpn_multiple * cfg.temporal_noise_dn,
        gain_fraction=cfg.fpn_gain_fraction,
        signal_dn=cfg.sky_e / cfg.gain_e_per_dn,
        seed=seed,
    )
    return Camera(sensor, cfg, fpn)


def rect_electrons(shape, rects, psf_sigma_px: float, fill_factor: float) -> np.ndarray:
    """Electrons of pixel-aligned rectangles ``(xc, yc, w_px, h_px, e_per_pixel)`` (e_per_pixel:
    the contrast a pixel-filling patch would give) convolved with a Gaussian PSF."""
    out = np.zeros(shape, np.float64)
    for xc, yc, w, h, e_px in rects:
        cx, cy = round(xc), round(yc)
        half = int(max(w, h) / 2 + 5 * psf_sigma_px + 3)
        fx = box_gaussian_fractions_1d(half, xc - cx, w, psf_sigma_px, fill_factor)
        fy = box_gaussian_fractions_1d(half, yc - cy, h, psf_sigma_px, fill_factor)
        total = e_px * w * h / fill_factor
        out[cy - half : cy + half + 1, cx - half : cx + half + 1] += total * np.outer(fy, fx)
    return out


def cross_drone(
    cam: Camera,
    *,
    range_m: float,
    xc: float,
    yc: float,
    span_m: float,
    arm_m: float,
    temp_k: float,
    sky_temp_k: float,
):
    """A cross (plus sign) of two bars ``span_m`` long, ``arm_m`` wide at ``temp_k``: electrons
    (H, W) over the sky, and its true area and bounding box [m^2]."""
    px = range_m * cam.sensor.ifov_rad
    span, arm = span_m / px, arm_m / px
    de = cam.electrons(temp_k) - cam.electrons(sky_temp_k)
    stub = (span - arm) / 2
    rects = [
        (xc, yc, span, arm, de),
        (xc, yc - arm / 2 - stub / 2, arm, stub, de),
        (xc, yc + arm / 2 + stub / 2, arm, stub, de),
    ]
    e = rect_electrons(cam.shape, rects, cam.config.psf_sigma_px, cam.sensor.fill_factor)
    area_m2 = 2 * span_m * arm_m - arm_m**2
    return cam.electrons(sky_temp_k) + e, area_m2, span_m**2
