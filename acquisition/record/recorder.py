"""The session recorder: one crash-safe HDF5 file per session, written on its own thread.

Producers (camera, measurement, rangefinder, GPS and GUI threads) call ``add_*``; each call only
puts a record on a queue and returns at once, so recording never stalls acquisition. The writer
thread appends to datasets that were all created up front, because the file runs in SWMR mode
(``libver="latest"``, ``swmr_mode = True``; anchors (b) 7, h5py#1807): a reader can follow the file
live, and after a ``kill -9`` or a power loss the file opens with everything up to the last flush.
Flushes (HDF5 flush + ``fsync``) happen at most every ``flush_interval_s``, so at most about one
second is lost. Frames are written as they arrive, one chunk per frame (navigate#596).

A slow disk shows as backlog; beyond ``max_backlog_bytes`` new frames are dropped and counted
(reason ``recorder_backlog``). A write error (disk full) ends the recording with one message in
``status().error``; the file stays readable up to the last flush and ``add_*`` keep returning.
The layout is in ``acquisition/record/schema.py`` and ``docs/session-format.md``.
"""

from __future__ import annotations

import errno
import json
import os
import queue
import shutil
import threading
import time
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from acquisition.measure.peak_snr import PeakSnr, flags_to_bits
from acquisition.record import schema as S  # noqa: N812
from acquisition.record.stream_rows import gps_row, range_row
from acquisition.record.writer import SessionWriter, frame_filter
from acquisition.runtime.ring import Reader
from acquisition.runtime.timebase import ClockMap
from drivers.gps.fix import GpsFix
from drivers.rangefinder.reading import RangeReading

BACKLOG = "recorder_backlog"
STOPPED = "recording_stopped"


@dataclass(frozen=True, slots=True)
class RecorderStatus:
    """Live state: ``state`` is recording | stopping | stopped | failed."""

    state: str
    path: str
    frames_written: dict[str, int]
    frames_flushed: dict[str, int]
    bytes_written: int
    backlog_frames: int
    backlog_bytes: int
    dropped: dict[str, dict[str, int]]
    free_bytes: int | None
    error: str | None


@dataclass(frozen=True, slots=True)
class RecorderSummary:
    """What a finished recording holds and what it lost, per camera and reason."""

    path: str
    state: str
    frames_received: dict[str, int]
    frames_written: dict[str, int]
    dropped: dict[str, dict[str, int]]
    measurements_written: dict[str, int]
    ranges_written: int
    gps_written: int
    events_written: int
    bytes_written: int
    duration_s: float
    error: str | None = None
    extra: dict = field(default_factory=dict)


def _describe(exc: BaseException, path: Path, frames: int) -> str:
    text = str(exc)
    if getattr(exc, "errno", None) == errno.ENOSPC or "No space left" in text:
        return f"recording stopped: disk full writing {path} after {frames} frames"
    first = text.splitlines()[0] if text else type(exc).__name__
    return f"recording stopped: write error on {path} after {frames} frames: {first}"


class SessionRecorder:
    """Records one session into ``path`` (created; an existing file is an error)."""

    def __init__(
        self,
        path: str | os.PathLike,
        *,
        config: Mapping[str, Any],
        cameras: Mapping[str, tuple[int, int]],
        flush_interval_s: float = 0.5,
        compression: str | None = None,
        max_backlog_bytes: int = 256 * 2**20,
        clock: ClockMap | None = None,
        fsync: bool = True,
    ) -> None:
        self.path = Path(path)
        if self.path.exists():
            raise FileExistsError(f"session file {self.path} already exists")
        if not 0 < flush_interval_s <= 1.0:
            raise ValueError(f"flush_interval_s must be in (0, 1] s, got {flush_interval_s}")
        for name, shape in cameras.items():
            if not name or len(name.encode()) > S.NAME_BYTES or "/" in name:
                raise ValueError(f"camera name {name!r} is not a valid dataset name")
            if len(shape) != 2 or min(shape) < 1:
                raise ValueError(f"camera {name!r} frame shape {shape} is not (rows, columns)")
        self.flush_interval_s = float(flush_interval_s)
        self.compression = compression
        self.max_backlog_bytes = int(max_backlog_bytes)
        self.clock = clock or ClockMap()
        self._shapes = {n: (int(s[0]), int(s[1])) for n, s in cameras.items()}
        self._filters = frame_filter(compression)
        self._lock = threading.Lock()
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._backlog_frames = 0
        self._backlog_bytes = 0
        self._received = dict.fromkeys(self._shapes, 0)
        self._accepted = dict.fromkeys(self._shapes, 0)
        self._dropped: dict[str, dict[str, int]] = {n: {} for n in self._shapes}
        self._index_of: dict[str, dict[int, int]] = {n: {} for n in self._shapes}
        self._state = "recording"
        self._error: str | None = None
        self._t0 = time.monotonic()
        self._final: RecorderSummary | None = None
        self._pumps: list[tuple[threading.Thread, Reader]] = []
        self._w = SessionWriter(
            self.path,
            config=dict(config),
            shapes=self._shapes,
            filters=self._filters,
            compression=compression,
            clock=self.clock,
            flush_interval_s=self.flush_interval_s,
            fsync=fsync,
        )
        self._writer: SessionWriter | None = self._w  # None once closed; _w keeps the counts
        self._thread = threading.Thread(target=self._run, name="session-recorder", daemon=True)
        self._thread.start()
        self.add_event("recording_started", payload={"path": str(self.path)})

    # -- producers' API (never blocks, never raises on write trouble) -----------------------------

    def add_frame(self, camera: str, frame: Any) -> int | None:
        """Queue a frame (``Frame`` or ``RingFrame``); its index in the file, or ``None`` if it
        was dropped (backlog full or recording over). The pixel array is kept by reference until
        written: pass an array nobody will overwrite."""
        shape = self._shapes.get(camera)
        if shape is None:
            raise ValueError(
                f"camera {camera!r} is not in this recording ({', '.join(self._shapes)})"
            )
        pixels = frame.pixels
        if pixels.shape != shape:
            raise ValueError(
                f"frame shape {pixels.shape} from {camera!r} is not the recorded {shape}"
            )
        with self._lock:
            self._received[camera] += 1
            reason = None
            if self._state not in ("recording", "stopping"):
                reason = STOPPED
            elif self._backlog_bytes + pixels.nbytes > self.max_backlog_bytes:
                reason = BACKLOG
            if reason is not None:
                d = self._dropped[camera]
                d[reason] = d.get(reason, 0) + 1
                return None
            index = self._accepted[camera]
            self._accepted[camera] = index + 1
            index_of = self._index_of[camera]
            index_of[int(frame.t_host_ns)] = index
            if len(index_of) > 4096:
                index_of.pop(next(iter(index_of)))
            self._backlog_frames += 1
            self._backlog_bytes += pixels.nbytes
            t_dev = -1 if frame.t_device_ns is None else int(frame.t_device_ns)
            self._queue.put(
                ("frame", camera, pixels, int(frame.counter), int(frame.t_host_ns), t_dev)
            )
        return index

    def add_measurement(
        self,
        camera: str,
        index: int | None,
        *,
        counter: int,
        t_host_ns: int,
        peak_x: int,
        peak_y: int,
        peak: float,
        bg_mean: float,
        bg_std: float,
        snr: float,
        flags: int | Iterable[str] = 0,
        background: str = "rim",
        extent_w_px: int = 0,
        extent_h_px: int = 0,
    ) -> None:
        """Queue one frame's Eq. (4) result. ``index``: the frame's index from ``add_frame``, or
        ``None`` to look it up by ``t_host_ns`` (-1 in the file when the frame is not recorded)."""
        if camera not in self._shapes:
            raise ValueError(
                f"camera {camera!r} is not in this recording ({', '.join(self._shapes)})"
            )
        bits = int(flags) if isinstance(flags, (int, np.integer)) else flags_to_bits(flags)
        if index is None:
            with self._lock:
                index = self._index_of[camera].get(int(t_host_ns), -1)
        row = (
            index, counter, t_host_ns, peak_x, peak_y, peak, bg_mean, bg_std, snr, bits,
            background.encode(), extent_w_px, extent_h_px,
        )  # fmt: skip
        self._put(("meas", camera, row))

    def add_peak_snr(
        self, camera: str, index: int | None, counter: int, t_host_ns: int, result: PeakSnr
    ) -> None:
        """``add_measurement`` from the measurement's own ``PeakSnr``."""
        self.add_measurement(
            camera,
            index,
            counter=counter,
            t_host_ns=t_host_ns,
            peak_x=result.peak_x,
            peak_y=result.peak_y,
            peak=result.peak,
            bg_mean=result.bg_mean,
            bg_std=result.bg_std,
            snr=result.snr,
            flags=result.flags,
            background=result.background,
            extent_w_px=result.extent_w_px,
            extent_h_px=result.extent_h_px,
        )

    def add_range(self, reading: RangeReading) -> None:
        """Queue one raw rangefinder reading."""
        self._put(("stream", S.RANGEFINDER, range_row(reading)))

    def add_gps(self, fix: GpsFix) -> None:
        """Queue one raw GPS fix."""
        self._put(("stream", S.GPS, gps_row(fix)))

    def add_event(
        self,
        kind: str,
        *,
        camera: str = "",
        payload: Mapping | None = None,
        t_host_ns: int | None = None,
    ) -> None:
        """Queue an operator event (``roi_set``, ``stop_marked``, ``note``, ...) with a JSON
        payload; a payload too long for the field is a ValueError (nothing is cut silently)."""
        text = json.dumps(dict(payload or {}), sort_keys=True)
        if len(text.encode()) > S.PAYLOAD_BYTES or len(kind.encode()) > S.NAME_BYTES:
            raise ValueError(
                f"event {kind!r} too long: kind <= {S.NAME_BYTES} bytes, payload <= "
                f"{S.PAYLOAD_BYTES} bytes of JSON (got {len(text.encode())})"
            )
        t = time.monotonic_ns() if t_host_ns is None else int(t_host_ns)
        row = (t, 0, kind.encode(), S.text_field(camera, S.NAME_BYTES), text.encode())
        self._put(("stream", S.EVENTS, row))

    def _put(self, item: tuple) -> None:
        with self._lock:  # under the lock so nothing lands behind stop()'s sentinel
            if self._state in ("recording", "stopping"):
                self._queue.put(item)

    def attach_reader(self, camera: str, reader: Reader) -> None:
        """Feed ``camera`` from a ring reader on a pump thread. On ``stop()`` the pump takes what
        was pushed up to then and closes the reader (the recorder owns it from now on). Frames
        the reader loses are its own overruns, counted by the ring."""

        def pump() -> None:
            end_seq = None  # frames pushed when stop() began: drain up to there, then leave
            try:
                while self._state in ("recording", "stopping"):
                    if end_seq is None and self._state != "recording":
                        end_seq = reader.ring.pushed
                    if end_seq is not None and reader.lag == 0:
                        return
                    item = reader.pop_next(timeout=0.05)
                    if item is not None:
                        self.add_frame(camera, item)
                        if end_seq is not None and item.seq >= end_seq - 1:
                            return
            finally:
                reader.close()

        t = threading.Thread(target=pump, name=f"recorder-pump-{camera}", daemon=True)
        self._pumps.append((t, reader))
        t.start()

    # -- control and status ------------------------------------------------------------------------

    def status(self) -> RecorderStatus:
        try:
            free = shutil.disk_usage(self.path.parent).free
        except OSError:
            free = None
        with self._lock:
            return RecorderStatus(
                self._state,
                str(self.path),
                dict(self._w.frames_written),
                dict(self._w.frames_flushed),
                self._bytes_on_disk(),
                self._backlog_frames,
                self._backlog_bytes,
                {k: dict(v) for k, v in self._dropped.items()},
                free,
                self._error,
            )

    def stop(self, timeout: float = 60.0) -> RecorderSummary:
        """Write what is queued, close the file and return the summary (idempotent)."""
        if self._final is not None:
            return self._final
        with self._lock:
            if self._state == "recording":
                self._state = "stopping"
        for t, _ in self._pumps:
            t.join(timeout)
        self.add_event("recording_stopped", payload=self._counts())
        with self._lock:
            if self._state == "stopping":
                self._state = "closing"
            self._queue.put(("stop",))
        self._thread.join(timeout)
        summary = self._summary()
        if summary.state == "stopped":
            try:  # the SWMR file is closed: a plain r+ open may add the summary attribute
                with h5py.File(self.path, "r+") as f:
                    f.attrs["summary_json"] = json.dumps(asdict(summary), sort_keys=True)
                    f.attrs["stopped_utc"] = datetime.now(UTC).isoformat()
            except OSError as exc:
                summary.extra["summary_attr_error"] = str(exc)
        if not self._thread.is_alive():
            self._final = summary
        return summary

    # -- writer thread -----------------------------------------------------------------------------

    def _counts(self) -> dict:
        with self._lock:
            return {"frames_received": dict(self._received), "dropped": dict(self._dropped)}

    def _run(self) -> None:
        next_flush = time.monotonic() + self.flush_interval_s
        while True:
            try:
                item = self._queue.get(timeout=max(0.0, next_flush - time.monotonic()))
            except queue.Empty:
                item = None
            if item is not None and item[0] == "stop":
                self._guarded("flush")
                self._close()
                with self._lock:
                    if self._state != "failed":
                        self._state = "stopped"
                return
            if item is not None and item[0] == "frame":
                _, cam, pixels, counter, t_host, t_dev = item
                ok = self._guarded("write_frame", cam, pixels, counter, t_host, t_dev)
                with self._lock:
                    self._backlog_frames -= 1
                    self._backlog_bytes -= pixels.nbytes
                    if not ok:
                        self._dropped[cam][STOPPED] = self._dropped[cam].get(STOPPED, 0) + 1
            elif item is not None and self._writer is not None:
                self._writer.add_row(*item)
            if time.monotonic() >= next_flush:
                self._guarded("flush")
                next_flush = time.monotonic() + self.flush_interval_s

    def _guarded(self, method: str, *args) -> bool:
        """Run one writer call; on any error end the recording with one message. True if done."""
        if self._writer is None:
            return False
        try:
            getattr(self._writer, method)(*args)
            return True
        except Exception as exc:  # disk full or any write error: stop recording, keep acquisition
            self._fail(exc)
            self._close()
            return False

    def _fail(self, exc: BaseException) -> None:
        w = self._w
        with self._lock:
            if self._state == "failed":
                return
            self._error = _describe(exc, self.path, sum(w.frames_flushed.values()))
            self._state = "failed"
            for cam, n in w.frames_written.items():  # written but never flushed: not in the file
                lost = n - w.frames_flushed[cam]
                if lost:
                    self._dropped[cam][STOPPED] = self._dropped[cam].get(STOPPED, 0) + lost

    def _close(self) -> None:
        writer, self._writer = self._writer, None
        if writer is None:
            return
        try:
            writer.close()
        except Exception as exc:  # the file keeps what was flushed; report, don't raise
            self._fail(exc)

    def _bytes_on_disk(self) -> int:
        try:
            return self.path.stat().st_size
        except OSError:
            return 0

    def _summary(self) -> RecorderSummary:
        with self._lock:
            return RecorderSummary(
                str(self.path),
                self._state,
                dict(self._received),
                dict(self._w.frames_flushed),
                {k: dict(v) for k, v in self._dropped.items()},
                dict(self._w.measurements),
                self._w.stream_rows[S.RANGEFINDER],
                self._w.stream_rows[S.GPS],
                self._w.stream_rows[S.EVENTS],
                self._bytes_on_disk(),
                time.monotonic() - self._t0,
                self._error,
            )
