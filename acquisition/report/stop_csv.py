"""The report's CSV: one row per stop and camera, every value at full precision, an empty cell
where a value is missing or undefined (never a made-up number). Its columns are the stop table's
(:func:`snrmon.acquisition.stops.columns.stop_columns`: the names of ``Session.stops()`` and the
campaign's Parquet, every model value a row can carry), then ``ratio_<curve>``, the measured SNR
mean over the model's SNR for that curve at the stop's range. Both expected Eq. (4) readings are
given (``model_expected_eq4_rim``: the paper's 7x7 rim; ``model_expected_eq4_extent``: the
console's target-aware rule); ``expected_eq4_rule`` names the one the stop's background makes
applicable (``rim``, ``extent``; empty for a clear-sky rectangle) and ``ratio_expected_eq4``
is the measured mean over it. The stop's times are UTC (ISO 8601) where the session's clock is
given, else empty."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from snrmon.acquisition.prediction import CURVES
from snrmon.acquisition.stops.columns import default_keys, stop_columns, stop_record
from snrmon.acquisition.stops.table import StopRow

CSV_COLUMNS: tuple[str, ...] = (
    *(c.name for c in stop_columns()),
    *(f"ratio_{c}" for c in CURVES),
    "expected_eq4_rule",
    "ratio_expected_eq4",
)


def ratio(measured: float, model: float | None) -> float:
    """measured / model; NaN when either is missing, not finite or the model is not > 0."""
    if model is None or not (math.isfinite(measured) and math.isfinite(model) and model > 0):
        return math.nan
    return measured / model


def csv_rows(
    rows: list[StopRow], utc: Callable[[int], Any] | None = None
) -> list[dict[str, object]]:
    """One dict per stop row with exactly :data:`CSV_COLUMNS` (None for a missing value);
    ``utc`` maps a host time to UTC (None: the times are missing)."""
    keys = default_keys()
    out = []
    for r in rows:
        row: dict[str, object] = stop_record(r, utc=utc, keys=keys)
        row["background"] = r.reading.background or None
        for c in CURVES:
            row[f"ratio_{c}"] = ratio(r.reading.snr_mean, r.model.model_snr.get(c))
        row["expected_eq4_rule"] = r.expected_eq4_rule
        row["ratio_expected_eq4"] = ratio(r.reading.snr_mean, r.expected_eq4)
        out.append(row)
    return out


def _cell(v: object) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""  # missing or undefined: an empty cell, never a made-up number
    if isinstance(v, float):
        return repr(v)
    return str(v)


def _write(fh, rows: list[dict[str, object]]) -> None:
    w = csv.writer(fh)
    w.writerow(CSV_COLUMNS)
    for row in rows:
        w.writerow([_cell(row[c]) for c in CSV_COLUMNS])


def write_csv(rows: list[dict[str, object]], path: str | Path) -> Path:
    """The CSV table: a header of :data:`CSV_COLUMNS`, full-precision numbers, empty cells for
    missing or undefined values."""
    out = Path(path)
    with out.open("w", newline="") as fh:
        _write(fh, rows)
    return out


def csv_text(rows: list[dict[str, object]]) -> str:
    """The same table as :func:`write_csv`, as text (the console copies it to the clipboard)."""
    buf = io.StringIO(newline="")
    _write(buf, rows)
    return buf.getvalue()
