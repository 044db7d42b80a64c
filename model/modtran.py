"""Readers for MODTRAN output (tape7) and a plain CSV of spectral transmission/path radiance.

tape7 (format as documented by pyradi ``rymodtran.loadtape7``): header lines echo tape5; then a
column-header line containing ``FREQ``, the data rows, and a terminating ``-9999.`` line.

* transmittance runs (IEMSCT=0): TWO header lines, names joined with "_" (FREQ_CM-1,
  COMBIN_TRANS, ...);
* thermal radiance runs (IEMSCT=1/2): one header line, FREQ TOT_TRANS PTH_THRML ... TOTAL_RAD,
  radiances in W cm^-2 sr^-1 (cm^-1)^-1.

Headings can run together and some columns are blank, so column boundaries are taken from the
first data row (fields are right-aligned: a heading belongs to the data field whose right end is
nearest its right end). CSV: columns ``wavelength_um, transmission[, path_radiance]`` with path
radiance in W m^-2 sr^-1 um^-1; ``#`` comment lines allowed.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from snrmon.model.atmosphere_table import Weather
from snrmon.model.constants import C, H
from snrmon.model.spectral_bins import cell_averaging


@dataclass(frozen=True, eq=False)
class SpectralPath:
    """Spectral transmission (and optionally path radiance) of one path of ``path_length_m``.

    ``wavelength_um`` ascending; ``path_radiance`` in W m^-2 sr^-1 um^-1 (or None).
    """

    wavelength_um: np.ndarray
    transmission: np.ndarray
    path_length_m: float
    path_radiance: np.ndarray | None = None
    source: str = ""
    growth: Weather | None = None  # whose curve of growth moves it (None: the default air)
    # the same air computed at other path lengths (:meth:`at_ranges`), shortest first
    other_paths: tuple[SpectralPath, ...] = ()

    def __post_init__(self) -> None:
        wl = np.asarray(self.wavelength_um, dtype=float)
        tau = np.asarray(self.transmission, dtype=float)
        if wl.ndim != 1 or wl.size < 2 or tau.shape != wl.shape:
            raise ValueError(f"{self.source or 'spectrum'}: needs >= 2 rows of wavelength, tau")
        if np.any(np.diff(wl) <= 0):
            raise ValueError(f"{self.source or 'spectrum'}: wavelengths must increase")
        if np.any(tau < 0) or np.any(tau > 1.0 + 1e-6):
            raise ValueError(f"{self.source or 'spectrum'}: transmission outside [0, 1]")
        if not (self.path_length_m > 0 and math.isfinite(self.path_length_m)):
            raise ValueError(f"path length must be > 0 m, got {self.path_length_m!r}")

    @property
    def has_radiance(self) -> bool:
        return self.path_radiance is not None

    @property
    def grid_key(self) -> object:
        """Identifies the wavelength grid (the spectral-bin cache's key): this object's."""
        return ("spectral-path", id(self))

    def covers(self, band_um: tuple[float, float]) -> bool:
        return self.wavelength_um[0] <= band_um[0] and band_um[1] <= self.wavelength_um[-1]

    @classmethod
    def at_ranges(cls, paths, growth: Weather | None = None) -> SpectralPath:
        """One atmosphere's spectra computed at several path lengths (one tape7 per range, on
        one wavelength grid) as one spectral path: the longest, holding the others. Between
        two of them each sample's transmission is interpolated (:meth:`transmission_at_ranges`),
        beyond them the nearest is moved along the curve of growth."""
        ps = sorted(paths, key=lambda q: q.path_length_m)
        if not ps:
            raise ValueError("spectra at ranges: none given")
        lengths = [q.path_length_m for q in ps]
        if len(set(lengths)) < len(lengths):
            raise ValueError(f"spectra at ranges: two of one path length ({lengths} m)")
        for q in ps[1:]:
            same = q.wavelength_um.shape == ps[0].wavelength_um.shape and np.allclose(
                q.wavelength_um, ps[0].wavelength_um, rtol=1e-9
            )
            if not same:
                raise ValueError(
                    f"{q.source or 'spectrum'}: its wavelengths are not those of "
                    f"{ps[0].source or 'the first spectrum'}: spectra at ranges share one grid"
                )
        top = ps[-1]
        return cls(
            top.wavelength_um,
            top.transmission,
            top.path_length_m,
            top.path_radiance,
            " + ".join(q.source for q in ps if q.source),
            growth if growth is not None else top.growth,
            tuple(ps[:-1]),
        )

    def transmission_at_ranges(self, ranges_m, columns: np.ndarray | None = None) -> np.ndarray:
        """(n_ranges, n_samples) tau(R) at each spectral sample (or at the samples
        ``columns``). Between two of its path lengths (:meth:`at_ranges`) ln(tau) per sample
        is interpolated as a power of R (ln(-ln tau) linear in ln R: the band model's own
        growth, OD = (K rho L)^a, exact for one power; linear in R it read LOWTRAN7's 500 m
        MWIR band 2.3 % high from 200 and 1500 m, this 0.25 % low); beyond them the nearest
        spectrum is moved along the band model's curve of growth (:func:`moved_transmission`;
        ValueError past :data:`MAX_MOVE_FACTOR` x the longest path)."""
        r = np.atleast_1d(np.asarray(ranges_m, dtype=float))
        paths = (*self.other_paths, self)
        lengths = np.array([q.path_length_m for q in paths])

        def samples(q: SpectralPath) -> tuple[np.ndarray, np.ndarray]:
            t = q.transmission if columns is None else q.transmission[columns]
            w = q.wavelength_um if columns is None else q.wavelength_um[columns]
            return t, w

        out = np.empty((r.size, samples(self)[0].size))
        below, above = r <= lengths[0], r >= lengths[-1]
        for pick, q in ((below, paths[0]), (above & ~below, paths[-1])):
            if np.any(pick):
                t, w = samples(q)
                what = q.source or "spectrum"
                out[pick] = moved_transmission(t, w, q.path_length_m, r[pick], self.growth, what)
        between = ~(below | above)
        if np.any(between):
            ln_od = np.log(np.stack([_optical_depth(samples(q)[0]) for q in paths]))
            x = np.log(lengths)
            lr = np.log(r[between])
            i = np.clip(np.searchsorted(x, lr) - 1, 0, x.size - 2)
            f = ((lr - x[i]) / (x[i + 1] - x[i]))[:, None]
            out[between] = np.exp(-np.exp(ln_od[i] + f * (ln_od[i + 1] - ln_od[i])))
        return out

    def path_source_photon(self, wl_um, weights_um=None) -> np.ndarray:
        """Effective source function avg(PTH) / avg(1 - tau(L0)) over each node's cell
        (:mod:`snrmon.model.spectral_bins`), in photon units per um."""
        if self.path_radiance is None:
            raise ValueError("this MODTRAN table has no path radiance column")
        wl = np.atleast_1d(np.asarray(wl_um, dtype=float))
        if wl.size == 1:
            j = int(np.argmin(np.abs(self.wavelength_um - wl[0])))
            cols, avg = np.array([j]), np.ones((1, 1))
        else:
            cols, avg = cell_averaging(self, wl, weights_um)
        lrad = avg @ self.path_radiance[cols]
        emis = avg @ (1.0 - np.clip(self.transmission[cols], 0.0, 1.0))
        src = np.where(emis > 1e-6, lrad / np.maximum(emis, 1e-6), 0.0)
        return src / (H * C / (wl * 1e-6))


MAX_MOVE_FACTOR = 300.0
"""The farthest a spectrum of one path is moved: 300 x its path (a 5 m tape7 to 1.5 km)."""


def moved_transmission(
    tau0, wavelength_um, path_m: float, ranges_m, growth: Weather | None, what: str
) -> np.ndarray:
    """(n_ranges, n) transmission at ``ranges_m`` of samples of transmission ``tau0`` over a
    path of ``path_m`` (paper sections 8-9): per sample along the LOWTRAN7 table's curve of
    growth for the air ``growth`` (None: the model's default, US Standard 1976 sea level with
    LOWTRAN7's rural aerosol at 23 km; a spectrum of a clear path moved along it to 500 m
    reads up to 0.5 % low, so give the air of the file),
    :meth:`snrmon.model.atmosphere_table.AtmosphereTable.moved_optical_depth`. Band-model
    samples do not follow Beer-Lambert tau(L0)^(R/L0): moving LOWTRAN7's own 200 m MWIR
    spectrum to 500 m that way reads its band 8.5 % low, to 1500 m 27 %, 10 m to 1500 m
    68 %; along the curve of growth within 0.1 % when the air is the spectrum's, within
    5.2 % with the air 10 K and 34 % RH off (docs/model.md, tests/model/test_modtran_ranges.py).
    A move to more than :data:`MAX_MOVE_FACTOR` x the path is refused (ValueError naming
    it); to shorter paths it is not (as R -> 0, tau -> 1 whatever the curve)."""
    from snrmon.model.atmosphere_table import load_table

    r = np.atleast_1d(np.asarray(ranges_m, dtype=float))
    far = float(np.max(r, initial=0.0))
    if far > MAX_MOVE_FACTOR * path_m:
        raise ValueError(
            f"{what}: a spectrum of a {path_m:g} m path is not moved to {far:g} m, beyond "
            f"{MAX_MOVE_FACTOR:g} x its path; give spectra computed nearer that range"
        )
    t0 = np.clip(np.asarray(tau0, dtype=float), 0.0, 1.0)
    with np.errstate(divide="ignore"):
        od0 = -np.log(t0)
    od = load_table().moved_optical_depth(
        growth or Weather(), 1e4 / np.asarray(wavelength_um, float), od0, path_m, r
    )
    out = np.exp(-od)
    out[r <= 0] = 1.0
    return out


_OD_RANGE = (1e-12, 700.0)  # tau 1 - 1e-12 to 1e-304: ln(OD) finite for the interpolation


def _optical_depth(tau) -> np.ndarray:
    with np.errstate(divide="ignore"):
        od = -np.log(np.clip(np.asarray(tau, dtype=float), 0.0, 1.0))
    return np.clip(od, *_OD_RANGE)


_NUM = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eEdD][+-]?\d+)?$")


def _is_data_row(line: str) -> bool:
    parts = line.split()
    return bool(parts) and all(_NUM.match(p) for p in parts)


def read_tape7(path: str | Path, path_length_m: float) -> SpectralPath:
    """Read a MODTRAN tape7 (transmittance or thermal-radiance run) for a path of
    ``path_length_m``. Raises ValueError naming the file on anything malformed."""
    p = Path(path)
    lines = p.read_text(errors="replace").splitlines()
    name = str(p)
    try:
        head = next(i for i, s in enumerate(lines) if "FREQ" in s.upper())
    except StopIteration:
        raise ValueError(f"{name}: not a MODTRAN tape7 (no FREQ column header)") from None
    first = next((i for i in range(head + 1, len(lines)) if _is_data_row(lines[i])), None)
    if first is None:
        raise ValueError(f"{name}: tape7 has no data rows after the FREQ header")
    header_lines = lines[head:first]
    row = lines[first]
    spans = [(m.start(), m.end()) for m in re.finditer(r"\S+", row)]
    ends = [e for _, e in spans]

    def names_of(hline: str) -> list[str]:
        out = [""] * len(spans)
        for m in re.finditer(r"\S+", hline):
            gaps = [abs(e - m.end()) for e in ends]
            j = int(np.argmin(gaps))
            if gaps[j] <= 3:  # farther headings sit over blank columns
                out[j] = (out[j] + m.group()).upper()
        return out

    parts = [names_of(h) for h in header_lines if h.strip()]
    cols = ["_".join(x for x in names if x) for names in zip(*parts, strict=True)]
    if not cols or not cols[0].startswith("FREQ"):
        raise ValueError(f"{name}: first tape7 column is not FREQ (got {cols[:1]})")
    rows = []
    for i in range(first, len(lines)):
        s = lines[i].strip()
        if s.startswith("-9999"):
            break
        if not s:
            continue
        words = s.split()
        if len(words) != len(spans):
            # a blank field in this row: cut it at the first row's right-aligned boundaries
            cuts = [0] + [e for e in ends[:-1]] + [len(lines[i])]
            words = [lines[i][cuts[k] : cuts[k + 1]].strip() for k in range(len(spans))]
        try:
            rows.append([float(w.replace("D", "E")) if w else math.nan for w in words])
        except ValueError:
            raise ValueError(f"{name}: line {i + 1} of the tape7 data is not numbers") from None
    else:
        raise ValueError(f"{name}: tape7 data does not end with a -9999. line")
    data = np.asarray(rows, dtype=float)
    tau_col = next(
        (j for j, c in enumerate(cols) if c in ("TOT_TRANS", "COMBIN_TRANS", "TRANS")), None
    )
    if tau_col is None:
        raise ValueError(f"{name}: no TOT_TRANS/COMBIN_TRANS column in {cols}")
    freq = data[:, 0]
    if np.any(freq <= 0):
        raise ValueError(f"{name}: FREQ must be > 0 cm^-1")
    wl = 1e4 / freq
    order = np.argsort(wl)
    rad = None
    if "PTH_THRML" in cols:
        # W cm^-2 sr^-1 (cm^-1)^-1 -> W m^-2 sr^-1 um^-1: x1e4 (cm^2 -> m^2) x nu^2/1e4.
        per_wn = data[:, cols.index("PTH_THRML")]
        rad = (per_wn * 1e4 * freq**2 / 1e4)[order]
    return SpectralPath(wl[order], data[order, tau_col], float(path_length_m), rad, source=name)


def read_spectral_csv(path: str | Path, path_length_m: float) -> SpectralPath:
    """Read ``wavelength_um, transmission[, path_radiance]`` (header row optional)."""
    p = Path(path)
    rows = []
    with p.open(newline="") as fh:
        for n, rec in enumerate(csv.reader(fh), start=1):
            if not rec or rec[0].strip().startswith("#"):
                continue
            try:
                rows.append([float(x) for x in rec if x.strip() != ""])
            except ValueError:
                if rows or n > 3:
                    raise ValueError(f"{p}: line {n} is not numbers: {','.join(rec)!r}") from None
    if not rows or any(len(r) != len(rows[0]) or len(r) not in (2, 3) for r in rows):
        raise ValueError(f"{p}: expected 2 or 3 numeric columns (wavelength_um, tau, path_rad)")
    a = np.asarray(rows)
    rad = a[:, 2] if a.shape[1] == 3 else None
    return SpectralPath(a[:, 0], a[:, 1], float(path_length_m), rad, source=str(p))
