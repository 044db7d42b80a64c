"""Atmospheric transmission and path radiance along a horizontal path (paper sections 8-9).

An :class:`Atmosphere` is spectral, one of

* the built-in LOWTRAN7 table for the day's weather (:mod:`snrmon.model.atmosphere_table`: air
  temperature, humidity, pressure, visibility and aerosol, the season's standard atmosphere for
  the readings not given; by default the US Standard 1976 atmosphere's sea-level air and
  LOWTRAN7's rural aerosol at 23 km), at any path length;
* a file's spectrum (MODTRAN tape7 or CSV, :mod:`snrmon.model.modtran`) of one path length
  L0, moved to other ranges per spectral sample along the LOWTRAN7 table's curve of growth
  (up to 300 x L0), or one tape7 per range, interpolated per sample between them;

or grey (no spectrum: transmission 1, "none"); any of them times a constant transmission
``constant_tau`` and a grey aerosol factor exp(-beta R_km) (user parameters).

The model integrates over the band on quadrature nodes; each node's transmission is the
spectrum's AVERAGE over the node's cell (:mod:`snrmon.model.spectral_bins`), not a sample of it.
A target's signal is tau x (L_target - L_path source) integrated over the band with the camera's
response (:mod:`snrmon.model.contrast`), so the transmission that multiplies it is weighted by
that contrast spectrum at every standard atmosphere and weather: where the mid-wave CO2 band eats
the strongest part of a warm target's contrast the weighted value is 7-14 % below the flat
band average. :meth:`Atmosphere.contrast_transmission` gives the band's value weighted by the
thermal contrast of a near-ambient target (dLq/dT at the air temperature, photon units: the
units in which the model integrates every detector's signal, the bolometer's included; dL/dT,
power, on request), the number to quote beside the flat :meth:`transmission`.

Path radiance is (1 - tau) L(T_path) per spectral cell: T_path is the air temperature unless
the paper's correction is applied (a measured sky/background temperature, see
:mod:`snrmon.model.snr`); for a homogeneous horizontal path this is what LOWTRAN7's radiance
mode computes (the table's test checks it). With a MODTRAN radiance run the cell's effective
source function avg(PTH_THRML) / avg(1 - tau(L0)) is used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from snrmon.model.atmosphere_table import SEASONS, TablePath, Weather
from snrmon.model.modtran import SpectralPath
from snrmon.model.spectral_bins import cell_averaging

US_STD_AIR_TEMP_K = 288.15
"""US Standard Atmosphere 1976 sea-level temperature."""

BAND_EDGES_UM = {"mwir": (3.0, 5.6), "lwir": (7.5, 14.0)}
TABLE_WINDOWS_UM = ((3.0, 6.0), (7.49, 12.5))  # what the built-in LOWTRAN7 table covers
RANGE_NODES = 96  # more ranges than this: computed at this many and interpolated


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


def _check_table_band(band_um: tuple[float, float]) -> tuple[float, float]:
    lo, hi = float(band_um[0]), float(band_um[1])
    if not any(a - 1e-9 <= lo < hi <= b + 1e-9 for a, b in TABLE_WINDOWS_UM):
        raise ValueError(
            f"band {lo}-{hi} um is outside the built-in atmosphere table (LOWTRAN7, MWIR "
            "3.0-6.0 um, LWIR 7.49-12.5 um); give a MODTRAN file or a constant transmission"
        )
    return lo, hi


SpectrumSource = SpectralPath | TablePath


@dataclass(frozen=True)
class Atmosphere:
    """A horizontal-path atmosphere for one sensor band (see the module docstring)."""

    name: str = "none"
    constant_tau: float = 1.0
    aerosol_beta_per_km: float = 0.0
    air_temp_k: float = US_STD_AIR_TEMP_K
    spectral: SpectrumSource | None = None
    source: str = ""
    band_um: tuple[float, float] | None = None
    weather: Weather | None = None  # the met readings behind a LOWTRAN7 table atmosphere

    def __post_init__(self) -> None:
        if not 0.0 <= self.constant_tau <= 1.0:
            raise ValueError(
                f"atmosphere transmission must be in [0, 1], got {self.constant_tau!r}"
            )
        if self.aerosol_beta_per_km < 0:
            raise ValueError(f"aerosol beta must be >= 0 /km, got {self.aerosol_beta_per_km!r}")
        if not self.air_temp_k > 0:
            raise ValueError(f"air temperature must be > 0 K, got {self.air_temp_k!r}")

    def _grey(self, range_m) -> np.ndarray:
        r_km = _check_ranges(range_m) / 1e3
        return self.constant_tau * np.exp(-self.aerosol_beta_per_km * r_km)

    def spectral_transmission(self, range_m, wavelengths_um, weights_um=None) -> np.ndarray:
        """tau(R, lambda) (n_ranges, n_wavelengths): at each node the spectrum's average over
        the node's cell (the quadrature's when ``weights_um`` are given)."""
        tau = np.atleast_1d(self._grey(range_m))[:, None]
        wl = np.atleast_1d(np.asarray(wavelengths_um, dtype=float))
        if self.spectral is None:
            return np.broadcast_to(tau, (tau.shape[0], wl.size)).copy()
        if wl.size == 1:
            return tau * self.spectral.transmission_at_ranges(
                np.atleast_1d(range_m), np.array([_nearest(self.spectral.wavelength_um, wl[0])])
            )
        cols, avg = cell_averaging(self.spectral, wl, weights_um)
        r = np.atleast_1d(_check_ranges(range_m))
        pos = r[r > 0]
        if pos.size <= RANGE_NODES:
            binned = self.spectral.transmission_at_ranges(r, cols) @ avg.T
            return tau * binned
        # Many ranges: exact at RANGE_NODES log-spaced ranges, ln(tau) linear in ln(R) between
        # (smooth there: |error| < 2e-4 in tau, tested)
        nodes = np.geomspace(pos.min(), pos.max(), RANGE_NODES)
        ln_t = np.log(np.maximum(self.spectral.transmission_at_ranges(nodes, cols) @ avg.T, 1e-300))
        x = np.log(nodes)
        lr = np.log(np.maximum(r, pos.min()))
        i = np.clip(np.searchsorted(x, lr) - 1, 0, x.size - 2)
        f = ((lr - x[i]) / (x[i + 1] - x[i]))[:, None]
        binned = np.exp(ln_t[i] + f * (ln_t[i + 1] - ln_t[i]))
        binned[r <= 0] = 1.0
        return tau * binned

    def signal_transmission(self, range_m, wavelengths_um, weights_um=None) -> np.ndarray:
        """tau(R, lambda) to apply to a target's contrast spectrum (the spectral transmission:
        the contrast integral weights it)."""
        return self.spectral_transmission(range_m, wavelengths_um, weights_um)

    def _band(self, band_um) -> tuple[float, float]:
        band = band_um if band_um is not None else self.band_um
        if band is None:
            if self.spectral is None:
                return (3.0, 5.0)  # grey: any band gives the same average
            raise ValueError("a spectral atmosphere needs the band to average over")
        return float(band[0]), float(band[1])

    def transmission(self, range_m, band_um: tuple[float, float] | None = None):
        """Band-averaged transmission, flat in wavelength, at ``range_m`` (scalar or array);
        ``band_um`` defaults to the atmosphere's own band."""
        from snrmon.model.radiometry import band_nodes

        if self.spectral is None:
            out = self._grey(range_m)
        else:
            wl, w = band_nodes(self._band(band_um))
            out = self.spectral_transmission(range_m, wl, w) @ w / np.sum(w)
            out = out if np.ndim(range_m) else out[0]
        return float(out) if np.ndim(out) == 0 else out

    def contrast_transmission(
        self, range_m, band_um: tuple[float, float] | None = None, *, photon: bool = True
    ):
        """Band transmission weighted by a near-ambient target's thermal contrast: dLq/dT
        (``photon``) or dL/dT at the air temperature over the band (module docstring)."""
        from snrmon.model.radiometry import (
            band_nodes,
            spectral_photon_radiance_dt,
            spectral_radiance_dt,
        )

        if self.spectral is None:
            out = self._grey(range_m)
            return float(out) if np.ndim(out) == 0 else out
        wl, w = band_nodes(self._band(band_um))
        d = (spectral_photon_radiance_dt if photon else spectral_radiance_dt)(wl, self.air_temp_k)
        k = w * d
        out = self.spectral_transmission(range_m, wl, w) @ k / np.sum(k)
        return float(out[0]) if np.ndim(range_m) == 0 else out

    def path_source_photon(self, wavelengths_um, weights_um=None) -> np.ndarray:
        """The path's source function per node [ph s^-1 m^-2 sr^-1 um^-1]: a MODTRAN radiance
        run's avg(PTH_THRML) / avg(1 - tau(L0)) over each cell, else a blackbody at the air
        temperature."""
        from snrmon.model.radiometry import spectral_photon_radiance

        wl = np.asarray(wavelengths_um, dtype=float)
        sp = self.spectral
        if isinstance(sp, SpectralPath) and sp.has_radiance:
            return sp.path_source_photon(wl, weights_um)
        return spectral_photon_radiance(wl, self.air_temp_k)

    def path_photon_radiance(
        self, range_m, wavelengths_um, *, path_temp_k: float | None = None, weights_um=None
    ) -> np.ndarray:
        """Spectral path photon radiance [ph s^-1 m^-2 sr^-1 um^-1], shape (n_ranges, n_wl):
        (1 - tau) times the source function (a blackbody at ``path_temp_k``, default the air
        temperature; or MODTRAN's when no path temperature is forced)."""
        from snrmon.model.radiometry import spectral_photon_radiance

        wl = np.asarray(wavelengths_um, dtype=float)
        tau = self.spectral_transmission(range_m, wl, weights_um)
        if path_temp_k is None:
            source = self.path_source_photon(wl, weights_um)
        else:
            source = spectral_photon_radiance(wl, path_temp_k)
        return (1.0 - tau) * source[None, :]

    def path_radiance(self, range_m, band_um: tuple[float, float], **kw) -> np.ndarray | float:
        """In-band path radiance [W m^-2 sr^-1] at each range (photon radiance times hc/lambda)."""
        from snrmon.model.constants import C, H
        from snrmon.model.radiometry import band_nodes

        wl, w = band_nodes(tuple(map(float, band_um)))
        lq = self.path_photon_radiance(range_m, wl, weights_um=w, **kw)
        out = lq @ (w * H * C / (wl * 1e-6))
        return out if np.ndim(range_m) else float(out[0])

    def with_aerosol(self, beta_per_km: float) -> Atmosphere:
        """This atmosphere with an extra Beer-Lambert aerosol factor exp(-beta R_km)."""
        return replace(self, aerosol_beta_per_km=float(beta_per_km))


def _nearest(grid: np.ndarray, x: float) -> int:
    return int(np.argmin(np.abs(np.asarray(grid) - x)))


def weather_atmosphere(band_um: tuple[float, float], weather: Weather) -> Atmosphere:
    """The built-in LOWTRAN7 table for ``weather`` over ``band_um``."""
    band = _check_table_band(band_um)
    t_k = weather.state()[0]
    return Atmosphere(
        name=f"LOWTRAN7 {weather.season}: {weather.describe()}",
        air_temp_k=t_k,
        spectral=TablePath(weather),
        source="LOWTRAN7 table (model/tables/lowtran7_horizontal.npz): spectral, per-bin "
        "averaged, contrast-weighted by the signal integral",
        band_um=band,
        weather=weather,
    )


def default_atmosphere(band_um: tuple[float, float], model: str = "us_std_1976") -> Atmosphere:
    """The built-in default: the LOWTRAN7 table at the standard atmosphere's sea-level air
    (``model``, a season: :data:`snrmon.model.atmosphere_table.SEASONS`) with LOWTRAN7's rural
    aerosol at 23 km visibility (:data:`snrmon.model.atmosphere_table.DEFAULT_VISIBILITY_KM`)."""
    if model not in SEASONS:
        raise ValueError(f"unknown standard atmosphere {model!r}; known: {', '.join(SEASONS)}")
    return weather_atmosphere(band_um, Weather(season=model))


def no_atmosphere() -> Atmosphere:
    """Transmission 1, no path radiance."""
    return Atmosphere(name="none", source="tau = 1")


def resolve_atmosphere(spec, band_um: tuple[float, float]) -> Atmosphere:
    """None or "default" -> :func:`default_atmosphere`; a :class:`Weather` -> the table for
    it; a season name -> its standard atmosphere; "none" -> no atmosphere; a number -> a
    constant transmission; an :class:`Atmosphere` as is; anything else is a file path (TOML
    atmosphere, MODTRAN tape7 or CSV, see :mod:`snrmon.model.presets`)."""
    if spec is None or (isinstance(spec, str) and spec == "default"):
        return default_atmosphere(band_um)
    if isinstance(spec, Atmosphere):
        return spec
    if isinstance(spec, Weather):
        return weather_atmosphere(band_um, spec)
    if isinstance(spec, str) and spec == "none":
        return no_atmosphere()
    if isinstance(spec, str) and spec in SEASONS:
        return default_atmosphere(band_um, spec)
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
    integrals): the spectrum's own samples inside the band (a LOWTRAN7 table's 5 cm^-1 grid,
    a MODTRAN run's), each sample's transmission at this range times the grey factors; a
    MODTRAN radiance run's path radiance at each sample is its source function PTH_THRML /
    (1 - tau(L0)) times (1 - tau(R)). A band model without spectral data gives its band value
    on a :data:`BAND_MODEL_STEP_CM1` grid."""
    lo, hi = float(band_um[0]), float(band_um[1])
    r = float(_check_ranges(range_m))
    grey = float(np.atleast_1d(atm._grey(r))[0])
    sp = atm.spectral
    path = None
    if sp is not None:
        wl_all = np.asarray(sp.wavelength_um, dtype=float)
        cols = np.flatnonzero((wl_all >= lo) & (wl_all <= hi))
        if cols.size < 2:
            raise ValueError(f"{atm.name}: fewer than 2 spectral points in {lo}-{hi} um")
        wl = wl_all[cols]
        tau = grey * sp.transmission_at_ranges(np.array([r]), cols)[0]
        if isinstance(sp, SpectralPath) and sp.has_radiance:
            assert sp.path_radiance is not None  # has_radiance says so
            t0 = np.clip(np.asarray(sp.transmission, dtype=float)[cols], 0.0, 1.0)
            emitted = np.asarray(sp.path_radiance, dtype=float)[cols]
            source_w = np.where(1.0 - t0 > 1e-6, emitted / np.maximum(1.0 - t0, 1e-6), 0.0)
            path = (1.0 - tau) * source_w
    else:
        wn = np.arange(1e4 / hi, 1e4 / lo + 0.5 * BAND_MODEL_STEP_CM1, BAND_MODEL_STEP_CM1)
        wl = np.clip(np.sort(1e4 / wn), lo, hi)  # the ends exactly on the band's edges
        tau = np.full(wl.size, grey)
    return LineOfSight(r, wl, tau, path, float(atm.air_temp_k), sp is not None)
