"""The campaign's Parquet tables: every stop of every session, and per-frame tables on request.

Plain Parquet (pyarrow), readable without snrmon: ``pandas.read_parquet``, ``polars.read_parquet``,
MATLAB's ``parquetread``. Missing values are nulls, never NaN or made-up numbers; times are
timestamp columns (UTC, ns); integer columns with nulls stay integers (the pandas metadata asks
for nullable integer dtypes, so pandas does not turn them into floats). The file's
key-value metadata holds ``snrmon.settings`` (the analysis settings as JSON), ``snrmon.campaign``
(the sessions, the failures, the snrmon version) and ``snrmon.units`` (column -> unit and meaning),
so a table says how it was made. Columns: :data:`STOP_COLUMNS` and :data:`FRAME_COLUMNS`.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from snrmon.acquisition.columns import Column
from snrmon.acquisition.record.schema import PEAK_SNR_COLUMNS
from snrmon.acquisition.stops.columns import stop_columns

_F = pa.float64()
_UTC = pa.timestamp("ns", tz="UTC")  # a timestamp column: readers get dates, not integers
_ARROW: dict[str, pa.DataType] = {
    "<i2": pa.int16(),
    "<i4": pa.int32(),
    "<i8": pa.int64(),
    "<u2": pa.uint16(),
    "<f8": _F,
    "?": pa.bool_(),
    "U": pa.string(),
    "M8[ns]": _UTC,
}


def arrow_type(c: Column) -> pa.DataType:
    """The Arrow type of a declared column (text of any length: a string)."""
    return pa.string() if c.dtype.startswith("S") else _ARROW[c.dtype]


def _declared(columns) -> dict[str, tuple[pa.DataType, str]]:
    return {c.name: (arrow_type(c), c.meaning) for c in columns}


STOP_COLUMNS: dict[str, tuple[pa.DataType, str]] = {
    "session": (
        pa.string(),
        "session name (file stem; the path relative to the common folder when two stems are equal)",
    ),
    "session_path": (pa.string(), "absolute path of the session file"),
    "target": (pa.string(), "target preset or TOML of the model curves"),
    "sensor": (pa.string(), "sensor preset of the model curves"),
    "day": (pa.date32(), "UTC date of the stop's start"),
    "gps_source": (pa.string(), "live | imported (snrmon gps-import) | null (no GPS)"),
    "stops_source": (
        pa.string(),
        "recorded (the live detector's stops) | redetected (found again from the range streams)",
    ),
    "n_frames_in_stop": (pa.int32(), "frames measured while the stop was open"),
    "n_frames_flagged": (pa.int32(), "of those, frames with a flag that keeps them out of runs"),
    "background_method": (pa.string(), "rim | rect x0,y0,x1,y1, +detrend when detrended"),
    "box_px": (pa.int32(), "px, Eq. (4) box side"),
    "search_px": (pa.int32(), "px, search window side"),
    "calibration": (pa.string(), "calibration file the analysis applied (null: as recorded)"),
    # The stop table's own columns, with the names of Session.stops() and the report's CSV.
    **_declared(stop_columns()),
    "flags": (
        pa.list_(pa.string()),
        "incomplete, manual, stop_open_at_end, no_range, gps_imported",
    ),
}
"""The stop table: the campaign's columns (which session, how it was analysed), then the
columns of every stop table (:func:`snrmon.acquisition.stops.columns.stop_columns`)."""
FRAME_COLUMNS: dict[str, tuple[pa.DataType, str]] = {
    "session": (pa.string(), "session name"),
    "camera": (pa.string(), "camera name"),
    "t_host_ns": (pa.int64(), "ns, host monotonic clock at receipt"),
    "utc": (_UTC, "the frame's receipt, UTC (session clock)"),
    "stop": (pa.int32(), "stop index while a stop was open, else null"),
    **_declared(PEAK_SNR_COLUMNS),
}
"""The per-frame table: which frame, then the Eq. (4) result's declared columns (as in the
session file; ``flags`` bit i is ``acquisition.measure.peak_snr.FLAG_NAMES[i]``)."""
STOP_SCHEMA = pa.schema([(k, t) for k, (t, _) in STOP_COLUMNS.items()])
FRAME_SCHEMA = pa.schema([(k, t) for k, (t, _) in FRAME_COLUMNS.items()])


def _metadata(columns: dict, settings: dict, campaign: dict) -> dict[bytes, bytes]:
    return {
        b"snrmon.settings": json.dumps(settings).encode(),
        b"snrmon.campaign": json.dumps(campaign).encode(),
        b"snrmon.units": json.dumps({k: u for k, (_, u) in columns.items()}).encode(),
    }


def stop_table(rows: list[dict[str, Any]]) -> pa.Table:
    """The stop rows as an Arrow table of :data:`STOP_SCHEMA` (sorted by session, camera, stop)."""
    rows = sorted(rows, key=lambda r: (r["session"], r["camera"], r["stop"]))
    return pa.Table.from_pylist(rows, schema=STOP_SCHEMA)


def _with_nullable_integers(table: pa.Table) -> pa.Table:
    """``table`` with pandas metadata that reads its integer columns as nullable integers
    (``Int32``...) instead of floats where they hold nulls."""
    frame = table.to_pandas(types_mapper=_nullable_pandas_type)
    return pa.Table.from_pandas(frame, schema=table.schema, preserve_index=False)


def _nullable_pandas_type(arrow_type: pa.DataType):
    """The pandas nullable dtype of an Arrow integer type (None: pandas' default)."""
    import pandas as pd

    if pa.types.is_integer(arrow_type):
        return pd.api.types.pandas_dtype(
            str(arrow_type).replace("int", "Int").replace("uInt", "UInt")
        )
    return None


def write_stop_table(path: Path, rows: list[dict], settings: dict, campaign: dict) -> Path:
    table = _with_nullable_integers(stop_table(rows))
    table = table.replace_schema_metadata(
        {**(table.schema.metadata or {}), **_metadata(STOP_COLUMNS, settings, campaign)}
    )
    pq.write_table(table, path)
    return path


def frame_table(columns: list[dict]) -> pa.Table:
    """Per-frame columns of one or more tasks as an Arrow table of :data:`FRAME_SCHEMA`; NaN
    SNRs and stop -1 become nulls."""
    import numpy as np

    parts = []
    for c in columns:
        arrays = []
        for name, (typ, _) in FRAME_COLUMNS.items():
            v = c[name]
            mask = None
            if name == "stop":
                mask = np.asarray(v) < 0
            elif typ == _F:
                mask = ~np.isfinite(np.asarray(v, float))
            arrays.append(pa.array(v, type=typ, mask=mask))
        parts.append(pa.Table.from_arrays(arrays, schema=FRAME_SCHEMA))
    return pa.concat_tables(parts) if parts else FRAME_SCHEMA.empty_table()


def write_frame_table(path: Path, columns: list[dict], settings: dict, campaign: dict) -> Path:
    table = _with_nullable_integers(frame_table(columns))
    table = table.replace_schema_metadata(
        {**(table.schema.metadata or {}), **_metadata(FRAME_COLUMNS, settings, campaign)}
    )
    pq.write_table(table, path)
    return path


def read_metadata(path: str | Path) -> dict[str, Any]:
    """The snrmon metadata of a campaign table, parsed (settings, campaign, units)."""
    meta = pq.read_schema(path).metadata or {}
    return {
        k.decode().removeprefix("snrmon."): json.loads(v)
        for k, v in meta.items()
        if k.startswith(b"snrmon.")
    }
