"""The reader side of the shared-memory frame ring (``docs/shm-frame-ring.md``, version 1).

:class:`ShmCamera` attaches to a ring by name, delivers each published frame once as a
:class:`Frame`, counts frames missing from the camera's own counter (``status().dropped``), counts
its own overruns when it falls more than ``slots - 1`` frames behind, and re-attaches when the
writer closes, dies or restarts.

Each frame is copied exactly once out of its slot (never handed out as a view): the writer reuses
the slot ``slots`` frames later while a consumer may still hold the frame, and the slot's seqlock
can only validate a copy that is complete.
"""

from __future__ import annotations

import contextlib
import os
import struct
import sys
import threading
import time
from collections.abc import Iterable
from multiprocessing import resource_tracker, shared_memory
from pathlib import Path

import numpy as np

from snrmon.drivers.camera.base import CameraDevice
from snrmon.drivers.camera.format import CameraFormat
from snrmon.drivers.camera.frame import Frame

MAGIC = b"SNRMRING"
VERSION = 1
HEADER_BYTES = 128
SLOT_HEADER_BYTES = 64
WRITER_CLOSED = 1
HAS_DEVICE_TIME = 1
# Header fields as (offset, struct format); see docs/shm-frame-ring.md.
_HEADER = struct.Struct("<8sIIII8sIIQQIIQ")
_U64_SESSION = 48 // 8
_U64_WRITE_INDEX = 64 // 8
_U32_FLAGS = 36 // 4


_TRACKER_PATCH = threading.Lock()


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, another user's process
        return True
    return not _ended(pid)


def _ended(pid: int) -> bool:
    """Whether ``pid`` ended but was not reaped yet (a zombie): it still answers ``kill(pid,
    0)``. A camera process started by this very process (``snrmon hil``'s, ``demo``'s) and
    killed stays one until multiprocessing is next asked about its children."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:  # no /proc (not Linux), or it ended meanwhile: kill(pid, 0) said alive
        return False
    return stat.rsplit(")", 1)[-1].split()[:1] in (["Z"], ["X"])


def _attach_untracked(name: str) -> shared_memory.SharedMemory:
    """Attach without Python 3.11's resource tracker, which would unlink the writer's ring when
    this (reading) process exits; the writer owns the ring's lifetime."""
    if sys.version_info >= (3, 13):
        return shared_memory.SharedMemory(name, track=False)  # type: ignore[call-arg]
    with _TRACKER_PATCH:
        register = resource_tracker.register
        resource_tracker.register = lambda *a, **k: None  # type: ignore[assignment]
        try:
            return shared_memory.SharedMemory(name)
        finally:
            resource_tracker.register = register  # type: ignore[assignment]


POLL_FROM = 0.6
"""The part of a frame period after a frame during which the reader sleeps before it polls for
the next one. Polling every 0.25 ms all the time woke each camera's reader 4000 times a second,
each time taking the interpreter lock and a core from the measurement; now 1600-1700 (60 and
30 fps), and a frame up to 40 % of a period early is still caught at the polling rate."""


class ShmCamera(CameraDevice):
    """A camera fed through a shared-memory frame ring written by another process.

    Args:
        name: the camera's name in frames and status (``"mwir"``).
        shm_name: name of the shared-memory object (without the leading ``/``).
        poll_s: how often ``write_index`` is polled while waiting for a frame that is due
            (:data:`POLL_FROM`: from 60 % of a frame period after the last frame on, at the rate
            the ring's header gives; all the time when it gives none).
        reuse_buffers: 0 (default) copies each frame into a new array, which consumers may keep
            forever; ``N >= 2`` copies round-robin into N preallocated arrays, so a consumer may
            hold a frame only while fewer than N newer frames arrived.
        **kw: passed to :class:`snrmon.drivers.device.Device` (``stale_after_s`` ...).
    """

    def __init__(
        self, name: str, shm_name: str, *, poll_s: float = 0.00025, reuse_buffers: int = 0, **kw
    ) -> None:
        super().__init__(name, **kw)
        if not shm_name or "/" in shm_name:
            raise ValueError(f"shared-memory name must be a plain name, got {shm_name!r}")
        if reuse_buffers == 1 or reuse_buffers < 0:
            raise ValueError(f"reuse_buffers must be 0 or at least 2, got {reuse_buffers}")
        self.shm_name = shm_name
        self.poll_s = poll_s
        self.reuse_buffers = reuse_buffers
        self.overruns = 0
        self.frames_lost_to_overrun = 0
        self._shm: shared_memory.SharedMemory | None = None
        self._pool: list[np.ndarray] = []
        self._pool_next = 0
        self._quiet_until = 0.0  # monotonic s: no frame is due before then (POLL_FROM)

    # ----------------------------------------------------------------- link
    def _connect(self) -> None:
        try:
            shm = _attach_untracked(self.shm_name)
        except FileNotFoundError as exc:
            raise OSError(f"no frame ring named {self.shm_name!r} (writer not running)") from exc
        try:
            self._attach(shm)
        except OSError:
            self._release(shm)
            raise
        self._shm = shm

    def _attach(self, shm: shared_memory.SharedMemory) -> None:
        if shm.size < HEADER_BYTES:
            raise OSError(f"frame ring {self.shm_name!r} is too small ({shm.size} bytes)")
        (
            magic,
            version,
            header_bytes,
            width,
            height,
            dtype,
            slots,
            flags,
            stride,
            session,
            pid,
            fps_milli,
            write_index,
        ) = _HEADER.unpack_from(shm.buf, 0)
        if magic != MAGIC or version != VERSION:
            raise OSError(
                f"{self.shm_name!r} is not a version-{VERSION} frame ring "
                f"(magic {magic!r}, version {version})"
            )
        dtype_s = dtype.rstrip(b"\0").decode("ascii", "replace")
        if dtype_s != "<u2" or header_bytes != HEADER_BYTES:
            raise OSError(f"frame ring {self.shm_name!r} has unsupported dtype {dtype_s!r}")
        if session == 0 or flags & WRITER_CLOSED:
            raise OSError(f"frame ring {self.shm_name!r} has no active writer")
        frame_bytes = width * height * 2
        if slots < 2 or stride < SLOT_HEADER_BYTES + frame_bytes:
            raise OSError(f"frame ring {self.shm_name!r}: bad geometry {slots} x {stride} B")
        if shm.size < header_bytes + slots * stride:
            raise OSError(f"frame ring {self.shm_name!r} is smaller than its header says")
        if pid and not _pid_alive(pid):
            raise OSError(f"frame ring {self.shm_name!r}: writer pid {pid} is not running")
        buf = shm.buf
        self._hdr64 = np.ndarray((HEADER_BYTES // 8,), "<u8", buf, 0)
        self._hdr32 = np.ndarray((HEADER_BYTES // 4,), "<u4", buf, 0)
        self._slot_hdr = np.ndarray((slots, 4), "<u8", buf, header_bytes, (stride, 8))
        self._slot_flags = np.ndarray((slots,), "<u4", buf, header_bytes + 32, (stride,))
        self._slot_px = np.ndarray(
            (slots, height, width),
            "<u2",
            buf,
            header_bytes + SLOT_HEADER_BYTES,
            (stride, width * 2, 2),
        )
        self._slots = slots
        self._session = session
        self._pid = pid
        self._next = write_index
        self._last_pid_check = time.monotonic()
        if not self._pool or self._pool[0].shape != (height, width):
            self._pool = [np.empty((height, width), np.uint16) for _ in range(self.reuse_buffers)]
        self._negotiated(
            CameraFormat(width, height, "Mono16", fps_milli / 1000.0 if fps_milli else None)
        )

    def _release(self, shm: shared_memory.SharedMemory) -> None:
        for attr in ("_hdr64", "_hdr32", "_slot_hdr", "_slot_flags", "_slot_px"):
            if hasattr(self, attr):
                delattr(self, attr)  # numpy views must go before the mapping can close
        with contextlib.suppress(BufferError):  # a view still exported: unmapped at exit
            shm.close()

    def _disconnect(self) -> None:
        if self._shm is not None:
            shm, self._shm = self._shm, None
            self._release(shm)

    # ----------------------------------------------------------------- frames
    def _check_writer(self, idle: bool) -> None:
        if int(self._hdr64[_U64_SESSION]) != self._session:
            raise OSError(f"frame ring {self.shm_name!r}: writer restarted (new session)")
        if int(self._hdr32[_U32_FLAGS]) & WRITER_CLOSED:
            raise OSError(f"frame ring {self.shm_name!r}: writer closed")
        now = time.monotonic()
        if idle and self._pid and now - self._last_pid_check > 0.25:
            self._last_pid_check = now
            if not _pid_alive(self._pid):
                raise OSError(f"frame ring {self.shm_name!r}: writer pid {self._pid} died")

    def _read(self) -> Iterable[Frame]:
        deadline = time.monotonic() + 0.1
        while True:
            written = int(self._hdr64[_U64_WRITE_INDEX])
            self._check_writer(idle=written <= self._next)
            if written > self._next:
                break
            now = time.monotonic()
            if now > deadline:
                return []
            time.sleep(max(self.poll_s, min(self._quiet_until, deadline) - now))
        frames = []
        while self._next < written:
            frame = self._copy_frame(written)
            if frame is not None:
                frames.append(frame)
            written = int(self._hdr64[_U64_WRITE_INDEX])
        return frames

    def _overrun(self, written: int) -> None:
        """Fell too far behind or lost a race with the writer: jump to the newest frame."""
        newest = written - 1
        self.overruns += 1
        self.frames_lost_to_overrun += max(0, newest - self._next)
        self._next = newest

    def _copy_frame(self, written: int) -> Frame | None:
        slots = self._slots
        if self._next < written - slots + 1:
            self._overrun(written)
        n = self._next
        i = n % slots
        stable = 2 * n + 2
        if int(self._slot_hdr[i, 0]) != stable:
            self._overrun(int(self._hdr64[_U64_WRITE_INDEX]))
            return None
        if self._pool:
            out = self._pool[self._pool_next]
            self._pool_next = (self._pool_next + 1) % len(self._pool)
        else:
            out = np.empty(self._slot_px.shape[1:], np.uint16)
        np.copyto(out, self._slot_px[i])
        counter, t_dev, t_write = (int(v) for v in self._slot_hdr[i, 1:4])
        flags = int(self._slot_flags[i])
        if int(self._slot_hdr[i, 0]) != stable:  # torn: overwritten during the copy
            self._overrun(int(self._hdr64[_U64_WRITE_INDEX]))
            return None
        self._next = n + 1
        t_host = time.monotonic_ns()
        fps = self.format.fps if self.format is not None else None
        self._quiet_until = t_host / 1e9 + POLL_FROM / fps if fps else 0.0
        self._account(counter)
        if flags & HAS_DEVICE_TIME:
            t_device: int | None = t_dev - (1 << 64) if t_dev >= 1 << 63 else t_dev
        else:
            t_device = None
        return Frame(
            pixels=out,
            camera=self.name,
            counter=counter,
            t_host_ns=t_host,
            t_device_ns=t_device,
            meta={"format": self.format, "t_write_ns": t_write, "ring_index": n},
        )
