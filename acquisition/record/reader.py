"""Reading a snrmon session file with plain h5py, including one left behind by a crash.

A file whose writer died (``kill -9``, power loss, disk full) still carries the superblock's
"open for SWMR writing" status flags, and HDF5 then refuses a plain read-only open ("file is
already open for write (may use <h5clear file> to clear file consistency flags)"). Two ways in,
both automatic here:

- open it as a SWMR reader (``h5py.File(path, "r", swmr=True)``): works for any session file
  (they are all written in the SWMR-capable 1.10 format) and changes nothing on disk (the default);
- clear the flags as ``h5clear -s`` does (``repair=True`` or :func:`clear_status_flags`): byte 11
  of the version-2/3 superblock is zeroed and the superblock's Jenkins lookup3 checksum
  recomputed, after which any HDF5 reader, MATLAB's ``h5read`` included, opens the file.

Frames stay lazy h5py datasets, so a replay reads only the frames (or the window) it needs.
Per camera the frame count is the shortest of the per-frame datasets: after a crash the pixels
may be one flush ahead of their counters and times.
"""

from __future__ import annotations

import fcntl
import json
import os
import struct
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from snrmon.acquisition.compression import register_filters
from snrmon.acquisition.record import schema
from snrmon.acquisition.record.writer import resize_rows

register_filters()  # frames written with any filter read like raw ones
_SIGNATURE = b"\x89HDF\r\n\x1a\n"
_M32 = 0xFFFFFFFF


@dataclass(frozen=True)
class CameraRecord:
    """One camera's recorded data; ``frames`` is a lazy (N, H, W) uint16 h5py dataset."""

    name: str
    frames: h5py.Dataset
    counter: np.ndarray
    t_host_ns: np.ndarray
    t_device_ns: np.ndarray
    utc_ns: np.ndarray
    measurements: np.ndarray  # MEASUREMENT_DTYPE (a 1.x file's rows upgraded: see upgrade_rows)
    states: np.ndarray  # STATE_DTYPE: engine states at recording gaps (none in a 1.x file)
    references: h5py.Dataset | None  # (K, H, W) float32 reference images (None in a 1.x file)

    @property
    def n_frames(self) -> int:
        return len(self.counter)

    def frame(self, i: int) -> np.ndarray:
        """Frame ``i`` as a (H, W) uint16 array."""
        if not 0 <= i < self.n_frames:
            raise IndexError(f"frame {i} out of range: {self.name} holds {self.n_frames}")
        return self.frames[i]


class SessionFile:
    """An open session file; use as a context manager or call ``close()``."""

    def __init__(self, f: h5py.File, recovered: str) -> None:
        self._f = f
        self.path = Path(f.filename)
        self.recovered = recovered  # "" (clean), "swmr_read" or "flags_cleared"
        self.attrs = dict(f.attrs)
        if self.attrs.get("format") != schema.FORMAT:
            name = f.filename
            f.close()
            raise ValueError(f"{name} is not a snrmon session file (format attribute missing)")
        self.format_version = str(self.attrs.get("format_version"))
        self.config: dict = json.loads(self.attrs.get("config_json", "{}"))
        self.summary: dict | None = (
            json.loads(self.attrs["summary_json"]) if "summary_json" in self.attrs else None
        )
        self.flag_names: tuple[str, ...] = schema.FLAG_NAMES
        self.cameras: dict[str, CameraRecord] = {}
        for name, g in f[schema.CAMERAS].items():
            cols = {c: g[c][()] for c in schema.FRAME_COLUMNS}
            n = min([g[schema.FRAMES].shape[0], *(len(v) for v in cols.values())])
            meas = upgrade_rows(measurement_rows(g[schema.MEASUREMENTS]))
            names = g[schema.MEASUREMENTS].attrs.get("flag_names")
            if names is not None:
                self.flag_names = tuple(x.decode() if isinstance(x, bytes) else x for x in names)
            states = g[schema.STATES][()] if schema.STATES in g else np.empty(0, schema.STATE_DTYPE)
            refs = g.get(schema.REFERENCES)
            self.cameras[name] = CameraRecord(
                name=name,
                frames=g[schema.FRAMES],
                counter=cols["counter"][:n],
                t_host_ns=cols["t_host_ns"][:n],
                t_device_ns=cols["t_device_ns"][:n],
                utc_ns=cols["utc_ns"][:n],
                measurements=meas,
                states=states,
                references=refs,
            )
        self.rangefinder: np.ndarray = f[schema.RANGEFINDER][()]
        self.gps: np.ndarray = f[schema.GPS][()]
        self.events: np.ndarray = f[schema.EVENTS][()]
        self.clock: np.ndarray = f[schema.CLOCK][()]

    @property
    def major_version(self) -> int:
        """The format's major version (1 or 2); what a replay can rely on depends on it."""
        try:
            return int(self.format_version.split(".")[0])
        except ValueError:
            return 1

    @property
    def version(self) -> tuple[int, int]:
        """(major, minor) of the format; (1, 0) when unreadable."""
        try:
            major, minor = (int(v) for v in self.format_version.split(".")[:2])
        except ValueError:
            return (1, 0)
        return (major, minor)

    @property
    def complete(self) -> bool:
        """True when the recorder stopped cleanly (a summary was written)."""
        return self.summary is not None

    def event_list(self) -> list[dict]:
        """The events as dicts with decoded strings and parsed JSON payloads, in time order."""
        out = [
            {
                "t_host_ns": int(e["t_host_ns"]),
                "utc_ns": int(e["utc_ns"]),
                "kind": schema.text_value(e["kind"]),
                "camera": schema.text_value(e["camera"]),
                "payload": json.loads(schema.text_value(e["payload"]) or "{}"),
            }
            for e in self.events
        ]
        return sorted(out, key=lambda e: e["t_host_ns"])

    def calibration_record(self, camera: str) -> tuple[dict, dict[str, np.ndarray]] | None:
        """``(metadata, maps)`` of the calibration ``camera`` was measured with, as the file
        keeps it (format 2.3 on), or None (no calibration, or an earlier file: its
        ``calibration`` event names the file it was loaded from)."""
        g = self._f.get(f"{schema.CAMERAS}/{camera}/{schema.CALIBRATION}")
        if g is None:
            return None
        meta = json.loads(g.attrs["metadata_json"])
        return meta, {k: g[k][()] for k in schema.CALIBRATION_MAPS if k in g}

    def close(self) -> None:
        self._f.close()

    def __enter__(self) -> SessionFile:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def append_event(
    path: str | os.PathLike, kind: str, *, camera: str = "", payload: dict | None = None
) -> None:
    """Add an event to a finished session file (an analysis result such as a target
    characterization belongs to the session it was made from). The file must not be open for
    writing elsewhere; ``t_host_ns`` and ``utc_ns`` are -1: the event was not live."""
    text = json.dumps(dict(payload or {}), sort_keys=True)
    if len(text.encode()) > schema.PAYLOAD_BYTES or len(kind.encode()) > schema.NAME_BYTES:
        raise ValueError(f"event {kind!r} too long for the session's event fields")
    row = np.array(
        [(-1, -1, kind.encode(), schema.text_field(camera, schema.NAME_BYTES), text.encode())],
        dtype=schema.EVENT_DTYPE,
    )
    with h5py.File(path, "r+") as f:
        ds = f[schema.EVENTS]
        n = ds.shape[0]
        resize_rows(ds, n + 1)
        ds[n] = row[0]


def measurement_rows(m: h5py.Group | h5py.Dataset) -> np.ndarray:
    """A camera's measurement rows as one structured array: from the group of named columns
    (format 2.4 on; as long as the shortest column, after a crash) or the compound dataset of
    earlier files."""
    if isinstance(m, h5py.Dataset):
        return m[()]
    names = [n for n in schema.MEASUREMENT_DTYPE.names or () if n in m]
    n = min((m[name].shape[0] for name in names), default=0)
    rows = empty_rows(n)
    for name in names:
        rows[name] = m[name][:n]
    return rows


def empty_rows(n: int) -> np.ndarray:
    """``n`` measurement rows of the current dtype, each Eq. (4) column a file may lack (one
    declared after the file was written) at its field's default, the others zero."""
    rows = np.zeros(n, schema.MEASUREMENT_DTYPE)
    for name, value in schema.MEASUREMENT_DEFAULTS.items():
        rows[name] = value
    return rows


def upgrade_rows(rows: np.ndarray) -> np.ndarray:
    """Measurement rows of any format version in the current dtype: fields a 1.x file lacks are
    "not given" (empty track state, the peak as the window, NaN cue, statistics and range)."""
    if rows.dtype == schema.MEASUREMENT_DTYPE:
        return rows
    out = empty_rows(len(rows))
    for name in ("cue_x", "cue_y", "snr_mean", "snr_std", "range_m"):
        out[name] = np.nan
    out["window_x"], out["window_y"] = rows["peak_x"], rows["peak_y"]
    out["background"] = b"rim"  # before 2.0 Eq. (4) was always on the 7x7 rim
    for name in rows.dtype.names or ():
        if name in (out.dtype.names or ()):
            out[name] = rows[name]
    return out


def open_session(path: str | os.PathLike, *, repair: bool = False) -> SessionFile:
    """Open a session file read-only, recovering a crashed one (see the module docstring).

    With the file locking h5py and xarray use by default (HDF5's, "best effort": a file system
    without ``flock`` is read all the same), so the same file opens again alongside in
    ``h5py.File(path, "r")`` or ``xarray.open_dataset``: HDF5 refuses a second open in one
    process whose locking flags differ. A crashed writer holds no lock (``flock`` ends with its
    process).
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"session file {p} not found")
    try:
        return SessionFile(h5py.File(p, "r"), "")
    except OSError as exc:
        if "h5clear" not in str(exc) and "consistency flags" not in str(exc):
            raise OSError(f"cannot open session file {p}: {str(exc).splitlines()[0]}") from exc
    if repair:
        clear_status_flags(p)
        return SessionFile(h5py.File(p, "r"), "flags_cleared")
    return SessionFile(h5py.File(p, "r", swmr=True), "swmr_read")


def clear_status_flags(path: str | os.PathLike) -> bool:
    """Zero the superblock's file-consistency flags in place (what ``h5clear -s`` does).

    Refuses (OSError) while another process holds the file open, as HDF5 writers lock it with
    ``flock``. Returns False when the flags were already clear.
    """
    p = Path(path)
    with open(p, "r+b") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            raise OSError(f"{p} is open in another process; not clearing its flags") from exc
        try:
            base = _superblock_offset(fh, p)
            fh.seek(base)
            head = fh.read(12)
            version, size_of_offsets = head[8], head[9]
            if version < 2:
                raise ValueError(f"{p}: superblock version {version} has no status flags to clear")
            end = 12 + 4 * size_of_offsets
            fh.seek(base)
            block = bytearray(fh.read(end + 4))
            if block[11] == 0:
                return False
            stored = struct.unpack("<I", block[end : end + 4])[0]
            if stored != lookup3(bytes(block[:end])):
                raise ValueError(f"{p}: superblock checksum does not match; not touching it")
            block[11] = 0
            block[end : end + 4] = struct.pack("<I", lookup3(bytes(block[:end])))
            fh.seek(base)
            fh.write(block)
            fh.flush()
            os.fsync(fh.fileno())
            return True
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def _superblock_offset(fh, p: Path) -> int:
    """The superblock sits at 0 or at a power of two from 512 up (after a user block)."""
    offset = 0
    size = os.fstat(fh.fileno()).st_size
    while offset < size:
        fh.seek(offset)
        if fh.read(8) == _SIGNATURE:
            return offset
        offset = 512 if offset == 0 else offset * 2
    raise ValueError(f"{p} is not an HDF5 file (no superblock signature)")


def _rot(x: int, k: int) -> int:
    return ((x << k) | (x >> (32 - k))) & _M32


def lookup3(data: bytes, initval: int = 0) -> int:
    """Bob Jenkins' lookup3 ``hashlittle``, the checksum HDF5 puts on its metadata."""
    n = len(data)
    a = b = c = (0xDEADBEEF + n + initval) & _M32
    i = 0
    while n > 12:
        x, y, z = struct.unpack_from("<III", data, i)
        a, b, c = (a + x) & _M32, (b + y) & _M32, (c + z) & _M32
        a = ((a - c) & _M32) ^ _rot(c, 4)
        c = (c + b) & _M32
        b = ((b - a) & _M32) ^ _rot(a, 6)
        a = (a + c) & _M32
        c = ((c - b) & _M32) ^ _rot(b, 8)
        b = (b + a) & _M32
        a = ((a - c) & _M32) ^ _rot(c, 16)
        c = (c + b) & _M32
        b = ((b - a) & _M32) ^ _rot(a, 19)
        a = (a + c) & _M32
        c = ((c - b) & _M32) ^ _rot(b, 4)
        b = (b + a) & _M32
        i += 12
        n -= 12
    if n == 0:
        return c
    x, y, z = struct.unpack("<III", data[i:] + bytes(12 - n))
    a, b, c = (a + x) & _M32, (b + y) & _M32, (c + z) & _M32
    c = (c ^ b) - _rot(b, 14) & _M32
    a = (a ^ c) - _rot(c, 11) & _M32
    b = (b ^ a) - _rot(a, 25) & _M32
    c = (c ^ b) - _rot(b, 16) & _M32
    a = (a ^ c) - _rot(c, 4) & _M32
    b = (b ^ a) - _rot(a, 14) & _M32
    c = (c ^ b) - _rot(b, 24) & _M32
    return c
