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
from dataclasses import asdict, dataclass

import numpy as np

from snrmon.model.constants import ZERO_C_K


@dataclass(frozen=True, slots=True)
class FlirCalibration:
    """The calibration and measurement conditions a FLIR frame carries (units in the names;
    temperatures in kelvin, as the file stores them)."""

    planck_r1: float
    planck_r2: float
    planck_b: float
    planck_f: float
    planck_o: float
    emissivity: float
    object_distance_m: float
    reflected_temp_k: float
    atmospheric_temp_k: float
    ir_window_temp_k: float
    ir_window_transmission: float
    relative_humidity: float  # a ratio, 0-1
    atm_trans_alpha1: float
    atm_trans_alpha2: float
    atm_trans_beta1: float
    atm_trans_beta2: float
    atm_trans_x: float

    def attrs(self) -> dict[str, float]:
        """The constants as a DataArray's attributes (plain floats, names as the fields)."""
        return {k: float(v) for k, v in asdict(self).items()}

    def blackbody_counts(self, temp_k: float) -> float:
        """``S(T) = R1 / (R2 (exp(B / T) - F)) - O``: the counts of a blackbody at ``temp_k``."""
        return (
            self.planck_r1 / (self.planck_r2 * (math.exp(self.planck_b / temp_k) - self.planck_f))
            - self.planck_o
        )

    def path_transmission(self) -> float:
        """The atmosphere's transmission over half the object distance (FLIR's two-band model;
        module docstring)."""
        t_c = self.atmospheric_temp_k - ZERO_C_K
        water = self.relative_humidity * math.exp(
            1.5587 + 0.06939 * t_c - 0.00027816 * t_c**2 + 0.00000068455 * t_c**3
        )
        root_d = math.sqrt(self.object_distance_m / 2.0)
        root_h = math.sqrt(water)
        x = self.atm_trans_x
        return x * math.exp(-root_d * (self.atm_trans_alpha1 + self.atm_trans_beta1 * root_h)) + (
            1.0 - x
        ) * math.exp(-root_d * (self.atm_trans_alpha2 + self.atm_trans_beta2 * root_h))

    def object_signal(self, raw: np.ndarray) -> np.ndarray:
        """``S_obj`` of every pixel (float64): the raw counts less the reflected, atmospheric
        and window contributions, divided by the emissivity and the transmissions."""
        e, w = self.emissivity, self.ir_window_transmission
        tau = self.path_transmission()
        atm = self.blackbody_counts(self.atmospheric_temp_k)
        through = e * tau * w * tau
        offset = (
            (1.0 - e) / e * self.blackbody_counts(self.reflected_temp_k)
            + (1.0 - tau) / (e * tau) * atm
            + (1.0 - w) / (e * tau * w) * self.blackbody_counts(self.ir_window_temp_k)
            + (1.0 - tau) / through * atm
        )
        return np.asarray(raw, dtype=np.float64) / through - offset

    def temperature_k(self, signal: np.ndarray) -> np.ndarray:
        """``T = B / ln(R1 / (R2 (S + O)) + F)`` of an object signal (NaN where the signal
        is below what any temperature gives)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = self.planck_r1 / (self.planck_r2 * (np.asarray(signal) + self.planck_o))
            temp = self.planck_b / np.log(ratio + self.planck_f)
        return np.where((ratio > 0) & np.isfinite(temp) & (temp > 0), temp, np.nan)

    def temperature_c(self, raw: np.ndarray) -> np.ndarray:
        """The object temperature [degC] of raw counts (module docstring)."""
        return self.temperature_k(self.object_signal(raw)) - ZERO_C_K
