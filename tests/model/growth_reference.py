"""The curve-of-growth move of a spectrum to another range (model/modtran.py), written apart
from the model's: each sample's equivalent path found by root-finding (scipy's brentq) on the
shipped LOWTRAN7 table's optical depth at that wavenumber (linear between the table's own
samples, never across a gap between its windows), read again at that path times R / L0;
Beer-Lambert outside the windows; a nearly opaque sample (tau < 1e-3) at its own path. The
model inverts a 40-per-decade grid of paths instead."""

import math

import numpy as np
from scipy.optimize import brentq

from snrmon.model.atmosphere_table import Weather, load_table


def _windows(nu: np.ndarray) -> list[np.ndarray]:
    """The table's runs of equally spaced samples."""
    gaps = np.flatnonzero(np.diff(nu) > 2.0 * np.median(np.diff(nu))) + 1
    return np.split(np.arange(nu.size), gaps)


def moved_reference(wl_um, tau0, path_m: float, range_m: float, weather=None) -> np.ndarray:
    """Each sample of transmission ``tau0`` over ``path_m`` moved to ``range_m``."""
    table, air = load_table(), weather or Weather()
    grid = table.wavenumber_cm1
    out = np.empty(len(tau0))
    for j, (wl, t) in enumerate(
        zip(np.asarray(wl_um, float), np.asarray(tau0, float), strict=True)
    ):
        nu = 1e4 / wl
        part = next((p for p in _windows(grid) if grid[p[0]] <= nu <= grid[p[-1]]), None)
        if part is None or not t < 1.0:
            out[j] = t ** (range_m / path_m) if t > 0 else 0.0
            continue

        def od(length_m: float, part=part, nu=nu) -> float:
            spectrum = table.optical_depth(air, np.array([length_m]))[0]
            return float(np.interp(nu, grid[part], spectrum[part]))

        if t < 1e-3:  # nearly opaque: its OD not read from it, the path taken as its own
            ln_eq = math.log(path_m)
        else:
            ln_target = math.log(-math.log(t))
            ln_eq = brentq(lambda x, y=ln_target: math.log(od(math.exp(x))) - y, -12.0, 18.0)
        out[j] = math.exp(-od(math.exp(ln_eq) * range_m / path_m))
    return out
