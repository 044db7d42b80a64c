"""A FLIR radiometric camera's own calibration: raw counts to object signal and temperature.

FLIR writes, with every radiometric frame (FFF, SEQ, CSQ, radiometric JPEG), the constants of
its factory calibration (Planck R1, R2, B, F, O) and the measurement conditions the operator set
(emissivity, reflected apparent temperature, atmospheric temperature, relative humidity, object
distance, the IR window's temperature and transmission) with the five constants of its
atmospheric transmission model. The relations below are FLIR's, as exiftool's FLIR notes,
Thermimage's ``raw2temp`` and flirpy publish them (docs/measurement.md, "FLIR raw counts to
temperature"):

* a blackbody at temperature T [K] reads ``S(T) = R1 / (R2 (exp(B / T) - F)) - O`` counts, and
  inversely ``T = B / ln(R1 / (R2 (S + O)) + F)``;
* the atmosphere's transmission over the object distance d [m] at water vapour content
  ``h = RH exp(1.5587 + 0.06939 t - 0.00027816 t^2 + 0.00000068455 t^3)`` (t the atmospheric
  temperature [degC], RH a ratio) is
  ``tau = X exp(-sqrt(d/2) (a1 + b1 sqrt(h))) + (1 - X) exp(-sqrt(d/2) (a2 + b2 sqrt(h)))``
  for each half of the path, an IR window (if any) at the middle;
* the object signal removes what the camera sees that is not the object (the reflected
  surroundings, the two atmospheric paths, the window's emission) and undoes the object's
  emissivity and the paths' transmissions::

      S_obj = raw / (E tau1 W tau2) - (1 - E) / E S(T_refl) - (1 - tau1) / (E tau1) S(T_atm)
              - (1 - W) / (E tau1 W) S(T_win) - (1 - tau2) / (E tau1 W tau2) S(T_atm)

  (W the window's transmission, 1 without one); the object's temperature is then
  ``B / ln(R1 / (R2 (S_obj + O)) + F)``.

``S_obj`` is what :func:`snrmon.load_stack` calls "radiance": the object's radiance in the
camera's radiometric unit, the count a blackbody at the object's temperature would give seen at
emissivity 1 through a transparent path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import ClassVar

import numpy as np

from snrmon.model.constants import ZERO_C_K


@dataclass(frozen=True, slots=True)
class PlanckConstants:
    """FLIR's factory calibration: a blackbody at ``T`` [K] reads
    ``R1 / (R2 (exp(B / T) - F)) - O`` counts (module docstring)."""

    ATTR_PREFIX: ClassVar[str] = "planck_"

    r1: float
    r2: float
    b: float
    f: float
    o: float

    def blackbody_counts(self, temp_k: float) -> float:
        """``S(T) = R1 / (R2 (exp(B / T) - F)) - O``: the counts of a blackbody at ``temp_k``."""
        return self.r1 / (self.r2 * (math.exp(self.b / temp_k) - self.f)) - self.o

    def temperature_k(self, signal: np.ndarray) -> np.ndarray:
        """``T = B / ln(R1 / (R2 (S + O)) + F)`` of an object signal (NaN where the signal
        is below what any temperature gives)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = self.r1 / (self.r2 * (np.asarray(signal) + self.o))
            temp = self.b / np.log(ratio + self.f)
        return np.where((ratio > 0) & np.isfinite(temp) & (temp > 0), temp, np.nan)


@dataclass(frozen=True, slots=True)
class MeasurementConditions:
    """What the operator set on the camera for the object (units in the names; temperatures
    in kelvin, as the file stores them)."""

    ATTR_PREFIX: ClassVar[str] = ""

    emissivity: float
    object_distance_m: float
    reflected_temp_k: float
    atmospheric_temp_k: float
    ir_window_temp_k: float
    ir_window_transmission: float
    relative_humidity: float  # a ratio, 0-1


@dataclass(frozen=True, slots=True)
class AtmosphericTransmission:
    """The five constants of FLIR's two-band atmospheric transmission model (module
    docstring): ``tau = X exp(-sqrt(d) (a1 + b1 sqrt(h))) + (1 - X) exp(-sqrt(d) (a2 + b2
    sqrt(h)))`` over a path of ``d`` metres at water vapour content ``h``."""

    ATTR_PREFIX: ClassVar[str] = "atm_trans_"

    alpha1: float
    alpha2: float
    beta1: float
    beta2: float
    x: float

    def over(self, distance_m: float, air_temp_k: float, relative_humidity: float) -> float:
        """The transmission over ``distance_m`` of air at ``air_temp_k`` and
        ``relative_humidity`` (a ratio)."""
        t_c = air_temp_k - ZERO_C_K
        water = relative_humidity * math.exp(
            1.5587 + 0.06939 * t_c - 0.00027816 * t_c**2 + 0.00000068455 * t_c**3
        )
        root_d = math.sqrt(distance_m)
        root_h = math.sqrt(water)
        x = self.x
        return x * math.exp(-root_d * (self.alpha1 + self.beta1 * root_h)) + (1.0 - x) * math.exp(
            -root_d * (self.alpha2 + self.beta2 * root_h)
        )


@dataclass(frozen=True, slots=True)
class FlirCalibration:
    """The calibration and measurement conditions a FLIR frame carries: the camera's Planck
    constants, the conditions the operator set and the atmospheric model's constants."""

    planck: PlanckConstants
    conditions: MeasurementConditions
    atmosphere: AtmosphericTransmission

    def attrs(self) -> dict[str, float]:
        """The constants as a DataArray's attributes (plain floats), each named by its part's
        ``ATTR_PREFIX`` and its field (``planck_r1``, ``emissivity``, ``atm_trans_x``)."""
        out: dict[str, float] = {}
        for part in (self.planck, self.conditions, self.atmosphere):
            for f in fields(part):
                out[part.ATTR_PREFIX + f.name] = float(getattr(part, f.name))
        return out

    def blackbody_counts(self, temp_k: float) -> float:
        """The counts of a blackbody at ``temp_k`` (:meth:`PlanckConstants.blackbody_counts`)."""
        return self.planck.blackbody_counts(temp_k)

    def path_transmission(self) -> float:
        """The atmosphere's transmission over half the object distance (FLIR's two-band model;
        module docstring)."""
        c = self.conditions
        return self.atmosphere.over(
            c.object_distance_m / 2.0, c.atmospheric_temp_k, c.relative_humidity
        )

    def object_signal(self, raw: np.ndarray) -> np.ndarray:
        """``S_obj`` of every pixel (float64): the raw counts less the reflected, atmospheric
        and window contributions, divided by the emissivity and the transmissions."""
        c = self.conditions
        e, w = c.emissivity, c.ir_window_transmission
        tau = self.path_transmission()
        atm = self.blackbody_counts(c.atmospheric_temp_k)
        through = e * tau * w * tau
        offset = (
            (1.0 - e) / e * self.blackbody_counts(c.reflected_temp_k)
            + (1.0 - tau) / (e * tau) * atm
            + (1.0 - w) / (e * tau * w) * self.blackbody_counts(c.ir_window_temp_k)
            + (1.0 - tau) / through * atm
        )
        return np.asarray(raw, dtype=np.float64) / through - offset

    def temperature_k(self, signal: np.ndarray) -> np.ndarray:
        """The temperature [K] of an object signal (:meth:`PlanckConstants.temperature_k`)."""
        return self.planck.temperature_k(signal)

    def temperature_c(self, raw: np.ndarray) -> np.ndarray:
        """The object temperature [degC] of raw counts (module docstring)."""
        return self.temperature_k(self.object_signal(raw)) - ZERO_C_K
