"""Temporal noise (paper Eq. 1), the model's NETD, and spatial noise (Eq. 3).

Photon detector: Noise_temporal = sqrt(shot_bg^2 + shot_lens^2 + shot_dark^2 + read^2), shot
noise = sqrt(electrons); the cold shield's (tiny) emission is counted with the background.

Uncooled bolometer: photon shot noise does not describe it (Johnson, 1/f and thermal-fluctuation
noise dominate), so its temporal noise is taken from its NETD: noise_e = NETD x d(electrons)/dT
at the NETD reference scene temperature (300 K), in the equivalent-electron scale of
:mod:`snrmon.model.detector`. The breakdown then reports the (negligible) photon shot noise as
background/lens and the rest, sqrt(temporal^2 - shot^2), as "read". Its model NETD therefore
equals the specification at 300 K by construction.

Spatial noise: none by default (the paper sets it to zero); an absolute value in electrons, a
multiple "k x" of the temporal noise, or a clutter category from section 6 whose multiples are
chosen from the paper's "two to three times" observation.

Measured noise (:class:`MeasuredNoise`, the operator's choice): the camera's own 3D noise in DN
replaces Eq. 1 and the spatial term in Eq. 3's denominator: temporal = sigma_tvh x gain, spatial
= sigma_vh x gain (electrons per DN from the sensor). Once row, column and frame offsets are gone
(as Eq. 4's rim removes them) a pixel's noise against the others of its frame is
sqrt(sigma_tvh^2 + sigma_vh^2). The breakdown's background, lens, dark and read terms stay the
model's Eq. 1 values, for comparison; they no longer add up to the temporal noise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from snrmon.model.detector import (
    cold_shield_electrons,
    dark_electrons,
    extended_responsivity_e_per_k,
    lens_electrons,
    scene_electrons,
)
from snrmon.model.sensor import Sensor

CLUTTER_SPATIAL_FACTOR = {"none": 0.0, "low": 1.0, "medium": 2.5, "high": 4.0}
"""Spatial noise as a multiple of the temporal noise per clutter category (chosen: section 6
measured spatial noise 2-3x temporal in raw single frames -> "medium" 2.5)."""


@dataclass(frozen=True)
class NoiseBreakdown:
    """Noise components in electrons rms per pixel per frame."""

    background: float
    lens: float
    dark: float
    read: float
    temporal: float
    spatial: float = 0.0

    @property
    def total(self) -> float:
        """sqrt(temporal^2 + spatial^2), the denominator of Eq. 3."""
        return math.hypot(self.temporal, self.spatial)

    def as_dict(self) -> dict[str, float]:
        return {
            "background": self.background,
            "lens": self.lens,
            "dark": self.dark,
            "read": self.read,
            "temporal": self.temporal,
            "spatial": self.spatial,
        }


@dataclass(frozen=True)
class MeasuredNoise:
    """A camera's measured 3D noise in DN (bias-corrected): ``temporal_dn`` = sigma_tvh,
    ``spatial_dn`` = sigma_vh (module docstring)."""

    temporal_dn: float
    spatial_dn: float

    def __post_init__(self) -> None:
        for name in ("temporal_dn", "spatial_dn"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise ValueError(f"measured noise {name} must be >= 0 DN, got {v!r}")
        if self.temporal_dn == 0 and self.spatial_dn == 0:
            raise ValueError("measured noise of 0 DN: the SNR would be infinite")

    @property
    def total_dn(self) -> float:
        return math.hypot(self.temporal_dn, self.spatial_dn)


def bolometer_noise_e(sensor: Sensor) -> float:
    """NETD x responsivity at the NETD reference temperature (equivalent electrons)."""
    resp = extended_responsivity_e_per_k(sensor, sensor.netd_reference_temp_k)
    return sensor.netd_mk * 1e-3 * resp


def noise_breakdown(
    sensor: Sensor,
    background_temp_k: float,
    spatial_noise: float | str | None = None,
    measured: MeasuredNoise | None = None,
) -> NoiseBreakdown:
    """Eq. 1 components for a clear background at ``background_temp_k`` and the spatial term;
    with ``measured``, its temporal and spatial noise in place of the model's."""
    if measured is not None and spatial_noise is not None:
        raise ValueError("give a spatial noise or a measured noise, not both")
    bg, lens, dark, read, temporal = (
        float(v) for v in _eq1(sensor, scene_electrons(sensor, background_temp_k))
    )
    if measured is not None:
        gain = sensor.gain_e_per_dn
        return NoiseBreakdown(
            bg, lens, dark, read, measured.temporal_dn * gain, measured.spatial_dn * gain
        )
    return NoiseBreakdown(bg, lens, dark, read, temporal, spatial_noise_e(spatial_noise, temporal))


def total_noise_e(
    sensor: Sensor,
    background_temp_k: np.ndarray,
    spatial_noise: float | str | None = None,
    measured: MeasuredNoise | None = None,
) -> np.ndarray:
    """:attr:`NoiseBreakdown.total` of :func:`noise_breakdown` for each of an array of
    background temperatures at once (the Monte-Carlo band's sky draws)."""
    t = np.asarray(background_temp_k, dtype=float)
    if measured is not None:
        one = noise_breakdown(sensor, float(t.flat[0]), spatial_noise, measured)
        return np.full(t.shape, one.total)
    temporal = _eq1(sensor, scene_electrons(sensor, t))[4]
    return np.hypot(temporal, spatial_noise_e(spatial_noise, temporal))


def _eq1(sensor: Sensor, scene_e):
    """(background, lens, dark, read, temporal) noise [e- rms] for the scene's electrons
    ``scene_e`` (a float or an array): Eq. 1, or a bolometer's NETD (module docstring)."""
    bg = np.sqrt(scene_e + cold_shield_electrons(sensor))
    lens = math.sqrt(lens_electrons(sensor))
    if sensor.detector == "photon":
        dark = math.sqrt(dark_electrons(sensor))
        read = float(sensor.read_noise_e)
        temporal = np.sqrt(bg**2 + lens**2 + dark**2 + read**2)
    else:
        dark = 0.0
        netd_e = bolometer_noise_e(sensor)
        read = np.sqrt(np.maximum(netd_e**2 - bg**2 - lens**2, 0.0))
        temporal = np.sqrt(bg**2 + lens**2 + read**2)
    return bg, lens, dark, read, temporal


def temporal_noise_e(sensor: Sensor, background_temp_k: float) -> float:
    """Eq. 1 temporal noise [e- rms] against a background at ``background_temp_k``."""
    return noise_breakdown(sensor, background_temp_k).temporal


def model_netd_mk(sensor: Sensor, scene_temp_k: float | None = None) -> float:
    """NETD the model implies [mK]: temporal noise over d(electrons)/dT of a pixel-filling
    blackbody at ``scene_temp_k`` (default the sensor's NETD reference, 300 K)."""
    t = sensor.netd_reference_temp_k if scene_temp_k is None else scene_temp_k
    return 1e3 * temporal_noise_e(sensor, t) / extended_responsivity_e_per_k(sensor, t)


def spatial_noise_e(spec: float | str | None, temporal_e):
    """None -> 0; a number -> electrons; "2.5x" -> 2.5 x temporal; a clutter category
    (``temporal_e`` a float, or an array: the multiples are then arrays too)."""
    if spec is None:
        return 0.0
    if isinstance(spec, str):
        s = spec.strip().lower()
        if s in CLUTTER_SPATIAL_FACTOR:
            return CLUTTER_SPATIAL_FACTOR[s] * temporal_e
        if s.endswith("x"):
            try:
                k = float(s[:-1])
            except ValueError:
                k = -1.0
            if k >= 0 and math.isfinite(k):
                return k * temporal_e
        try:
            spec = float(s)
        except ValueError:
            known = ", ".join(CLUTTER_SPATIAL_FACTOR)
            raise ValueError(
                f"spatial noise must be electrons, 'Kx' (K x temporal) or one of {known}; "
                f"got {spec!r}"
            ) from None
    value = float(spec)
    if not (value >= 0 and math.isfinite(value)):
        raise ValueError(f"spatial noise must be >= 0 electrons, got {spec!r}")
    return value
