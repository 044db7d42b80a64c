"""The session recorder: one crash-safe HDF5 file per session, written on its own thread.

Producers (camera, measurement, rangefinder, GPS and GUI threads) call ``add_*``; each call only
puts a record on a queue and returns at once, so recording never stalls acquisition. The writer
thread appends to datasets that were all created up front, because the file runs in SWMR mode
(``libver=("v110", "v110")``, ``swmr_mode = True``, as ophyd-async's simulated HDF5 writer does;
h5py#1807): a reader can follow the file live, and after a ``kill -9`` or a power loss the file
opens with everything up to the last flush. Flushes (HDF5 flush + ``fsync``) happen at most every
``flush_interval_s``, so at most about one second is lost. Frames are written as they arrive, one
chunk per frame (navigate#596).

A slow disk shows as backlog; beyond ``max_backlog_bytes`` new frames are dropped and counted
(reason ``recorder_backlog``), unless ``backlog_wait_s`` lets the producer wait that long for
room first (back-pressure, for a producer that can wait: a simulated camera's pipeline). A
write error (disk full) ends the recording with one message in ``status().error``; the file
stays readable up to the last flush and ``add_*`` keep returning. The layout is in
``acquisition/record/schema.py`` and ``docs/session-format.md``.
"""

from __future__ import annotations

import json
import os
import queue
import shutil
import threading
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import asdict
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from snrmon.acquisition.columns import values_of
from snrmon.acquisition.compression import frame_filter
from snrmon.acquisition.engine.inputs import Measurement
from snrmon.acquisition.measure.peak_snr import PeakSnr
from snrmon.acquisition.record import schema as S  # noqa: N812
from snrmon.acquisition.record.recorder_status import (
    RecorderStatus,
    RecorderSummary,
    describe_failure,
)
from snrmon.acquisition.record.stream_rows import gps_row, measurement_row, range_row, values_row
from snrmon.acquisition.record.writer import SessionWriter
from snrmon.acquisition.streams.ring import Reader
from snrmon.acquisition.streams.timebase import ClockMap
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.rangefinder.reading import RangeReading

BACKLOG = "recorder_backlog"
STOPPED = "recording_stopped"


class FrameTally:
    """What became of the frames each camera gave the recorder: received, accepted (each one's
    index in the file, kept by host time for its measurement to find), dropped by reason; and
    how many background references were queued. Read and changed under the recorder's lock."""

    INDEX_KEPT = 4096  # the latest accepted frames whose index a measurement may look up

    def __init__(self, cameras: Iterable[str]) -> None:
        cameras = list(cameras)
        self.received = dict.fromkeys(cameras, 0)
        self.accepted = dict.fromkeys(cameras, 0)
        self.dropped: dict[str, dict[str, int]] = {n: {} for n in cameras}
        self.references = dict.fromkeys(cameras, 0)
        self._index_of: dict[str, dict[int, int]] = {n: {} for n in cameras}

    def drop(self, camera: str, reason: str, n: int = 1) -> None:
        d = self.dropped[camera]
        d[reason] = d.get(reason, 0) + n

    def accept(self, camera: str, t_host_ns: int) -> int:
        """The index in the file of ``camera``'s next frame (host time ``t_host_ns``)."""
        index = self.accepted[camera]
        self.accepted[camera] = index + 1
        index_of = self._index_of[camera]
        index_of[t_host_ns] = index
        if len(index_of) > self.INDEX_KEPT:
            index_of.pop(next(iter(index_of)))
        return index

    def index_at(self, camera: str, t_host_ns: int) -> int:
        """The file index of ``camera``'s recent frame at ``t_host_ns``; -1: not recorded."""
        return self._index_of[camera].get(t_host_ns, -1)

    def next_reference(self, camera: str) -> int:
        k = self.references[camera]
        self.references[camera] = k + 1
        return k

    def counts(self) -> dict:
        """Frames received and dropped so far (the ``recording_stopped`` event's payload)."""
        return {"frames_received": dict(self.received), "dropped": dict(self.dropped)}

    def dropped_copy(self) -> dict[str, dict[str, int]]:
        return {k: dict(v) for k, v in self.dropped.items()}


class Backlog:
    """The frames queued for the writer thread and not yet written, against the limit of
    ``max_bytes``: a producer beyond it waits up to ``wait_s`` for room (back-pressure), then
    its frame is dropped. Used under the recorder's lock (``room`` waits on it)."""

    def __init__(self, lock: threading.Lock, max_bytes: int, wait_s: float) -> None:
        self.max_bytes = int(max_bytes)
        self.wait_s = float(wait_s)
        self.frames = 0
        self.bytes = 0
        self.room = threading.Condition(lock)  # the writer freed backlog, or the recording ended

    def full_for(self, nbytes: int) -> bool:
        return self.bytes + nbytes > self.max_bytes

    def wait_for_room(self, nbytes: int, accepting: Callable[[], bool]) -> None:
        """Wait (at most ``wait_s``) while a frame of ``nbytes`` does not fit behind queued
        ones and frames are still ``accepting``."""
        if self.wait_s <= 0:
            return
        deadline = time.monotonic() + self.wait_s
        while (
            accepting()
            and self.full_for(nbytes)
            and self.frames > 0
            and (remaining := deadline - time.monotonic()) > 0
        ):
            self.room.wait(min(remaining, 0.1))

    def queued(self, nbytes: int) -> None:
        self.frames += 1
        self.bytes += nbytes

    def written(self, nbytes: int) -> None:
        self.frames -= 1
        self.bytes -= nbytes
        self.room.notify_all()


class WriterThread:
    """The recorder's writer thread: takes the queued items in order into the
    :class:`SessionWriter`, flushes at most every ``flush_interval_s``, and on the first write
    error closes the file and tells ``failed`` (the file stays readable up to its last flush).
    ``frame_done(camera, nbytes, written)`` follows every queued frame, ``ended()`` the close
    after the ``stop`` item."""

    def __init__(
        self,
        writer: SessionWriter,
        flush_interval_s: float,
        *,
        frame_done: Callable[[str, int, bool], None],
        failed: Callable[[BaseException], None],
        ended: Callable[[], None],
    ) -> None:
        self.counts = writer.counts  # kept after the file is closed
        self.queue: queue.SimpleQueue = queue.SimpleQueue()
        self._writer: SessionWriter | None = writer  # None once closed
        self._flush_interval_s = flush_interval_s
        self._frame_done, self._failed, self._ended = frame_done, failed, ended
        self._thread = threading.Thread(target=self._run, name="session-recorder", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def join(self, timeout: float) -> bool:
        """Wait for the thread to end; True if it has."""
        self._thread.join(timeout)
        return not self._thread.is_alive()

    def _run(self) -> None:
        next_flush = time.monotonic() + self._flush_interval_s
        while True:
            try:
                item = self.queue.get(timeout=max(0.0, next_flush - time.monotonic()))
            except queue.Empty:
                item = None
            if item is not None and item[0] == "stop":
                self._guarded("flush")
                self._close()
                self._ended()
                return
            if item is not None and item[0] == "frame":
                _, cam, pixels, counter, t_host, t_dev = item
                ok = self._guarded("write_frame", cam, pixels, counter, t_host, t_dev)
                self._frame_done(cam, pixels.nbytes, ok)
            elif item is not None and item[0] == "reference":
                self._guarded("write_reference", item[1], item[2])
            elif item is not None and self._writer is not None:
                self._writer.add_row(*item)
            if time.monotonic() >= next_flush:
                self._guarded("flush")
                next_flush = time.monotonic() + self._flush_interval_s

    def _guarded(self, method: str, *args) -> bool:
        """Run one writer call; on any error end the recording with one message. True if done."""
        if self._writer is None:
            return False
        try:
            getattr(self._writer, method)(*args)
            return True
        except Exception as exc:  # disk full or any write error: stop recording, keep acquisition
            self._failed(exc)
            self._close()
            return False

    def _close(self) -> None:
        writer, self._writer = self._writer, None
        if writer is None:
            return
        try:
            writer.close()
        except Exception as exc:  # the file keeps what was flushed; report, don't raise
            self._failed(exc)


class SessionRecorder:
    """Records one session into ``path`` (created; an existing file is an error).

    ``calibrations``: per camera, the ``(metadata, maps)`` of the radiometric calibration its
    frames are measured with
    (:func:`snrmon.acquisition.calibrate.calibration_file.calibration_record`), kept in the file
    from its start (``/cameras/<name>/calibration``).

    Its parts: the per-camera :class:`FrameTally`, the :class:`Backlog` of frames not yet
    written, and the :class:`WriterThread` that owns the :class:`SessionWriter`."""

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
        backlog_wait_s: float = 0.0,
        calibrations: Mapping[str, tuple[dict, dict[str, np.ndarray]]] | None = None,
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
        self.clock = clock or ClockMap()
        self._shapes = {n: (int(s[0]), int(s[1])) for n, s in cameras.items()}
        self._lock = threading.Lock()
        self._backlog = Backlog(self._lock, max_backlog_bytes, backlog_wait_s)
        self._tally = FrameTally(self._shapes)
        self._state = "recording"
        self._error: str | None = None
        self._t0 = time.monotonic()
        self._final: RecorderSummary | None = None
        self._pumps: list[tuple[threading.Thread, Reader]] = []
        writer = SessionWriter(
            self.path,
            config=dict(config),
            shapes=self._shapes,
            filters=frame_filter(compression),
            compression=compression,
            clock=self.clock,
            flush_interval_s=self.flush_interval_s,
            fsync=fsync,
            calibrations=dict(calibrations or {}),
        )
        self._writes = WriterThread(
            writer,
            self.flush_interval_s,
            frame_done=self._frame_done,
            failed=self._fail,
            ended=self._ended,
        )
        self._writes.start()
        self.add_event("recording_started", payload={"path": str(self.path)})

    @property
    def max_backlog_bytes(self) -> int:
        return self._backlog.max_bytes

    @property
    def backlog_wait_s(self) -> float:
        return self._backlog.wait_s

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
        backlog, tally = self._backlog, self._tally
        with self._lock:
            tally.received[camera] += 1
            backlog.wait_for_room(pixels.nbytes, lambda: self.accepting)
            reason = None
            if not self.accepting:
                reason = STOPPED
            elif backlog.full_for(pixels.nbytes):
                reason = BACKLOG
            if reason is not None:
                tally.drop(camera, reason)
                return None
            index = tally.accept(camera, int(frame.t_host_ns))
            backlog.queued(pixels.nbytes)
            t_dev = -1 if frame.t_device_ns is None else int(frame.t_device_ns)
            self._writes.queue.put(
                ("frame", camera, pixels, int(frame.counter), int(frame.t_host_ns), t_dev)
            )
        return index

    def add_measurement(
        self,
        camera: str,
        index: int | None,
        m: Measurement | PeakSnr,
        *,
        counter: int = -1,
        t_host_ns: int | None = None,
    ) -> None:
        """Queue one frame's measurement (the one entry point): the engine's
        :class:`Measurement`, or an Eq. (4) result alone (:class:`PeakSnr`: a frame measured
        without the engine's context, such as the stop table's kept rows; the track fields are
        then "not given") with its frame's ``counter`` and ``t_host_ns``. ``index``: the frame's
        index from ``add_frame``, or None to look it up by the frame's ``t_host_ns`` (-1 in the
        file when the frame is not recorded: a dropped frame's measurement is kept all the
        same)."""
        self._check_camera(camera)
        t = m.t_host_ns if isinstance(m, Measurement) else t_host_ns
        if t is None:
            raise ValueError(f"{camera}: an Eq. (4) result alone needs its frame's t_host_ns")
        if index is None:
            with self._lock:
                index = self._tally.index_at(camera, int(t))
        if isinstance(m, Measurement):
            row = measurement_row(index, m)
        else:
            row = values_row(index, counter=counter, t_host_ns=int(t), **values_of(m))
        self._put(("meas", camera, row))

    def add_state(self, camera: str, counter: int, t_host_ns: int, state: Mapping) -> None:
        """Queue the engine's state before frame ``counter``: the first recorded frame after
        frames the recording does not hold (a replay restores it there)."""
        self._check_camera(camera)
        text = json.dumps(dict(state), allow_nan=False, separators=(",", ":")).encode()
        if len(text) > S.STATE_BYTES:
            raise ValueError(
                f"{camera}: engine state of {len(text)} bytes exceeds the "
                f"{S.STATE_BYTES}-byte field"
            )
        self._put(("state", camera, (int(counter), int(t_host_ns), text)))

    def add_reference(
        self, camera: str, offset: np.ndarray, summary: Mapping, *, t_host_ns: int
    ) -> int | None:
        """Queue a background reference image and its ``background_reference`` event (with the
        image's index in /cameras/<camera>/references); the index, None when not recording."""
        self._check_camera(camera)
        with self._lock:
            if not self.accepting:
                return None
            k = self._tally.next_reference(camera)
            self._writes.queue.put(("reference", camera, np.asarray(offset, np.float32).copy()))
        self.add_event(
            "background_reference",
            camera=camera,
            payload={**dict(summary), "reference_index": k},
            t_host_ns=t_host_ns,
        )
        return k

    def _check_camera(self, camera: str) -> None:
        if camera not in self._shapes:
            raise ValueError(
                f"camera {camera!r} is not in this recording ({', '.join(self._shapes)})"
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
            if self.accepting:
                self._writes.queue.put(item)

    def attach_reader(self, camera: str, reader: Reader) -> None:
        """Feed ``camera`` from a ring reader on a pump thread
        (:func:`snrmon.acquisition.record.ring_feed.pump_reader`); ``stop()`` waits for it."""
        from snrmon.acquisition.record.ring_feed import pump_reader

        self._pumps.append((pump_reader(self, camera, reader), reader))

    def frames_of(self, camera: str) -> tuple[int, int, dict[str, int]]:
        """(frames given, frames written, frames dropped by reason) of ``camera`` so far: cheap,
        for a per-frame check (:meth:`status` also asks the disk)."""
        with self._lock:
            return (
                self._tally.received.get(camera, 0),
                self._writes.counts.frames_written.get(camera, 0),
                dict(self._tally.dropped.get(camera, {})),
            )

    @property
    def accepting(self) -> bool:
        """True while frames are still taken (recording, or stopping and draining)."""
        return self._state in ("recording", "stopping")

    @property
    def draining(self) -> bool:
        """True once ``stop()`` began: a pump takes what was pushed up to then, then leaves."""
        return self._state != "recording"

    # -- control and status ------------------------------------------------------------------------

    def status(self) -> RecorderStatus:
        try:
            free = shutil.disk_usage(self.path.parent).free
        except OSError:
            free = None
        on_disk = self._bytes_on_disk()
        counts = self._writes.counts
        raw = sum(counts.frame_bytes_flushed.values())
        stored = sum(counts.frame_bytes_stored.values())
        with self._lock:
            return RecorderStatus(
                self._state,
                str(self.path),
                dict(counts.frames_written),
                dict(counts.frames_flushed),
                on_disk,
                self._backlog.frames,
                self._backlog.bytes,
                self._tally.dropped_copy(),
                free,
                self._error,
                compression_ratio=raw / stored if raw and stored else None,
            )

    def stop(
        self,
        timeout: float = 60.0,
        *,
        accounting: Callable[[], Mapping[str, Mapping]] | None = None,
        devices_lost: Callable[[], list[dict]] | None = None,
    ) -> RecorderSummary:
        """Write what is queued, close the file and return the summary (idempotent).
        ``accounting()``: what became of every frame the source received, per camera (frames
        received before the recording, lost before the recorder: the pipeline's), asked once
        everything is written and kept in the summary's ``extra`` and so in ``summary_json``;
        ``devices_lost()``: the devices lost while it ran (with their times), kept likewise."""
        if self._final is not None:
            return self._final
        with self._lock:
            if self._state == "recording":
                self._state = "stopping"
        for t, _ in self._pumps:
            t.join(timeout)
        with self._lock:
            counts = self._tally.counts()
        self.add_event("recording_stopped", payload=counts)
        with self._lock:
            if self._state == "stopping":
                self._state = "closing"
            self._backlog.room.notify_all()
            self._writes.queue.put(("stop",))
        ended = self._writes.join(timeout)
        summary = self._summary()
        if accounting is not None:
            summary.extra["accounting"] = {k: dict(v) for k, v in accounting().items()}
        if devices_lost is not None:
            summary.extra["devices_lost"] = devices_lost()
        if summary.state == "stopped":
            try:  # the SWMR file is closed: a plain r+ open may add the summary attribute
                with h5py.File(self.path, "r+") as f:
                    f.attrs["summary_json"] = json.dumps(asdict(summary), sort_keys=True)
                    f.attrs["stopped_utc"] = datetime.now(UTC).isoformat()
            except OSError as exc:
                summary.extra["summary_attr_error"] = str(exc)
        if ended:
            self._final = summary
        return summary

    # -- the writer thread's reports -----------------------------------------------------------

    def _frame_done(self, camera: str, nbytes: int, written: bool) -> None:
        with self._lock:
            self._backlog.written(nbytes)
            if not written:
                self._tally.drop(camera, STOPPED)

    def _ended(self) -> None:
        with self._lock:
            if self._state != "failed":
                self._state = "stopped"

    def _fail(self, exc: BaseException) -> None:
        counts = self._writes.counts
        with self._lock:
            if self._state == "failed":
                return
            self._error = describe_failure(exc, self.path, sum(counts.frames_flushed.values()))
            self._state = "failed"
            self._backlog.room.notify_all()
            for cam, n in counts.frames_written.items():  # written, never flushed: not in the file
                lost = n - counts.frames_flushed[cam]
                if lost:
                    self._tally.drop(cam, STOPPED, lost)

    def _bytes_on_disk(self) -> int:
        try:
            return self.path.stat().st_size
        except OSError:
            return 0

    def _summary(self) -> RecorderSummary:
        counts = self._writes.counts
        with self._lock:
            return RecorderSummary(
                str(self.path),
                self._state,
                dict(self._tally.received),
                dict(counts.frames_flushed),
                self._tally.dropped_copy(),
                dict(counts.measurements),
                counts.stream_rows[S.RANGEFINDER],
                counts.stream_rows[S.GPS],
                counts.stream_rows[S.EVENTS],
                self._bytes_on_disk(),
                time.monotonic() - self._t0,
                self._error,
            )
