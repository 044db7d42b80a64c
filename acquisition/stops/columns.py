"""The stop table's columns, one set of names for every table of it: ``Session.stops()``, the
report's CSV, the campaign's Parquet and the console's stop table.

They come from what :class:`snrmon.acquisition.stops.table.StopRow` declares of its fields and
of its parts' (:func:`snrmon.acquisition.columns.column`), one flat table: a dict field is one
column per key (``model_`` + the model's curve; a per-frame value's mean, ``<column>_mean``)
after the single ones, the stop's times are UTC where the table has the session's clock, and
``range_m`` (the rangefinder's range, else the GPS range) comes before the two it is taken from.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

from snrmon.acquisition.columns import MEAN, Column, columns_of
from snrmon.acquisition.measure.peak_snr import PeakSnr
from snrmon.acquisition.prediction import STOP_MODEL_KEYS
from snrmon.acquisition.stops.table import StopRow, recorded_order

RANGE = Column(
    "m, the rangefinder's range, else the GPS range", units="m", dtype="<f8", name="range_m"
)
"""The stop's range (:attr:`StopRow.range_m`), a column derived from two declared ones."""


def frame_mean_columns(record: type = PeakSnr) -> tuple[Column, ...]:
    """The per-frame columns the stop table carries the mean of (declared ``stop="mean"``), as
    the stop table's ``<column>_mean`` columns."""
    return tuple(
        dataclasses.replace(
            c, name=f"{c.name}_mean", meaning=f"mean over the stop's run: {c.meaning}"
        )
        for c in columns_of(record)
        if c.stop == MEAN
    )


def stop_columns(keys: Mapping[str, Sequence[str]] | None = None) -> tuple[Column, ...]:
    """Every column of a stop table, in order: each declared field's, a dict field's one per
    key (``keys[field]``; default: every model value a row can carry and every declared frame
    mean)."""
    keys = {**default_keys(), **(keys or {})}
    out: list[Column] = []
    for c in _in_table_order():
        if c.name == "lrf_range_m":
            out.append(RANGE)
        if c.keyed is None:
            out.append(c)
            continue
        for k in keys.get(c.field, ()):
            out.append(dataclasses.replace(c, name=f"{c.keyed}{k}", keyed=None))
    return tuple(out)


def _in_table_order() -> tuple[Column, ...]:
    """:class:`StopRow`'s declared columns, its parts' among them, in
    :data:`~snrmon.acquisition.stops.table.RECORDED_ORDER`, those of its dict fields (a column
    per key) last."""
    by_field = {c.field: c for c in columns_of(StopRow)}
    declared = [by_field[k] for k in recorded_order(by_field)]
    return (
        *(c for c in declared if c.keyed is None),
        *(c for c in declared if c.keyed is not None),
    )


def default_keys() -> dict[str, tuple[str, ...]]:
    """The keys of :class:`StopRow`'s dict fields in a table of fixed columns (the CSV, the
    Parquet): every model value a row can carry, every declared frame mean."""
    return {
        "model_snr": STOP_MODEL_KEYS,
        "frame_means": tuple(c.name for c in frame_mean_columns()),
    }


def stop_record(
    row: StopRow,
    *,
    utc: Callable[[int], Any] | None = None,
    keys: Mapping[str, Iterable[str]] | None = None,
) -> dict[str, Any]:
    """One stop row as ``{column: value}``, under the columns' names: ``utc`` maps a host time
    to the table's UTC (None: the times are missing); ``keys`` the keys of each dict field
    (None: the row's own, the model's in :data:`STOP_MODEL_KEYS` order)."""
    out: dict[str, Any] = {}
    for c in _in_table_order():
        value = c.value_of(row)
        if c.name == "lrf_range_m":
            out[RANGE.name] = row.range_m
        if c.keyed is not None:
            wanted = value if keys is None or c.field not in keys else keys[c.field]
            for k in _ordered(wanted):
                out[f"{c.keyed}{k}"] = value.get(k)
        elif c.dtype == "M8[ns]":
            out[c.name] = None if value is None or utc is None else utc(value)
        else:
            out[c.name] = value
    return out


def _ordered(keys: Iterable[str]) -> list[str]:
    """Keys in :data:`STOP_MODEL_KEYS` order, any other after them by name."""
    known = {k: i for i, k in enumerate(STOP_MODEL_KEYS)}
    return sorted(keys, key=lambda k: (known.get(k, len(known)), k))


def stop_units(names: Iterable[str]) -> dict[str, str]:
    """``{column: units}`` of the named stop-table columns that have units (the DataFrames'
    ``attrs["units"]``): each declared column's; a model value is an SNR, ``1``."""
    declared = {c.name: c.units for c in (*stop_columns(), *frame_mean_columns())}
    out = {}
    for name in names:
        units = declared[name] if name in declared else "1" if name.startswith("model_") else None
        if units is not None:
            out[name] = units
    return out
