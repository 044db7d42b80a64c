"""The twin's own radiometry: from the day's temperatures and the atmosphere's spectral data to
electrons per pixel per frame, and each camera's temporal noise.

The simulated day has to test the model's radiometry (paper Eqs. 1-3), not repeat it, so none
of it is borrowed: an import-linter contract forbids ``sim`` the model's contrast, noise, SNR,
PVF, detector and radiometry code. What the twin shares with the model is DATA: the camera's
datasheet (the sensor preset: band, optics, QE, noise figures), the drone's temperature (the
target preset) and the atmosphere's spectral transmission and path radiance
(:func:`snrmon.model.atmosphere.line_of_sight`, the same tables or spectra the model reads),
plus the physical constants.

* Planck's law in photon units, written here (:func:`photon_radiance`, its temperature
  derivative :func:`photon_radiance_dt`).
* Band integrals as sums over the atmosphere data's own bins (:func:`spectral_bins`): each
  grid point stands for the bin between the midpoints to its neighbours, the band's edges
  clipping the first and last: the integration is at the table's resolution (a band model, the
  same value at every wavelength, comes on a 5 cm^-1 grid).
* One etendue for every source the pixel sees (:class:`TwinCamera`): the active area A_det = FF
  p^2 under an aperture of F-number F obeying the sine condition, pi / (4 F^2) sr projected.
  A drone's light through the aperture, A_opt x (target area / R^2), is the same geometry:
  for a pixel-filling drone it is A_det pi / (4 F^2) too, so the drone reads its own radiance
  through a calibration made on a blackbody. (The model uses the cone pi / (4 F^2 + 1) for its
  background: 4.5 % fewer MWIR sky electrons, 14 % fewer LWIR; docs/simulation.md.)
* Photon statistics: the pixel's charge is Poisson (variance = mean: the scene, the lens's and
  the cold shield's emission, dark current), plus read noise. The uncooled bolometer is no
  photon counter: its temporal noise is its NETD times its responsivity dN/dT to a
  pixel-filling blackbody at the NETD's reference temperature (300 K), of which the absorbed
  photons' own fluctuation is a (tiny) part; signal and noise are in equivalent electrons
  (absorbed photons x absorptance), the preset's scale.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from snrmon.model.constants import C2, Q_E, C, H

BOLOMETER = "bolometer"


def photon_radiance(wl_um, temp_k) -> np.ndarray:
    """Planck's spectral photon radiance [photons s^-1 m^-2 sr^-1 um^-1] at ``wl_um`` (array)
    and one temperature: 2 c / lambda^4 / (exp(hc / lambda k T) - 1)."""
    lam = np.asarray(wl_um, dtype=float) * 1e-6
    return 2.0 * C / lam**4 / np.expm1(C2 / (lam * float(temp_k))) * 1e-6


def photon_radiance_dt(wl_um, temp_k) -> np.ndarray:
    """d(photon_radiance)/dT [photons s^-1 m^-2 sr^-1 um^-1 K^-1]."""
    lam = np.asarray(wl_um, dtype=float) * 1e-6
    x = C2 / (lam * float(temp_k))
    return photon_radiance(wl_um, temp_k) * x / (-np.expm1(-x)) / float(temp_k)


def spectral_bins(wavelength_um, band_um: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """(centres, widths) [um] of the bins of a grid inside the band: each point's bin reaches
    halfway to its neighbours, the band's edges bound the first and the last."""
    wl = np.asarray(wavelength_um, dtype=float)
    lo, hi = float(band_um[0]), float(band_um[1])
    if wl.ndim != 1 or wl.size < 2 or np.any(np.diff(wl) <= 0):
        raise ValueError("a spectral grid needs >= 2 increasing wavelengths")
    if wl[0] < lo or wl[-1] > hi:
        raise ValueError(f"spectral grid {wl[0]}-{wl[-1]} um leaves the band {lo}-{hi} um")
    edges = np.concatenate([[lo], 0.5 * (wl[1:] + wl[:-1]), [hi]])
    return wl, np.diff(edges)


@dataclass(frozen=True)
class TwinCamera:
    """One twin camera's photon chain, from its datasheet (:meth:`from_sensor`). Lengths as
    named, temperatures in kelvin, QE as ((wavelength_um, qe), ...) or one flat value."""

    name: str
    band_um: tuple[float, float]
    pitch_um: float
    fill_factor: float
    focal_length_m: float
    f_number: float
    t_int_s: float
    detector: str
    qe: float
    qe_curve: tuple[tuple[float, float], ...]
    tau_optics: float
    tau_cold_filter: float
    lens_temp_k: float
    lens_emissivity: float
    cold_shield_temp_k: float
    dark_current_a_per_cm2: float
    read_noise_e: float
    netd_mk: float
    netd_reference_temp_k: float

    @classmethod
    def from_sensor(cls, sensor) -> TwinCamera:
        """The twin of a sensor preset (``model.presets.load_sensor``): its datasheet numbers."""
        return cls(
            name=str(sensor.name),
            band_um=(float(sensor.band_um[0]), float(sensor.band_um[1])),
            pitch_um=float(sensor.pitch_um),
            fill_factor=float(sensor.fill_factor),
            focal_length_m=float(sensor.focal_length_m),
            f_number=float(sensor.f_number),
            t_int_s=float(sensor.t_int_s),
            detector=str(sensor.detector),
            qe=float(sensor.qe),
            qe_curve=tuple(tuple(map(float, row)) for row in sensor.qe_curve),
            tau_optics=float(sensor.tau_optics),
            tau_cold_filter=float(sensor.tau_cold_filter),
            lens_temp_k=float(sensor.lens_temp_k),
            lens_emissivity=float(sensor.lens_emissivity),
            cold_shield_temp_k=float(sensor.cold_shield_temp_k),
            dark_current_a_per_cm2=float(sensor.dark_current_a_per_cm2),
            read_noise_e=float(sensor.read_noise_e),
            netd_mk=float(sensor.netd_mk),
            netd_reference_temp_k=float(sensor.netd_reference_temp_k),
        )

    # ------------------------------------------------------------------ geometry
    @property
    def detector_area_m2(self) -> float:
        """The active area FF p^2 (FF an area fill factor)."""
        return self.fill_factor * (self.pitch_um * 1e-6) ** 2

    @property
    def aperture_area_m2(self) -> float:
        return math.pi * (self.focal_length_m / self.f_number) ** 2 / 4.0

    @property
    def cone_sr(self) -> float:
        """Projected solid angle of the aperture seen from the detector, sine condition."""
        return math.pi / (4.0 * self.f_number**2)

    @property
    def ifov_rad(self) -> float:
        return self.pitch_um * 1e-6 / self.focal_length_m

    # ------------------------------------------------------------------ response
    def quantum_efficiency(self, wl_um) -> np.ndarray:
        wl = np.asarray(wl_um, dtype=float)
        if not self.qe_curve:
            return np.full(wl.shape, self.qe)
        c = np.asarray(self.qe_curve, dtype=float)
        return np.interp(wl, c[:, 0], c[:, 1], left=0.0, right=0.0)

    def _after_lens(self, wl_um) -> np.ndarray:
        """Photons to charge behind the lens: the cold filter (photon detector) and the QE."""
        cold = self.tau_cold_filter if self.detector != BOLOMETER else 1.0
        return cold * self.quantum_efficiency(wl_um)

    def response(self, wl_um) -> np.ndarray:
        """Photons at the aperture to charge: optics, cold filter, QE (absorptance)."""
        return self.tau_optics * self._after_lens(wl_um)

    def _grid(self, n: int = 400) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = self.band_um
        return spectral_bins(lo + (np.arange(n) + 0.5) * (hi - lo) / n, self.band_um)

    # ------------------------------------------------------------------ charge per frame
    def extended_electrons(self, wl_um, width_um, photon_radiance_at_aperture) -> float:
        """Charge from a scene of spectral photon radiance (per bin) filling the pixel's view."""
        k = self.detector_area_m2 * self.cone_sr * self.t_int_s
        return float(k * np.sum(self.response(wl_um) * photon_radiance_at_aperture * width_um))

    def blackbody_electrons(self, temp_k: float) -> float:
        """Charge from a blackbody at ``temp_k`` filling the view (no air between)."""
        wl, dw = self._grid()
        return self.extended_electrons(wl, dw, photon_radiance(wl, temp_k))

    def pedestal_electrons(self) -> float:
        """Charge whatever the scene: the lens's own emission into the cone, the cold shield's
        over the rest of the hemisphere (photon detector) and the dark current."""
        wl, dw = self._grid()
        k = self.detector_area_m2 * self.t_int_s
        lens = self.lens_emissivity * photon_radiance(wl, self.lens_temp_k)
        out = k * self.cone_sr * float(np.sum(self._after_lens(wl) * lens * dw))
        if self.detector != BOLOMETER:
            if self.cold_shield_temp_k > 0:
                shield = photon_radiance(wl, self.cold_shield_temp_k)
                rest = math.pi - self.cone_sr
                out += k * rest * float(np.sum(self.quantum_efficiency(wl) * shield * dw))
            amps = self.dark_current_a_per_cm2 * 1e4 * self.detector_area_m2
            out += amps * self.t_int_s / Q_E
        return out

    def pixel_electrons(self, scene_temp_k: float) -> float:
        """Charge of a pixel looking at a blackbody scene (the sky at its apparent
        temperature, a calibration source): scene plus pedestal."""
        return self.blackbody_electrons(scene_temp_k) + self.pedestal_electrons()

    def responsivity_e_per_k(self, temp_k: float) -> float:
        """dN/dT of a pixel-filling blackbody at ``temp_k``."""
        wl, dw = self._grid()
        k = self.detector_area_m2 * self.cone_sr * self.t_int_s
        return float(k * np.sum(self.response(wl) * photon_radiance_dt(wl, temp_k) * dw))

    # ------------------------------------------------------------------ noise
    def floor_noise_e(self) -> float:
        """Temporal noise [e-] that is not the pixel's own Poisson charge: read noise (photon
        detector); for the bolometer what its NETD leaves once the Poisson part of a pixel at
        the NETD's reference scene is taken out (module docstring)."""
        if self.detector != BOLOMETER:
            return self.read_noise_e
        netd_e = self.netd_mk * 1e-3 * self.responsivity_e_per_k(self.netd_reference_temp_k)
        poisson = self.pixel_electrons(self.netd_reference_temp_k)
        return math.sqrt(max(netd_e**2 - poisson, 0.0))

    def temporal_noise_e(self, pixel_e: float) -> float:
        """Temporal noise [e- rms] of a pixel holding ``pixel_e``: Poisson plus the floor."""
        return math.sqrt(self.floor_noise_e() ** 2 + max(float(pixel_e), 0.0))

    # ------------------------------------------------------------------ the drone
    def contrast_electrons(
        self,
        line,
        target_temp_k: float,
        sky_temp_k: float,
        target_area_m2: float,
    ) -> float:
        """The drone's contrast charge on the focal plane, all pixels together (PVF = 1): its
        light through the path ``line`` (:class:`snrmon.model.atmosphere.LineOfSight`), tau L_t
        plus what the path emits (the table's path radiance, else (1 - tau) B(T_air)), less the
        sky it hides, B(T_sky), through the aperture's solid angle from the drone,
        A_opt x area / R^2."""
        wl, dw = spectral_bins(line.wavelength_um, self.band_um)
        tau = np.asarray(line.transmission, dtype=float)
        if line.path_radiance_w is not None:
            # W -> photons: a photon of wavelength lambda carries h c / lambda
            path = np.asarray(line.path_radiance_w, dtype=float) * wl * 1e-6 / (C * H)
        else:
            path = (1.0 - tau) * photon_radiance(wl, line.air_temp_k)
        seen = tau * photon_radiance(wl, target_temp_k) + path - photon_radiance(wl, sky_temp_k)
        k = self.aperture_area_m2 * self.t_int_s * target_area_m2 / line.range_m**2
        return float(k * np.sum(self.response(wl) * seen * dw))
