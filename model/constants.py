"""Physical constants (SI 2019 exact values, CODATA 2018) used by the sensor model."""

from __future__ import annotations

import math

H = 6.62607015e-34
"""Planck constant [J s]."""
C = 299792458.0
"""Speed of light in vacuum [m/s]."""
K_B = 1.380649e-23
"""Boltzmann constant [J/K]."""
Q_E = 1.602176634e-19
"""Elementary charge [C]."""
SIGMA_SB = 2.0 * math.pi**5 * K_B**4 / (15.0 * H**3 * C**2)
"""Stefan-Boltzmann constant [W m^-2 K^-4], derived from the exact constants."""
C2 = H * C / K_B
"""Second radiation constant hc/k [m K]."""
ZERO_C_K = 273.15
"""0 degrees Celsius in kelvin."""
