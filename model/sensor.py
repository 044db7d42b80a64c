"""The camera description the model works from (paper Table 1 plus the detector parameters the
paper does not give; presets in ``model/presets/*.toml``, documented in docs/model.md)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from snrmon.model.psf import AiryGaussianPsf, AiryPsf, GaussianPsf, Psf

DETECTOR_KINDS = ("photon", "bolometer")
REAL_PSF_KINDS = ("airy", "gaussian", "airy+gaussian")


@dataclass(frozen=True)
class Sensor:
    """A staring IR camera. Lengths as named; temperatures in kelvin.

    ``detector``: "photon" (cooled photon counter; Eq. 1 shot noise) or "bolometer" (uncooled;
    temporal noise from ``netd_mk``, signal in equivalent electrons, see docs/model.md).
    ``qe`` is a flat quantum efficiency (absorptance for a bolometer) unless ``qe_curve`` gives
    ((wavelength_um, qe), ...) pairs. ``real_psf``: the measured ("real") PSF of the corrected
    curves: "airy" (diffraction limited), "gaussian" or "airy+gaussian" with ``real_psf_sigma_px``
    or, if that is None, the blur solved from ``real_psf_average_pvf``.
    """

    name: str
    band_um: tuple[float, float]
    pitch_um: float
    fill_factor: float
    focal_length_m: float
    f_number: float
    width_px: int
    height_px: int
    fps: float
    netd_mk: float
    t_int_s: float
    gain_e_per_dn: float
    dn_offset: float = 0.0
    bit_depth: int = 14
    detector: str = "photon"
    qe: float = 0.6
    qe_curve: tuple[tuple[float, float], ...] = ()
    tau_optics: float = 0.8
    tau_cold_filter: float = 1.0
    read_noise_e: float = 0.0
    dark_current_a_per_cm2: float = 0.0
    well_capacity_e: float = math.inf
    lens_temp_k: float = 293.15
    lens_emissivity: float = 0.0
    cold_shield_temp_k: float = 80.0
    netd_reference_temp_k: float = 300.0
    real_psf: str = "airy"
    real_psf_sigma_px: float | None = None
    real_psf_average_pvf: float | None = None
    fov_deg: tuple[float, float] | None = None
    description: str = ""

    @property
    def ifov_rad(self) -> float:
        """Pixel pitch over focal length [rad]."""
        return self.pitch_um * 1e-6 / self.focal_length_m

    @property
    def aperture_diameter_m(self) -> float:
        """Entrance pupil diameter f / F#."""
        return self.focal_length_m / self.f_number

    @property
    def aperture_area_m2(self) -> float:
        """A_opt of Eq. 2."""
        return math.pi * self.aperture_diameter_m**2 / 4.0

    @property
    def detector_area_m2(self) -> float:
        """Active area FF p^2 (FF is an area fill factor)."""
        return self.fill_factor * (self.pitch_um * 1e-6) ** 2

    @property
    def f_lambda_over_d(self) -> float:
        """F lambda / pitch at the band centre (Table 1's last row)."""
        return self.f_number * 0.5 * (self.band_um[0] + self.band_um[1]) / self.pitch_um

    @property
    def full_scale_dn(self) -> int:
        return (1 << int(self.bit_depth)) - 1

    def qe_at(self, wl_um: np.ndarray) -> np.ndarray:
        """QE(lambda) (flat ``qe`` unless ``qe_curve`` is given; linear interpolation)."""
        wl = np.asarray(wl_um, dtype=float)
        if not self.qe_curve:
            return np.full(wl.shape, float(self.qe))
        c = np.asarray(self.qe_curve, dtype=float)
        return np.interp(wl, c[:, 0], c[:, 1], left=0.0, right=0.0)

    def diffraction_psf(self) -> AiryPsf:
        """Diffraction-limited PSF of the uncorrected curves: Airy averaged over the band,
        weighted by the signal spectrum (:func:`signal_weighted_airy`)."""
        return signal_weighted_airy(
            self.f_number, self.pitch_um, tuple(self.band_um), tuple(self.qe_curve)
        )

    @property
    def corrected_psf_source(self) -> str:
        """Which real PSF the corrected curves use when no PSF was measured (paper section 8),
        in words for a display: "preset: PVF 0.082 (sensor mwir)" where the blur is solved
        from the sensor's average PVF, "preset: airy+gaussian sigma 0.8 px (sensor ...)" where
        it is given, "preset: diffraction limited (sensor ...)"."""
        if self.real_psf == "airy":
            what = "diffraction limited"
        elif self.real_psf_sigma_px is not None:
            what = f"{self.real_psf} sigma {self.real_psf_sigma_px:g} px"
        else:
            what = f"PVF {self.real_psf_average_pvf:g}"
        return f"preset: {what} (sensor {self.name})"

    def corrected_psf(self) -> Psf:
        """The "real" PSF of the corrected curves (paper section 8)."""
        return _real_psf(self)


SIGNAL_SPECTRUM_TEMP_K = 300.0
"""The thermal contrast dLq/dT is taken at 300 K: a near-ambient drone against a near-ambient
sky (the atmosphere's contrast-weighted transmission uses the same spectrum)."""
N_AIRY_WAVELENGTHS = 15


@functools.lru_cache(maxsize=32)
def signal_weighted_airy(
    f_number: float,
    pitch_um: float,
    band_um: tuple[float, float],
    qe_curve: tuple[tuple[float, float], ...] = (),
) -> AiryPsf:
    """The diffraction PSF of a camera over its band as its signal sees it: the Airy pattern at
    15 wavelengths, each weighted by the photons a small thermal contrast puts there through the
    response, dLq/dT(lambda, 300 K) QE(lambda) (flat ``qe`` if no ``qe_curve``; the flat
    optics and cold-filter transmissions drop out). A flat average over the band gives the
    long, wide-Airy end of a MWIR band too little weight: average PVF 0.2653 flat, 0.2414
    weighted (MWIR preset); in the LWIR the two agree within 0.1 % (docs/model.md)."""
    from snrmon.model.psf import band_wavelengths_um
    from snrmon.model.radiometry import spectral_photon_radiance_dt

    wl = band_wavelengths_um(band_um, N_AIRY_WAVELENGTHS)
    qe = np.ones_like(wl)
    if qe_curve:
        c = np.asarray(qe_curve, dtype=float)
        qe = np.interp(wl, c[:, 0], c[:, 1], left=0.0, right=0.0)
    weights = spectral_photon_radiance_dt(wl, SIGNAL_SPECTRUM_TEMP_K) * qe
    return AiryPsf.polychromatic(f_number, pitch_um, band_um, N_AIRY_WAVELENGTHS, weights)


@functools.lru_cache(maxsize=32)
def _real_psf(sensor: Sensor) -> Psf:
    from snrmon.model.pvf import solve_blur_sigma

    airy = sensor.diffraction_psf()
    if sensor.real_psf == "airy":
        return airy
    sigma = sensor.real_psf_sigma_px
    if sigma is None:
        if sensor.real_psf_average_pvf is None:
            raise ValueError(
                f"sensor {sensor.name!r}: a {sensor.real_psf!r} PSF needs real_psf_sigma_px or "
                "real_psf_average_pvf"
            )
        base = airy if sensor.real_psf == "airy+gaussian" else None
        sigma = solve_blur_sigma(sensor.real_psf_average_pvf, sensor.fill_factor, base_psf=base)
    if sensor.real_psf == "gaussian":
        return GaussianPsf(float(sigma))
    return AiryGaussianPsf(airy, float(sigma))
