"""Each record's fields declared once: what a dataclass field is as a column of every table.

A record (:class:`snrmon.acquisition.measure.peak_snr.PeakSnr`,
:class:`snrmon.acquisition.stops.table.StopRow`) declares each of its fields with :func:`column`:
the column's name, its meaning, its units and its type in the session file, and whether the stop
table summarises it. The session file's measurement columns, the API's DataFrames and their
``attrs["units"]``, the campaign's Parquet tables, the report's CSV and the console's stop table
take them from there (:func:`columns_of`), so a field added to a record reaches all of them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from operator import attrgetter
from typing import Any

COLUMN = "snrmon.column"
"""The key of a field's :class:`Column` in its ``dataclasses.field`` metadata."""

PART = "snrmon.part"
"""The key of a part's class in the ``dataclasses.field`` metadata of a record's field that holds
one (:func:`part`)."""

MEAN = "mean"
"""A per-frame field the stop table carries as its mean over the stop's run (``<name>_mean``)."""


@dataclass(frozen=True, slots=True)
class Column:
    """One field of a record as a column.

    Attributes:
        meaning: what the value is, with its unit in words (the session file's ``units_json``
            and, after the name, its CF ``long_name``; the Parquet tables' ``snrmon.units``).
        units: the unit in the API's DataFrames (``attrs["units"]``): ``DN``, ``px``, ``m``,
            ``1`` ...; None: text, a flag or a count of nothing.
        cf_units: the CF ``units`` of the column in the session file (UDUNITS: DN and pixel
            positions are counts, ``1``); None: a text or flag column, CF gives it none.
        dtype: the column's numpy dtype (``<i4``, ``<f8``, ``?``; text: ``S32`` fixed-length
            UTF-8 in the session file, ``U`` elsewhere; ``M8[ns]``: a UTC time, kept on the host
            clock in the record). For a measurement, its type in the session file.
        name: the column's name in every table (``""``: the field's name).
        stop: ``"mean"``: the stop table carries the mean of this per-frame value over the
            stop's run, as ``<name>_mean``; ``""``: it does not.
        encode, decode: the value as the file holds it and back (flags as bits); None: the
            value as it is (text: UTF-8 bytes of ``dtype``'s length).
        keyed: a dict field: one column per key, named ``keyed`` + the key (``model_`` +
            the curve); None: one column.
        field: the dataclass field it is declared on (set by :func:`columns_of`).
        part: where that field is, in a record made of parts (:func:`part`): the record's
            field holding it (dotted for a part of a part); ``""``: the record's own field.
    """

    meaning: str
    units: str | None = None
    cf_units: str | None = None
    dtype: str = ""
    name: str = ""
    stop: str = ""
    encode: Callable[[Any], Any] | None = None
    decode: Callable[[Any], Any] | None = None
    keyed: str | None = None
    field: str = ""
    part: str = ""

    def value_of(self, record: Any) -> Any:
        """The column's value in ``record`` (read from its part, where it is in one)."""
        holder = attrgetter(self.part)(record) if self.part else record
        return getattr(holder, self.field)

    def file_value(self, value: Any) -> Any:
        """``value`` as the session file's column holds it."""
        if self.encode is not None:
            return self.encode(value)
        if self.dtype.startswith("S"):
            return text_field(value, int(self.dtype[1:]))
        return value

    def record_value(self, raw: Any) -> Any:
        """A value read from the session file's column as the record holds it."""
        if self.decode is not None:
            return self.decode(raw)
        kind = self.dtype[1:2] if self.dtype[:1] in "<>|=" else self.dtype[:1]
        if kind == "S":
            return text_value(raw)
        if kind in "iu":
            return int(raw)
        if kind == "f":
            return float(raw)
        return raw


def column(
    meaning: str,
    *,
    default: Any = dataclasses.MISSING,
    default_factory: Any = dataclasses.MISSING,
    compare: bool = True,
    **kw: Any,
) -> Any:
    """A dataclass field declared as a column (:class:`Column`'s attributes as keywords)."""
    return dataclasses.field(
        default=default,
        default_factory=default_factory,
        compare=compare,
        metadata={COLUMN: Column(meaning, **kw)},
    )


def part(cls: type, **kw: Any) -> Any:
    """A dataclass field holding a part of a record: a dataclass ``cls`` whose declared columns
    are the record's, as if declared on the record (``dataclasses.field``'s keywords)."""
    return dataclasses.field(metadata={PART: cls}, **kw)


_DECLARED: dict[type, tuple[Column, ...]] = {}


def columns_of(cls: type) -> tuple[Column, ...]:
    """The columns a dataclass declares, in its field order (fields without a column left out),
    a part's in the place of the field holding it (:func:`part`)."""
    declared = _DECLARED.get(cls)
    if declared is None:
        out: list[Column] = []
        for f in dataclasses.fields(cls):
            inner = f.metadata.get(PART)
            if inner is not None:
                out.extend(
                    dataclasses.replace(c, part=f"{f.name}.{c.part}" if c.part else f.name)
                    for c in columns_of(inner)
                )
            elif (c := f.metadata.get(COLUMN)) is not None:
                out.append(dataclasses.replace(c, field=f.name, name=c.name or f.name))
        declared = _DECLARED[cls] = tuple(out)
    return declared


def defaults_of(cls: type) -> dict[str, Any]:
    """``{column name: default}`` of the columns a dataclass gives a default (what a file
    written before a column existed reads as)."""
    defaults = {}
    for c in columns_of(cls):
        holder = cls
        for name in c.part.split(".") if c.part else ():
            holder = {f.name: f for f in dataclasses.fields(holder)}[name].metadata[PART]
        f = {f.name: f for f in dataclasses.fields(holder)}[c.field]
        if f.default is not dataclasses.MISSING:
            defaults[c.name] = f.default
        elif f.default_factory is not dataclasses.MISSING:
            defaults[c.name] = f.default_factory()
    return defaults


def values_of(record: Any) -> dict[str, Any]:
    """``{field: value}`` of a record's declared columns."""
    return {c.field: c.value_of(record) for c in columns_of(type(record))}


def units_of(columns: tuple[Column, ...] | list[Column]) -> dict[str, str]:
    """``{column name: units}`` of the columns that have one (a DataFrame's ``attrs["units"]``)."""
    return {c.name: c.units for c in columns if c.units is not None}


def text_field(value: str, size: int) -> bytes:
    """UTF-8 bytes for a fixed-length field, cut at ``size`` bytes on a character boundary."""
    raw = value.encode("utf-8")
    if len(raw) <= size:
        return raw
    return raw[:size].decode("utf-8", errors="ignore").encode("utf-8")


def text_value(raw: bytes) -> str:
    """The str of a fixed-length field as read back (NUL padding already stripped by numpy)."""
    return raw.decode("utf-8", errors="replace")
