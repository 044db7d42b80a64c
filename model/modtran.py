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

    def transmission_at_ranges(self, ranges_m, columns: np.ndarray | None = None) -> np.ndarray:
        """(n_ranges, n_samples) tau(R) = tau(L0)^(R / L0) at each spectral sample (or at the
        samples ``columns``): Beer-Lambert per sample, where it holds (a sample is narrower
        than the band model's structure)."""
        t0 = np.clip(self.transmission, 0.0, 1.0)
        t0 = t0 if columns is None else t0[columns]
        r = np.atleast_1d(np.asarray(ranges_m, dtype=float))[:, None] / self.path_length_m
        with np.errstate(divide="ignore"):
            return np.where(t0 > 0, t0 ** np.where(t0 > 0, r, 1.0), np.where(r > 0, 0.0, 1.0))

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
