"""The HDF5 side of the session recorder: creates the SWMR file and appends to it (one thread).

Every dataset is created before ``swmr_mode`` is switched on (SWMR cannot create objects later).
Frames go to disk as they come, one chunk per frame when uncompressed (``write_direct_chunk``,
which skips the filter and type-conversion path), row strips through a filter
(:func:`snrmon.acquisition.compression.frame_chunks`); the per-frame columns and the small
streams are held in memory and appended at each ``flush``, which then flushes HDF5 and
``fsync``s the file so that what was flushed survives a kill or a power loss. A reader takes,
per camera, the shortest of the per-frame datasets (frames reach the file before their columns).
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import h5py
import numpy as np

from snrmon.acquisition.compression import frame_chunks
from snrmon.acquisition.record import schema
from snrmon.acquisition.streams.timebase import (
    ClockMap,
    ClockReference,
    rows_array,
    utc_of_rows,
)

# The NAME netCDF-4 gives a dimension scale that is only a dimension (netCDF's own convention).
NETCDF_PURE_DIMENSION = "This is a netCDF dimension but not a netCDF variable."
LIBVER = ("v110", "v110")
_U16 = np.dtype("<u2")


def pure_dimension(
    parent: h5py.Group, name: str, of: str, length: int, chunk: int = 64
) -> h5py.Dataset:
    """A netCDF "dimension without a variable" named ``name`` for the rows of dataset ``of``:
    an empty-valued scale as long as it (kept so by :func:`resize_rows`), so readers name the
    axis."""
    scale = parent.create_dataset(name, (length,), np.int8, chunks=(chunk,), maxshape=(None,))
    scale.make_scale(f"{NETCDF_PURE_DIMENSION}{length:10d}")
    scale.attrs.update(units="1", long_name=f"index of a row of {of}")
    return scale


def resize_rows(ds: h5py.Dataset, n: int) -> None:
    """Resize a 1-D row dataset to ``n`` rows, and the pure dimension it is attached to."""
    ds.resize((n,))
    for scale in ds.dims[0].values():
        if str(scale.attrs.get("NAME", b"").decode()).startswith(NETCDF_PURE_DIMENSION):
            scale.resize((n,))


def copy_rows(parent: h5py.Group, ds: h5py.Dataset, name: str) -> h5py.Dataset:
    """A copy of the row dataset ``ds`` as ``parent[name]``: its rows and attributes, and a
    pure dimension of its own (``<name>_row``), not the original's."""
    new = parent.create_dataset(name, data=ds[()], chunks=ds.chunks, maxshape=(None,))
    for key, value in ds.attrs.items():
        if key not in ("DIMENSION_LIST", "REFERENCE_LIST", "CLASS", "NAME"):
            new.attrs[key] = value
    _attach(new, pure_dimension(parent, f"{name}_row", name, len(new)))
    return new


def _attach(ds: h5py.Dataset, *scales: h5py.Dataset) -> None:
    """Attach one dimension scale per axis of ``ds``, in order."""
    for axis, scale in enumerate(scales):
        ds.dims[axis].attach_scale(scale)


def _describe_all(f: h5py.File) -> None:
    """The CF attributes of every dataset the layout names (schema.ATTRS): ``units`` (not on a
    compound table), ``long_name``, ``standard_name`` time on the UTC times, the flag meanings
    of the bad-pixel map; and the root's ``Conventions``."""

    def visit(name: str, obj: object) -> None:
        if isinstance(obj, h5py.Dataset):
            key = name.rsplit("/", 1)[-1]
            if key in schema.ATTRS and "long_name" not in obj.attrs:
                units, long_name = schema.ATTRS[key]
                obj.attrs["long_name"] = long_name
                if units is not None:
                    obj.attrs["units"] = units
            if key in schema.TIME_VARIABLES:
                obj.attrs.update(standard_name="time", calendar="proleptic_gregorian")
            if key == "bad" and schema.CALIBRATION in name:
                obj.attrs.update(
                    flag_masks=np.array(schema.BAD_PIXEL_FLAGS["flag_masks"], np.uint8),
                    flag_meanings=schema.BAD_PIXEL_FLAGS["flag_meanings"],
                )

    f.attrs["Conventions"] = schema.CONVENTIONS
    f.visititems(visit)


def _new_file(path: Path, filters: dict) -> h5py.File:
    """The session file, created exclusively ("w-": of two writers racing for one path one is
    refused) with the layout's file-level settings."""
    # chunks of 64 KiB and more start on a page boundary, so a frame is whole pages
    # libver bounded at v110: SWMR needs the 1.10 file format, and nothing newer is used,
    # so readers built on HDF5 1.10 (MATLAB, h5dump 1.10) open the file (docs/session-format).
    # With a filter, no chunk cache: a frame goes through the filter and to the file when
    # written, as a raw one does (write_direct_chunk). Cached, a frame that a full disk
    # refused stayed in the cache of a file that cannot close, and HDF5 ran the filter on
    # it again when the process let go of the file: a segmentation fault in the plugin.
    try:
        return h5py.File(
            path,
            "w-",
            libver=LIBVER,
            alignment_threshold=65536,
            alignment_interval=4096,
            **({"rdcc_nbytes": 0} if filters else {}),
        )
    except FileExistsError:
        raise FileExistsError(f"session file {path} already exists") from None


def _write_header(
    f: h5py.File,
    config: dict,
    ref: ClockReference,
    compression: str | None,
    flush_interval_s: float,
) -> None:
    """The root's attributes (format, creation, clock start, the configuration as JSON) and
    ``/config``: one attribute per configuration key (JSON where not a plain value)."""
    f.attrs.update(
        format=schema.FORMAT,
        format_version=schema.FORMAT_VERSION,
        created_utc=datetime.now(UTC).isoformat(),
        flush_interval_s=flush_interval_s,
        frames_compression=compression or "none",
        clock_start_monotonic_ns=ref.monotonic_ns,
        clock_start_utc_ns=ref.utc_ns,
        clock_start_source=ref.source,
        config_json=json.dumps(config, sort_keys=True, default=str),
    )
    cfg = f.create_group(schema.CONFIG)
    for key, value in config.items():
        simple = isinstance(value, (str, int, float, bool))
        cfg.attrs[str(key)] = value if simple else json.dumps(value, sort_keys=True, default=str)


@dataclass
class FileCounts:
    """What the writer has put into the file so far, per camera or stream (the recorder's
    status and summary read them; only the writer thread changes them)."""

    frames_written: dict[str, int]
    frames_flushed: dict[str, int]  # the frames in the file as of the last flush
    frame_bytes_flushed: dict[str, int]  # raw pixel bytes, at the last flush
    frame_bytes_stored: dict[str, int]  # what the filter made of them
    measurements: dict[str, int]
    stream_rows: dict[str, int]

    @classmethod
    def empty(cls, cameras: Iterable[str]) -> FileCounts:
        cameras = list(cameras)
        return cls(
            frames_written=dict.fromkeys(cameras, 0),
            frames_flushed=dict.fromkeys(cameras, 0),
            frame_bytes_flushed=dict.fromkeys(cameras, 0),
            frame_bytes_stored=dict.fromkeys(cameras, 0),
            measurements=dict.fromkeys(cameras, 0),
            stream_rows=dict.fromkeys(schema.STREAMS, 0),
        )


class ClockStamps:
    """The state of the clock map a flush stamps the held rows' UTC with, and how much of the
    map ``/clock`` holds: the file keeps the map every UTC in it was stamped with, row for
    row."""

    def __init__(self, clock: ClockMap) -> None:
        self._clock = clock
        self._relabelled_ns, self._map = clock.snapshot()
        self.rows_written = 0

    def advance(self) -> int:
        """Take the clock map's present state for this flush; the offset (ns) the receiver's
        first time moved the whole map by since the last one (0: not moved)."""
        # One state of the map per flush: what it moved the file by, and the rows the held rows
        # are stamped with (a fix between the two would stamp them twice).
        relabelled_ns, self._map = self._clock.snapshot()
        delta = relabelled_ns - self._relabelled_ns
        self._relabelled_ns += delta
        return delta

    def utc_ns(self, t_host_ns: np.ndarray) -> np.ndarray:
        return utc_of_rows(rows_array(self._map), np.asarray(t_host_ns, np.int64))

    def unwritten_rows(self) -> np.ndarray | None:
        """The map's rows ``/clock`` does not hold yet (None: none), to be appended and then
        counted (:meth:`written`)."""
        rows = self._map[self.rows_written :]
        if not rows:
            return None
        fields = ("monotonic_ns", "utc_ns", "source", "rate", "slew_until_ns", "residual_ns")
        return np.array([tuple(getattr(r, k) for k in fields) for r in rows], schema.CLOCK_DTYPE)

    def written(self, n: int) -> None:
        self.rows_written += n


class SessionWriter:
    """Owns the open session file; not thread-safe (the recorder's writer thread only)."""

    def __init__(
        self,
        path: Path,
        *,
        config: dict,
        shapes: dict[str, tuple[int, int]],
        filters: dict,
        compression: str | None,
        clock: ClockMap,
        flush_interval_s: float,
        fsync: bool,
        calibrations: dict[str, tuple[dict, dict[str, np.ndarray]]] | None = None,
    ) -> None:
        self.path = path
        self.counts = FileCounts.empty(shapes)
        self._raw_frames = not filters
        self._pending: dict[tuple[str, str], list] = {}
        self._frames: dict[str, h5py.Dataset] = {}  # per camera, looked up once (not per frame)
        self._dimensions: dict[str, h5py.Dataset] = {}  # dataset path -> its pure dimension
        self._file = self._create(
            config, shapes, filters, compression, clock, flush_interval_s, calibrations or {}
        )
        self._fd = os.open(path, os.O_RDONLY) if fsync else None

    def _create(
        self,
        config: dict,
        shapes: dict[str, tuple[int, int]],
        filters: dict,
        compression: str | None,
        clock: ClockMap,
        flush_interval_s: float,
        calibrations: dict[str, tuple[dict, dict[str, np.ndarray]]],
    ) -> h5py.File:
        """The new file with every dataset of the layout and its first ``/clock`` rows, in
        SWMR mode; a file that fails on the way is closed and removed."""
        f = _new_file(self.path, filters)
        try:
            _write_header(f, config, clock.reference, compression, flush_interval_s)
            for name, (h, w) in shapes.items():
                self._camera_group(f, name, h, w, filters, compression, calibrations.get(name))
            for name, (dtype, units) in schema.STREAMS.items():
                d = f.create_dataset(name, (0,), dtype, chunks=(64,), maxshape=(None,))
                d.attrs["units_json"] = json.dumps(units)
                _attach(d, self._dimension(f, name, 64))
            _describe_all(f)
            self._stamps = ClockStamps(clock)
            self._append_clock_rows(f)
            f.swmr_mode = True
        except BaseException:
            f.close()
            self.path.unlink(missing_ok=True)
            raise
        return f

    def _camera_group(
        self,
        f: h5py.File,
        name: str,
        h: int,
        w: int,
        filters: dict,
        compression: str | None,
        calibration: tuple[dict, dict[str, np.ndarray]] | None,
    ) -> h5py.Group:
        """``/cameras/<name>``: the frame cube and its axes, the per-frame columns, the
        measurements, the engine states, the background references and the calibration."""
        g = f.create_group(f"{schema.CAMERAS}/{name}")
        g.attrs.update(height=h, width=w, pixel_dtype="uint16")
        frames = g.create_dataset(
            schema.FRAMES,
            (0, h, w),
            np.uint16,
            chunks=frame_chunks((h, w), compression if filters else None),
            maxshape=(None, h, w),
            **filters,
        )
        self._frames[name] = frames
        time, row, col = self._frame_axes(g, h, w)
        _attach(frames, time, row, col)
        for column in schema.FRAME_COLUMNS:
            ds = g.create_dataset(column, (0,), np.int64, chunks=(4096,), maxshape=(None,))
            _attach(ds, time)
        self._measurement_columns(g)
        st = g.create_dataset(
            schema.STATES, (0,), schema.STATE_DTYPE, chunks=(1,), maxshape=(None,)
        )
        st.attrs["units_json"] = json.dumps(schema.STATE_UNITS)
        _attach(st, self._dimension(g, schema.STATES, 64))
        images = g.create_dataset(
            schema.REFERENCES, (0, h, w), np.float32, chunks=(1, h, w), maxshape=(None, h, w)
        )
        _attach(images, self._dimension(g, schema.REFERENCES, 64), row, col)
        if calibration is not None:
            self._write_calibration(g, row, col, *calibration)
        return g

    @staticmethod
    def _write_calibration(
        g: h5py.Group,
        row: h5py.Dataset,
        col: h5py.Dataset,
        metadata: dict,
        maps: dict[str, np.ndarray],
    ) -> None:
        """The camera's calibration, whole, before the file turns SWMR (no object can be made
        after that): the maps and the metadata of the calibration file they came from."""
        cal = g.create_group(schema.CALIBRATION)
        cal.attrs["metadata_json"] = json.dumps(metadata, sort_keys=True, allow_nan=False)
        for key, dtype in schema.CALIBRATION_MAPS.items():
            data = np.asarray(maps[key], dtype)
            if data.shape != (row.shape[0], col.shape[0]):
                raise ValueError(
                    f"calibration map {key} is {data.shape}, the frames are "
                    f"{(row.shape[0], col.shape[0])}"
                )
            # contiguous and uncompressed: every replay reads the maps whole, and gzip made
            # that 80 ms of a 20 s recording's 0.24 s fast replay (a few MB beside the frames)
            ds = cal.create_dataset(key, data=data)
            _attach(ds, row, col)

    def write_frame(self, camera: str, pixels: np.ndarray, counter: int, t_host: int, t_dev: int):
        """Append one frame's pixels now; its counter and times at the next flush."""
        ds = self._frames[camera]
        n = self.counts.frames_written[camera]
        # The low-level calls: h5py's path lookup and Dataset.resize cost ~100 us a frame
        # together, a quarter of writing the frame's 1.8 MB (MWIR) to the page cache.
        ds.id.set_extent((n + 1, *pixels.shape))
        if self._raw_frames and pixels.dtype == _U16 and pixels.flags.c_contiguous:
            ds.id.write_direct_chunk((n, 0, 0), pixels)
        else:
            ds[n] = pixels
        self._pending.setdefault(("frame", camera), []).append((counter, t_host, t_dev))
        self.counts.frames_written[camera] = n + 1

    def write_reference(self, camera: str, offset: np.ndarray) -> int:
        """Append a background reference image now; its index in /cameras/<camera>/references."""
        ds = self._file[f"{schema.CAMERAS}/{camera}/{schema.REFERENCES}"]
        n = ds.shape[0]
        ds.resize(n + 1, axis=0)
        ds[n] = offset
        self._dimensions[ds.name].resize((n + 1,))
        return n

    def add_row(self, kind: str, key: str, row: tuple) -> None:
        """Hold one row of a measurement (kind "meas", key = camera) or a stream (key = name)."""
        self._pending.setdefault((kind, key), []).append(row)

    def flush(self) -> None:
        """Append the held rows, record a changed clock reference, flush HDF5 and fsync."""
        f = self._file
        self._relabel(f, self._stamps.advance())
        for (kind, key), rows in list(self._pending.items()):
            if kind == "frame":
                cols = np.array(rows, np.int64).reshape(-1, 3)
                utc = self._stamps.utc_ns(cols[:, 1])
                for name, values in zip(schema.FRAME_COLUMNS, (*cols.T, utc), strict=True):
                    self._append(f[f"{schema.CAMERAS}/{key}/{name}"], values)
                self._append(f[f"{schema.CAMERAS}/{key}/{schema.TIME}"], utc)
            elif kind == "meas":
                arr = np.array(rows, schema.MEASUREMENT_DTYPE)
                group = f"{schema.CAMERAS}/{key}/{schema.MEASUREMENTS}"
                for name in schema.MEASUREMENT_DTYPE.names or ():
                    self._append(f[f"{group}/{name}"], arr[name])
                self.counts.measurements[key] += len(rows)
            elif kind == "state":
                arr = np.array(rows, schema.STATE_DTYPE)
                self._append(f[f"{schema.CAMERAS}/{key}/{schema.STATES}"], arr)
            else:
                arr = np.array(rows, schema.STREAMS[key][0])
                arr["utc_ns"] = self._stamps.utc_ns(arr["t_host_ns"])
                self._append(f[key], arr)
                self.counts.stream_rows[key] += len(rows)
            del self._pending[(kind, key)]
        self._append_clock_rows(f)
        f.flush()
        if self._fd is not None:
            os.fsync(self._fd)
        counts = self.counts
        flushed = dict(counts.frames_written)
        for camera, ds in self._frames.items():  # the filter's ratio so far, for the status
            frame_bytes = ds.dtype.itemsize * ds.shape[1] * ds.shape[2]
            counts.frame_bytes_flushed[camera] = flushed[camera] * frame_bytes
            counts.frame_bytes_stored[camera] = self.frames_bytes_stored(camera)
        # published after their bytes: a status that sees these frames flushed sees their ratio
        counts.frames_flushed = flushed

    def frames_bytes_stored(self, camera: str) -> int:
        """Bytes the file gives ``camera``'s frames (after the filter; chunk index aside)."""
        return int(self._frames[camera].id.get_storage_size())

    def close(self) -> None:
        """Close the file and the fsync handle (both attempted; the first error is raised)."""
        errors = []
        for closer in (self._file.close, self._close_fd):
            try:
                closer()
            except Exception as exc:
                errors.append(exc)
        if errors:
            raise errors[0]

    def _close_fd(self) -> None:
        fd, self._fd = self._fd, None
        if fd is not None:
            os.close(fd)

    def _append_clock_rows(self, f: h5py.File) -> None:
        """The clock map's rows since the last flush into ``/clock``: the map every UTC in the
        file was stamped with, row for row."""
        arr = self._stamps.unwritten_rows()
        if arr is None:
            return
        self._append(f[schema.CLOCK], arr)
        self._stamps.written(len(arr))
        self.counts.stream_rows[schema.CLOCK] = self._stamps.rows_written

    def _relabel(self, f: h5py.File, delta: int) -> None:
        """The receiver's first time moved the whole clock map by ``delta`` ns (timebase):
        every UTC already written moves by the same offset, so the file keeps one monotone
        map."""
        if not delta:
            return
        cams = list(self.counts.frames_written)
        paths = [f"{schema.CAMERAS}/{cam}/{col}" for cam in cams for col in ("utc_ns", schema.TIME)]
        for ds in (f[p] for p in paths):
            if ds.shape[0]:
                ds[:] = ds[()] + delta
        for name in schema.STREAMS:
            ds = f[name]
            if ds.shape[0]:
                rows = ds[()]
                live = rows["utc_ns"] >= 0  # -1: an event added afterwards, never stamped
                rows["utc_ns"][live] += delta
                ds[:] = rows  # /clock too: its rows are the map's, moved likewise

    def _append(self, ds: h5py.Dataset, values: np.ndarray) -> None:
        n = ds.shape[0] + len(values)
        ds.resize((n,))
        ds[-len(values) :] = values
        scale = self._dimensions.get(ds.name)
        if scale is not None:  # a pure dimension is as long as its dataset
            scale.resize((n,))

    @staticmethod
    def _frame_axes(g: h5py.Group, h: int, w: int) -> tuple[h5py.Dataset, ...]:
        """The frame cube's coordinates as dimension scales: ``time`` (the frames' UTC, CF time
        units, appended with them), ``row`` and ``col`` (pixel indices)."""
        time = g.create_dataset(schema.TIME, (0,), np.int64, chunks=(4096,), maxshape=(None,))
        time.attrs.update(standard_name="time", calendar="proleptic_gregorian")
        row = g.create_dataset(schema.ROW, data=np.arange(h, dtype=np.int32))
        col = g.create_dataset(schema.COL, data=np.arange(w, dtype=np.int32))
        for axis, name in ((time, schema.TIME), (row, schema.ROW), (col, schema.COL)):
            axis.make_scale(name)
        return time, row, col

    def _measurement_columns(self, g: h5py.Group) -> None:
        """``measurements``: a group of one 1-D dataset per field of MEASUREMENT_DTYPE (a table
        of named columns for netCDF readers), with their CF attributes and the ``measurement``
        dimension inside the group, kept as long as they are."""
        m = g.create_group(schema.MEASUREMENTS)
        m.attrs["flag_names"] = np.array([n.encode() for n in schema.FLAG_NAMES])
        m.attrs["units_json"] = json.dumps(schema.MEASUREMENT_UNITS)
        m.attrs["long_name"] = schema.ATTRS[schema.MEASUREMENTS][1]
        scale = pure_dimension(m, schema.DIMENSIONS[schema.MEASUREMENTS], "measurements", 0, 1024)
        for name in schema.MEASUREMENT_DTYPE.names or ():
            column = m.create_dataset(
                name, (0,), schema.MEASUREMENT_DTYPE[name], chunks=(1024,), maxshape=(None,)
            )
            units, long_name = schema.MEASUREMENT_CF[name]
            column.attrs["long_name"] = long_name
            if units is not None:
                column.attrs["units"] = units
            if name == "flags":
                column.attrs.update(
                    flag_masks=np.array([1 << i for i in range(len(schema.FLAG_NAMES))], np.uint16),
                    flag_meanings=" ".join(schema.FLAG_NAMES),
                )
            _attach(column, scale)
            self._dimensions[column.name] = scale

    def _dimension(self, parent: h5py.Group, dataset: str, chunk: int) -> h5py.Dataset:
        scale = pure_dimension(parent, schema.DIMENSIONS[dataset], dataset, 0, chunk)
        self._dimensions[f"{parent.name.rstrip('/')}/{dataset}"] = scale
        return scale
