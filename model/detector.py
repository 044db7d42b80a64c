"""Charge collected per pixel per frame from the scene, the lens, the cold shield and dark current
(the sources of paper Eq. 1), and the detector's response to scene temperature.

Geometry: background flux reaches the active area FF p^2 through the cold-shield cone of the
F-number, projected solid angle pi / (4F^2 + 1) (exact for a cone of half-angle
atan(1/2F)); target signals use A_opt x solid angle (Eq. 2, paraxial pi / 4F^2 per detector
area). The cold shield (photon detector) fills the rest of the hemisphere. For the uncooled
bolometer these are EQUIVALENT electrons (absorbed photons x absorptance ``qe``), the scale on
which :mod:`snrmon.model.noise` expresses its NETD-derived noise; it has no cold shield or dark
current.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from snrmon.model.constants import Q_E
from snrmon.model.radiometry import (
    band_nodes,
    spectral_photon_radiance,
    spectral_photon_radiance_dt,
)
from snrmon.model.sensor import Sensor

N_SPECTRAL = 48


def cone_projected_solid_angle(f_number: float) -> float:
    """pi sin^2(theta) with tan(theta) = 1 / 2F: pi / (4F^2 + 1) [sr]."""
    return math.pi / (4.0 * f_number**2 + 1.0)


@functools.lru_cache(maxsize=64)
def spectral_grid(sensor: Sensor) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Wavelength nodes [um], quadrature weights [um] and the photon response
    tau_optics tau_cold_filter QE(lambda) at the nodes."""
    wl, w = band_nodes(tuple(map(float, sensor.band_um)), N_SPECTRAL)
    resp = sensor.tau_optics * _cold_filter(sensor) * sensor.qe_at(wl)
    resp.setflags(write=False)
    return wl, w, resp


def _cold_filter(sensor: Sensor) -> float:
    return sensor.tau_cold_filter if sensor.detector == "photon" else 1.0


def _per_sr_to_e(sensor: Sensor, solid_angle_sr: float) -> float:
    return solid_angle_sr * sensor.detector_area_m2 * sensor.t_int_s


def scene_electrons(sensor: Sensor, scene_temp_k):
    """Electrons from a uniform blackbody scene at ``scene_temp_k`` filling the view (a float;
    an array for an array of temperatures)."""
    t = np.asarray(scene_temp_k, dtype=float)
    if not np.all((t > 0) & np.isfinite(t)):
        raise ValueError(f"scene temperature must be > 0 K, got {scene_temp_k!r}")
    wl, w, resp = spectral_grid(sensor)
    lq = spectral_photon_radiance(wl, t)  # (n_wl,) or (n_wl, n_temps)
    k = _per_sr_to_e(sensor, cone_projected_solid_angle(sensor.f_number))
    out = k * np.tensordot(w * resp, lq, axes=(0, 0))
    return float(out) if out.ndim == 0 else out


def lens_electrons(sensor: Sensor) -> float:
    """Electrons from the lens's own emission (emissivity x blackbody at the lens temperature)
    through the cold-filter and QE, over the same cone."""
    if sensor.lens_emissivity <= 0:
        return 0.0
    wl, w, _ = spectral_grid(sensor)
    lq = sensor.lens_emissivity * spectral_photon_radiance(wl, float(sensor.lens_temp_k))
    resp = _cold_filter(sensor) * sensor.qe_at(wl)
    k = _per_sr_to_e(sensor, cone_projected_solid_angle(sensor.f_number))
    return float(k * np.sum(w * resp * lq))


def cold_shield_electrons(sensor: Sensor) -> float:
    """Electrons from the cold shield's emission over the rest of the hemisphere (photon
    detector only; tiny at cryogenic temperatures)."""
    if sensor.detector != "photon" or sensor.cold_shield_temp_k <= 0:
        return 0.0
    wl, w, _ = spectral_grid(sensor)
    lq = spectral_photon_radiance(wl, float(sensor.cold_shield_temp_k))
    omega = math.pi - cone_projected_solid_angle(sensor.f_number)
    return float(_per_sr_to_e(sensor, omega) * np.sum(w * sensor.qe_at(wl) * lq))


def dark_electrons(sensor: Sensor) -> float:
    """Dark current x active area x integration time / q (photon detector only)."""
    if sensor.detector != "photon":
        return 0.0
    amps = sensor.dark_current_a_per_cm2 * 1e4 * sensor.detector_area_m2
    return amps * sensor.t_int_s / Q_E


def background_electrons(sensor: Sensor, scene_temp_k: float) -> float:
    """Per pixel per frame, everything but the target: scene + lens + cold shield + dark
    current (the pedestal whose shot noise enters Eq. 1; for a bolometer scene + lens, in
    equivalent electrons)."""
    return (
        scene_electrons(sensor, scene_temp_k)
        + lens_electrons(sensor)
        + cold_shield_electrons(sensor)
        + dark_electrons(sensor)
    )


def extended_responsivity_e_per_k(sensor: Sensor, scene_temp_k: float) -> float:
    """d(electrons)/dT for a pixel-filling blackbody scene at ``scene_temp_k`` seen with
    A_opt x pixel solid angle (the geometry of Eq. 2), no atmosphere: the NETD denominator."""
    _check_temp("scene temperature", scene_temp_k)
    wl, w, resp = spectral_grid(sensor)
    dlq = spectral_photon_radiance_dt(wl, float(scene_temp_k))
    k = sensor.aperture_area_m2 * sensor.fill_factor * sensor.ifov_rad**2 * sensor.t_int_s
    return float(k * np.sum(w * resp * dlq))


def well_fill(sensor: Sensor, scene_temp_k: float) -> float:
    """Fraction of the well used by the pedestal (photon detector; 0 if no well is given)."""
    if not math.isfinite(sensor.well_capacity_e):
        return 0.0
    return background_electrons(sensor, scene_temp_k) / sensor.well_capacity_e


def _check_temp(what: str, value: float) -> None:
    if not (value > 0 and math.isfinite(value)):
        raise ValueError(f"{what} must be > 0 K, got {value!r}")
