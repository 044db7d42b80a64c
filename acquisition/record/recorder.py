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
from collections.abc import Callable, Mapping
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


class SessionRecorder:
    """Records one session into ``path`` (created; an existing file is an error).

    ``calibrations``: per camera, the ``(metadata, maps)`` of the radiometric calibration its
    frames are measured with
    (:func:`snrmon.acquisition.calibrate.calibration_file.calibration_record`), kept in the file
    from its start (``/cameras/<name>/calibration``)."""

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
        self.max_backlog_bytes = int(max_backlog_bytes)
        self.backlog_wait_s = float(backlog_wait_s)
        self.clock = clock or ClockMap()
        self._shapes = {n: (int(s[0]), int(s[1])) for n, s in cameras.items()}
        self._filters = frame_filter(compression)
        self._lock = threading.Lock()
        self._room = threading.Condition(self._lock)  # the writer freed backlog
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._backlog_frames = 0
        self._backlog_bytes = 0
        self._received = dict.fromkeys(self._shapes, 0)
        self._accepted = dict.fromkeys(self._shapes, 0)
        self._dropped: dict[str, dict[str, int]] = {n: {} for n in self._shapes}
        self._index_of: dict[str, dict[int, int]] = {n: {} for n in self._shapes}
        self._references = dict.fromkeys(self._shapes, 0)
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
            calibrations=dict(calibrations or {}),
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
            if self.backlog_wait_s > 0:
                deadline = time.monotonic() + self.backlog_wait_s
                while (
                    self._state in ("recording", "stopping")
                    and self._backlog_bytes + pixels.nbytes > self.max_backlog_bytes
                    and self._backlog_frames > 0
                    and (remaining := deadline - time.monotonic()) > 0
                ):
                    self._room.wait(min(remaining, 0.1))
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
                index = self._index_of[camera].get(int(t), -1)
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
            if self._state not in ("recording", "stopping"):
                return None
            k = self._references[camera]
            self._references[camera] = k + 1
            self._queue.put(("reference", camera, np.asarray(offset, np.float32).copy()))
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
            if self._state in ("recording", "stopping"):
                self._queue.put(item)

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
                self._received.get(camera, 0),
                self._w.frames_written.get(camera, 0),
                dict(self._dropped.get(camera, {})),
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
        raw = sum(self._w.frame_bytes_flushed.values())
        stored = sum(self._w.frame_bytes_stored.values())
        with self._lock:
            return RecorderStatus(
                self._state,
                str(self.path),
                dict(self._w.frames_written),
                dict(self._w.frames_flushed),
                on_disk,
                self._backlog_frames,
                self._backlog_bytes,
                {k: dict(v) for k, v in self._dropped.items()},
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
        self.add_event("recording_stopped", payload=self._counts())
        with self._lock:
            if self._state == "stopping":
                self._state = "closing"
            self._room.notify_all()
            self._queue.put(("stop",))
        self._thread.join(timeout)
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
                    self._room.notify_all()
                    if not ok:
                        self._dropped[cam][STOPPED] = self._dropped[cam].get(STOPPED, 0) + 1
            elif item is not None and item[0] == "reference":
                self._guarded("write_reference", item[1], item[2])
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
            self._error = describe_failure(exc, self.path, sum(w.frames_flushed.values()))
            self._state = "failed"
            self._room.notify_all()
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
