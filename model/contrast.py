"""The target's contrast signal at the aperture (paper Eq. 2 without the PVF), with the sky and
the air as two temperatures.

Along the line of sight to a drone at range R the camera sees the drone through the air:
tau(R) L_t + (1 - tau(R)) S_air; around it, the clear sky: L_sky (the whole path, i.e. the
apparent sky temperature a calibrated camera measures). The contrast photon radiance is

    dLq(R, lambda) = tau(R) (L_t - S_air) + (S_air - L_sky)

with S_air a blackbody at the air temperature (or MODTRAN's path source function) and L_sky a
blackbody at the measured sky temperature, or S_air itself when no sky temperature is given (the
infinite path of the model's own atmosphere; then dLq = tau (L_t - S_air) as before). The paper
corrected the background with the measured sky (its path-radiance correction, sections 8-9);
using the sky temperature for the path as well understates the contrast when the air is warmer
than the sky (4-13 % at 37-508 m with a 280 K sky and 288 K air in the MWIR, UAV1;
tools/doc_figures.py). tau is the atmosphere's spectral transmission averaged over each
quadrature cell (:meth:`snrmon.model.atmosphere.Atmosphere.signal_transmission`), so the
integral weights it by the contrast spectrum itself.

When no sky temperature is given the sky is ASSUMED equal to the air (``sky_assumed``): the
Monte-Carlo band then draws the sky with :attr:`snrmon.model.montecarlo.InputUncertainty.
sky_assumed_k` (8 K) instead of the measurement's 5 % of its radiance.

Electrons: the contrast radiance times A_opt t_int and the photon response tau_o tau_cf QE,
integrated over the band (48-node Gauss-Legendre), per unit (target area / range^2): multiply
by A_t / R^2 for the point-source equivalent (PVF = 1). Temperatures may be arrays (they
broadcast against each other; the Monte-Carlo band samples them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from snrmon.model.atmosphere import Atmosphere, band_key, resolve_atmosphere
from snrmon.model.detector import spectral_grid
from snrmon.model.footprint import matmul
from snrmon.model.radiometry import spectral_photon_radiance
from snrmon.model.sensor import Sensor
from snrmon.model.target import Target


def _check_temp(what: str, value) -> float:
    if not (value is not None and value > 0 and math.isfinite(value)):
        raise ValueError(f"{what} must be > 0 K, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class Contrast:
    """The radiometric chain of one sensor, target and atmosphere at a set of ranges."""

    atmosphere: Atmosphere
    sky_temp_k: float  # the clear sky behind the drone (the noise's background too)
    air_temp_k: float  # the air between the camera and the drone
    target_temp_k: float
    ranges_m: np.ndarray
    band_um: tuple[float, float]
    tau: np.ndarray  # (n_ranges, n_wl): the per-cell averaged spectral transmission
    k_spec: np.ndarray  # A_opt t_int w resp per wavelength node [m^2 s um]
    wavelengths_um: np.ndarray
    source_air: np.ndarray  # S_air per wavelength (photon, per um)
    sky: np.ndarray  # L_sky per wavelength
    sky_assumed: bool = False  # no sky temperature given: the sky is the air's (widened band)

    def intensity_e(
        self, target_temp_k=None, air_temp_k=None, sky_temp_k=None, tau_scale=1.0
    ) -> np.ndarray:
        """Contrast electrons per (m^2 of target / m^2 of range^2) at each range; any argument
        given (scalar or an array of samples, shape (n,)) replaces the chain's value: the
        result is then (n, n_ranges). The sum of :meth:`through_air_e` and :meth:`path_e`."""
        sampled = not (
            target_temp_k is None
            and air_temp_k is None
            and sky_temp_k is None
            and np.ndim(tau_scale) == 0
        )
        out = self.through_air_e(target_temp_k, air_temp_k, tau_scale) + self.path_e(
            air_temp_k, sky_temp_k
        )
        return out if sampled else out[0]

    def _radiance(self, temp_k, default) -> np.ndarray:
        """Photon radiance per wavelength (n, n_wl) at temperatures ``temp_k`` (n,), or
        ``default`` (one row) for None."""
        if temp_k is None:
            return np.atleast_2d(default)
        wl = self.wavelengths_um
        return spectral_photon_radiance(wl, np.atleast_1d(np.asarray(temp_k, float))).T

    def through_air_e(self, target_temp_k=None, air_temp_k=None, tau_scale=1.0) -> np.ndarray:
        """The target's part of :meth:`intensity_e`, tau (L_t - S_air), (n, n_ranges): it
        holds no sky. ``tau_scale``: a number, one per sample (n,), or one per sample and range
        (n, n_ranges)."""
        lt = self._radiance(
            target_temp_k, spectral_photon_radiance(self.wavelengths_um, self.target_temp_k)
        )
        air = self._radiance(air_temp_k, self.source_air)
        scale = np.asarray(tau_scale, float)
        scale = scale if scale.ndim == 2 else np.atleast_1d(scale)[:, None]
        # (n, n_ranges): the Monte-Carlo band's 201 x 48 x 500 product, in blocks that a
        # threaded BLAS runs on one thread (50 ms now and then as one product)
        return scale * matmul((lt - air) * self.k_spec, self.tau.T)

    def path_e(self, air_temp_k=None, sky_temp_k=None) -> np.ndarray:
        """The path's part of :meth:`intensity_e`, S_air - L_sky, (n, 1): the same at every
        range."""
        air = self._radiance(air_temp_k, self.source_air)
        sky = self._radiance(sky_temp_k, self.sky)
        return np.sum((air - sky) * self.k_spec, axis=1)[:, None]

    @property
    def background_over_contrast(self) -> np.ndarray:
        """L_sky / dLq, response weighted, per range (the Fig. 12 path-radiance amplifier)."""
        return float(np.sum(self.k_spec * self.sky)) / self.intensity_e()

    @property
    def transmission_contrast(self) -> np.ndarray:
        """The band transmission per range weighted by the response and a near-ambient
        target's thermal contrast at the air temperature, in the units the signal is
        integrated in (Eq. 2): photons, dLq/dT, for the photon detector and the bolometer
        alike (the model's bolometer signal is absorbed photons x absorptance,
        :mod:`snrmon.model.detector`). Weighted in power (dL/dT), as it once was for the
        bolometer, the LWIR preset's read 1.0 % high at 1.5 km in humid air (30 C, 90 %) and
        0.6 % low in the default air (tests/model/test_continuous.py). It sets the optical
        depth of the uncertainty band (paper section 9), not the signal."""
        from snrmon.model.radiometry import spectral_photon_radiance_dt

        w = self.k_spec * spectral_photon_radiance_dt(self.wavelengths_um, self.air_temp_k)
        return self.tau @ (w / np.sum(w))

    @property
    def transmission_flat(self) -> np.ndarray:
        """The band transmission per range, flat in wavelength over the band."""
        w = self.quadrature_weights
        return self.tau @ (w / np.sum(w))

    @property
    def quadrature_weights(self) -> np.ndarray:
        from snrmon.model.radiometry import band_nodes

        return band_nodes(self.band_um, len(self.wavelengths_um))[1]


_TAU: dict[tuple, np.ndarray] = {}
_TAU_KEPT = 8


def _signal_transmission(atm: Atmosphere, ranges_m: np.ndarray, wl: np.ndarray, w: np.ndarray):
    """:meth:`Atmosphere.signal_transmission` at ``ranges_m``, kept per atmosphere and range
    grid: a new sky temperature on the same path does not change it."""
    key = (atm, ranges_m.tobytes(), wl.tobytes(), w.tobytes())
    tau = _TAU.get(key)
    if tau is None:
        tau = np.asarray(atm.signal_transmission(ranges_m, wl, w), dtype=float)
        tau.setflags(write=False)
        if len(_TAU) >= _TAU_KEPT:
            _TAU.pop(next(iter(_TAU)), None)  # the oldest
        _TAU[key] = tau
    return tau


def contrast(
    sensor: Sensor,
    target: Target,
    ranges_m: np.ndarray,
    *,
    atmosphere=None,
    sky_temp_k: float | None = None,
    air_temp_k: float | None = None,
) -> Contrast:
    """The :class:`Contrast` of ``target`` seen by ``sensor`` at ``ranges_m`` (module
    docstring). ``sky_temp_k``: the measured (apparent) sky temperature, None for the model's own
    (the infinite path at the air temperature); ``air_temp_k``: None for the atmosphere's."""
    atm = resolve_atmosphere(atmosphere, (float(sensor.band_um[0]), float(sensor.band_um[1])))
    wl, w, resp = spectral_grid(sensor)
    t_target = target.temp_k(band_key(sensor.band_um))
    if air_temp_k is not None:
        t_air = _check_temp("air temperature", air_temp_k)
        source_air = spectral_photon_radiance(wl, t_air)
    elif atm.spectral is not None and atm.spectral.has_radiance:
        t_air = atm.air_temp_k
        source_air = atm.path_source_photon(wl, w)
    else:
        t_air = atm.air_temp_k
        source_air = spectral_photon_radiance(wl, t_air)
    if sky_temp_k is not None:
        t_sky = _check_temp("background (sky) temperature", sky_temp_k)
        sky = spectral_photon_radiance(wl, t_sky)
    else:
        t_sky, sky = t_air, source_air
    ranges = np.asarray(ranges_m, dtype=float)
    band = (float(sensor.band_um[0]), float(sensor.band_um[1]))
    return Contrast(
        atmosphere=atm,
        sky_temp_k=t_sky,
        air_temp_k=t_air,
        target_temp_k=t_target,
        ranges_m=ranges,
        band_um=band,
        tau=_signal_transmission(atm, ranges, wl, w),
        k_spec=sensor.aperture_area_m2 * sensor.t_int_s * w * resp,
        wavelengths_um=wl,
        source_air=source_air,
        sky=sky,
        sky_assumed=sky_temp_k is None,
    )
