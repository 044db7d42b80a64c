"""Scene configurations from the physics model (``model/``): the simulator's numbers are the
model's numbers, so the truth of every frame can be compared with the model's prediction.

Owns :func:`scene_config_from_model` and :func:`blackbody_scene`. The sensor chain is the
model's: background electrons of the apparent sky temperature (``model.detector``), temporal
noise (``model.noise``, paper Eq. 1; what is not sky shot noise becomes the scene's floor noise),
target contrast electrons with PVF = 1 versus range (``model.snr``, Eq. 2 without PVF) tabulated
once, and, when a model PSF is given, the pixel energy fractions of ``model.pvf`` tabulated over
sub-pixel phases. ``model`` is imported lazily: the rest of ``sim`` works without it.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from snrmon.sim.drone import GaussianSpread, TabulatedSpread
from snrmon.sim.scene import SceneConfig, TargetSignal

DEFAULT_SKY_TEMP_K = 280.0
"""The simulated clear sky's apparent temperature: a cold clear sky (the paper's LWIR sky read
29.5-33.5 C in a cloud gap; a scenario sets its own, ``sim.twin.Scenario``)."""


def _airy_equivalent_sigma_px(sensor) -> float:
    """Gaussian sigma [px] of an Airy core: 0.42 lambda F at the band centre, over the pitch."""
    lam_um = 0.5 * (sensor.band_um[0] + sensor.band_um[1])
    return 0.42 * lam_um * sensor.f_number / sensor.pitch_um


def _energy_fractions(psf, fill_factor, dx, dy, target_sigma_px):
    from snrmon.model.pvf import pixel_energy_fractions

    return pixel_energy_fractions(
        psf, dx, dy, half_size_px=3, fill_factor=fill_factor, target_sigma_px=target_sigma_px
    )


def scene_config_from_model(
    sensor,
    target,
    *,
    size: str = "small",
    sky_temp_k: float = DEFAULT_SKY_TEMP_K,
    air_temp_k: float | None = None,
    atmosphere=None,
    psf=None,
    psf_sigma_px: float | None = None,
    ranges_m: tuple[float, ...] | None = None,
    **overrides,
) -> SceneConfig:
    """A :class:`SceneConfig` for ``sensor`` (``model.presets.load_sensor``) watching
    ``target`` (``model.presets.load_target``) against a clear sky at ``sky_temp_k``, through
    air at ``air_temp_k`` (default the model atmosphere's; ``model.contrast``).

    ``size`` picks the characteristic dimension ("small" or "large", paper section 3) for both
    the signal and the rendered source. ``psf``: a ``model.psf`` object, rendered through
    ``model.pvf.pixel_energy_fractions`` for unresolved sources; without it the PSF is a Gaussian
    of ``psf_sigma_px`` (default: the Airy-core equivalent 0.42 lambda F / pitch). Any other
    :class:`SceneConfig` field may be overridden by keyword.
    """
    from snrmon.model.detector import background_electrons
    from snrmon.model.noise import temporal_noise_e
    from snrmon.model.snr import target_contrast_electrons

    if size not in ("small", "large"):
        raise ValueError(f"target size must be 'small' or 'large', got {size!r}")
    if not sky_temp_k > 0:
        raise ValueError(f"sky temperature must be > 0 K, got {sky_temp_k}")
    size_m = float(target.small_m if size == "small" else target.large_m)
    sky_e = float(background_electrons(sensor, sky_temp_k))
    noise_e = float(temporal_noise_e(sensor, sky_temp_k))
    floor_e = math.sqrt(max(noise_e**2 - sky_e, 0.0))
    grid = ranges_m or tuple(float(r) for r in np.geomspace(5.0, 3000.0, 48))
    kwargs = {"size": size, "background_temp_k": sky_temp_k, "air_temp_k": air_temp_k}
    if atmosphere is not None:
        kwargs["atmosphere"] = atmosphere
    electrons = tuple(float(target_contrast_electrons(sensor, target, r, **kwargs)) for r in grid)
    if psf_sigma_px is None:
        psf_sigma_px = float(getattr(psf, "sigma_px", None) or _airy_equivalent_sigma_px(sensor))
    fill_factor = float(sensor.fill_factor)
    spread = None
    if psf is not None:
        spread = TabulatedSpread(
            functools.partial(_energy_fractions, psf, fill_factor),
            GaussianSpread(psf_sigma_px, fill_factor),
        )
    config = SceneConfig(
        name=str(getattr(sensor, "name", "camera")),
        width_px=int(sensor.width_px),
        height_px=int(sensor.height_px),
        gain_e_per_dn=float(sensor.gain_e_per_dn),
        dn_offset=float(sensor.dn_offset),
        sky_e=sky_e,
        floor_noise_e=floor_e,
        fill_factor=fill_factor,
        psf_sigma_px=psf_sigma_px,
        ifov_rad=float(sensor.ifov_rad),
        bit_depth=int(getattr(sensor, "bit_depth", 14)),
        target=TargetSignal(size_m, grid, electrons),
        spread=spread,
    )
    return dataclasses.replace(config, **overrides) if overrides else config


def blackbody_scene(config: SceneConfig, sensor, temp_k: float) -> SceneConfig:
    """``config`` looking into a uniform blackbody at ``temp_k`` (calibration captures): the
    model's background electrons at that temperature, through the same FPN and noise floor."""
    from snrmon.model.detector import background_electrons

    if not temp_k > 0:
        raise ValueError(f"blackbody temperature must be > 0 K, got {temp_k}")
    return dataclasses.replace(config, blackbody_e=float(background_electrons(sensor, temp_k)))
