"""Simulated camera, writer side of the shared-memory frame ring (``docs/shm-frame-ring.md``).

Written from the documented layout alone (``sim`` never imports ``drivers``), so it doubles as a
check that the document is enough to build a writer, e.g. a vendor grabber.

* :class:`ShmFrameWriter` owns one ring and publishes frames into it.
* :class:`ShmProducer` runs a writer in a separate process (spawn-safe) that calls a picklable
  ``render(counter) -> np.ndarray`` at an exact rate (absolute-time pacing: frame k is due at
  ``t0 + k / fps``, so sleep overshoot never accumulates) or as fast as possible. It can skip
  counters (link drops), pause (a silent camera), stop cleanly, be killed (a camera lost without
  goodbye) and be started again (the camera is back, its counter restarted). Like a real camera
  it never falls behind its own clock: a frame it could not render in time is lost (a counter
  gap), so the picture stays in step with the flight the serial simulators report.
* With a shared ``clock`` (a ``multiprocessing.Value("d")`` of camera seconds, written by whoever
  runs the simulated day) the camera follows that clock instead of the wall: frame k is published
  once the clock reads ``k / fps``, never skipped. A simulated day that has no real time to keep
  holds its clock back while the console is busy, and every camera waits with it (no drop).
"""

from __future__ import annotations

import _posixshmem
import multiprocessing as mp
import os
import secrets
import signal
import struct
import sys
import threading
import time
from collections.abc import Callable, Collection
from multiprocessing import resource_tracker, shared_memory

import numpy as np

_MAGIC = b"SNRMRING"
_VERSION = 1
_HEADER_BYTES = 128
_SLOT_HEADER_BYTES = 64
_CLOSED = 1
_HAS_DEVICE_TIME = 1
_FIXED = struct.Struct("<8sIIII8sII")  # magic .. flags, offsets 0..39
_STRIDE_AT, _SESSION_AT, _PID_AT, _FPS_AT, _WRITE_INDEX_AT, _FLAGS_AT = 40, 48, 56, 60, 64, 36

LAG_LIMIT_NS = 250_000_000  # behind its own clock by more than this, the camera drops frames


class ShmFrameWriter:
    """Creates (or re-initialises) a frame ring and publishes uint16 frames into it.

    Args:
        name: shared-memory object name (no ``/``).
        width, height: frame size in pixels.
        slots: ring length (at least 2).
        fps: nominal rate written to the header for readers to report; ``None`` = free-running.
    """

    def __init__(
        self, name: str, width: int, height: int, slots: int = 8, *, fps: float | None = None
    ) -> None:
        if width <= 0 or height <= 0:
            raise ValueError(f"frame size must be positive, got {width}x{height}")
        if slots < 2:
            raise ValueError(f"a frame ring needs at least 2 slots, got {slots}")
        self.name, self.width, self.height, self.slots = name, width, height, slots
        self.stride = -(-(_SLOT_HEADER_BYTES + width * height * 2) // 64) * 64
        size = _HEADER_BYTES + slots * self.stride
        try:
            shm = _untracked_shm(name, create=True, size=size)
        except FileExistsError:
            # A writer that crashed left its ring: reuse it when large enough (a reader still
            # mapping it sees the new session), else replace it.
            shm = _untracked_shm(name)
            if shm.size < size:
                shm.close()
                unlink_ring(name)
                shm = _untracked_shm(name, create=True, size=size)
        self._shm = shm
        buf = shm.buf
        self._h64 = np.ndarray((_HEADER_BYTES // 8,), "<u8", buf, 0)
        self._slot_u64 = np.ndarray((slots, 4), "<u8", buf, _HEADER_BYTES, (self.stride, 8))
        self._slot_flags = np.ndarray((slots,), "<u4", buf, _HEADER_BYTES + 32, (self.stride,))
        self._pixels = np.ndarray(
            (slots, height, width),
            "<u2",
            buf,
            _HEADER_BYTES + _SLOT_HEADER_BYTES,
            (self.stride, width * 2, 2),
        )
        self._h64[_SESSION_AT // 8] = 0  # readers treat session 0 as "initialising"
        _FIXED.pack_into(buf, 0, _MAGIC, _VERSION, _HEADER_BYTES, width, height, b"<u2", slots, 0)
        struct.pack_into("<Q", buf, _STRIDE_AT, self.stride)
        struct.pack_into("<Q", buf, _WRITE_INDEX_AT, 0)
        struct.pack_into("<II", buf, _PID_AT, os.getpid(), round((fps or 0.0) * 1000))
        self._slot_u64[:, 0] = 0
        buf[72:_HEADER_BYTES] = bytes(_HEADER_BYTES - 72)
        self.session = int.from_bytes(secrets.token_bytes(8), "little") | 1
        self._h64[_SESSION_AT // 8] = self.session
        self.frames_written = 0

    def write(self, pixels: np.ndarray, counter: int, t_device_ns: int | None = None) -> None:
        """Publish one frame with the camera's own ``counter`` (and its timestamp, if any)."""
        if pixels.shape != (self.height, self.width):
            raise ValueError(
                f"frame shape {pixels.shape} does not match the ring's {(self.height, self.width)}"
            )
        if pixels.dtype != np.uint16:
            raise ValueError(f"frame dtype must be uint16, got {pixels.dtype}")
        n = self.frames_written
        i = n % self.slots
        row = self._slot_u64[i]
        row[0] = 2 * n + 1  # odd: readers must not trust this slot
        np.copyto(self._pixels[i], pixels)
        row[1] = counter
        if t_device_ns is None:
            self._slot_flags[i] = 0
        else:
            row[2] = t_device_ns & 0xFFFFFFFFFFFFFFFF
            self._slot_flags[i] = _HAS_DEVICE_TIME
        row[3] = time.monotonic_ns()
        row[0] = 2 * n + 2  # even: complete, and it names frame n
        self.frames_written = n + 1
        self._h64[_WRITE_INDEX_AT // 8] = n + 1

    def close(self, unlink: bool = True) -> None:
        """Mark the ring closed for readers, unmap it, and remove its name (unless told not to)."""
        if self._shm is None:
            return
        flags = struct.unpack_from("<I", self._shm.buf, _FLAGS_AT)[0]
        struct.pack_into("<I", self._shm.buf, _FLAGS_AT, flags | _CLOSED)
        del self._h64, self._slot_u64, self._slot_flags, self._pixels
        shm, self._shm = self._shm, None
        shm.close()
        if unlink:
            unlink_ring(self.name)

    def __enter__(self) -> ShmFrameWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def unlink_ring(name: str) -> bool:
    """Remove the ring's name if it exists (readers keep their mapping); True if removed."""
    try:
        _posixshmem.shm_unlink("/" + name)
    except FileNotFoundError:
        return False
    return True


def _untracked_shm(name: str, create: bool = False, size: int = 0) -> shared_memory.SharedMemory:
    """Open or create the object without Python 3.11's resource tracker, which would unlink it
    when the creating process ends: a ring's lifetime is explicit (close(unlink=True)), and a
    killed writer must leave it for its restarted successor."""
    if sys.version_info >= (3, 13):
        return shared_memory.SharedMemory(name, create, size, track=False)  # type: ignore[call-arg]
    with _TRACKER_PATCH:
        register = resource_tracker.register
        resource_tracker.register = lambda *a, **k: None  # type: ignore[assignment]
        try:
            return shared_memory.SharedMemory(name, create, size)
        finally:
            resource_tracker.register = register  # type: ignore[assignment]


_TRACKER_PATCH = threading.Lock()


class RandomPattern:
    """Picklable render: frame ``counter`` is uniform random DN from a generator seeded by
    ``(seed, counter)``, so a test can recompute exactly what was written."""

    def __init__(self, width: int, height: int, seed: int = 0) -> None:
        self.width, self.height, self.seed = width, height, seed

    def __call__(self, counter: int) -> np.ndarray:
        rng = np.random.default_rng([self.seed, counter])
        return rng.integers(0, 65536, (self.height, self.width), dtype=np.uint16)


class StampPattern:
    """Picklable render that costs nothing: one constant frame with the counter in pixel 0
    (for throughput measurements where rendering must not be the bottleneck)."""

    def __init__(self, width: int, height: int, level: int = 1000) -> None:
        self.width, self.height, self.level = width, height, level
        self._frame: np.ndarray | None = None

    def __call__(self, counter: int) -> np.ndarray:
        if self._frame is None:
            self._frame = np.full((self.height, self.width), self.level, np.uint16)
        self._frame[0, 0] = counter & 0xFFFF
        return self._frame

    def __getstate__(self) -> dict:
        return {"width": self.width, "height": self.height, "level": self.level, "_frame": None}


def _produce(
    name: str,
    width: int,
    height: int,
    slots: int,
    render: Callable[[int], np.ndarray],
    fps: float | None,
    first_counter: int,
    drop_counters: frozenset[int],
    max_frames: int | None,
    ready: mp.Event,  # type: ignore[valid-type]
    stop: mp.Event,  # type: ignore[valid-type]
    paused: mp.Event,  # type: ignore[valid-type]
    done: mp.Event,  # type: ignore[valid-type]
    written: mp.Value,  # type: ignore[valid-type]
    skipped: mp.Value,  # type: ignore[valid-type]
    clock: mp.Value | None = None,  # type: ignore[valid-type]
    initializer: Callable[[], object] | None = None,
) -> None:
    """Body of the producer process (top level so that spawn can import it)."""
    # SIGTERM (a parent-death signal the initializer arms, a kill) ends the loop through its
    # finally: the ring is marked closed and unlinked, not left in /dev/shm.
    signal.signal(signal.SIGTERM, _terminated)
    if initializer is not None:
        initializer()
    writer = ShmFrameWriter(name, width, height, slots, fps=fps)
    # A killed console (SIGKILL, a test runner's timeout) never sets ``stop``: watch the parent
    # so the camera process does not outlive it, rendering into a ring no one reads.
    parent = os.getppid()
    if clock is not None:
        render(first_counter)  # the first render builds the scene: before the day's clock runs
    ready.set()
    counter = first_counter
    period_ns = round(1e9 / fps) if fps else 0
    t0 = time.monotonic_ns()
    k = 0
    try:
        while not stop.is_set():
            if os.getppid() != parent:
                break
            if max_frames is not None and written.value >= max_frames:
                done.set()
                stop.wait()
                break
            if paused.is_set():
                stop.wait(0.005)
                t0, k = time.monotonic_ns(), 0  # resume on a fresh schedule, no burst
                continue
            if clock is not None and fps:
                # The day's clock: wait until it reaches this frame (never skip one).
                due_s = k / fps
                if clock.value < due_s:
                    stop.wait(0.0005)
                    continue
                k += 1
            elif period_ns:
                due = t0 + k * period_ns
                wait_ns = due - time.monotonic_ns()
                if wait_ns > 0:
                    stop.wait(wait_ns / 1e9)
                elif -wait_ns > LAG_LIMIT_NS:
                    # A real camera's clock does not wait for a slow host: a short delay is
                    # caught up from its buffer, but the frames it could not deliver within
                    # LAG_LIMIT are lost (a gap in its counter) and the next one shows the scene
                    # at its own time, so the picture never lags the flight's clock for long.
                    behind = -wait_ns // period_ns
                    k += behind
                    counter += behind
                    skipped.value += behind
                k += 1
            if counter not in drop_counters:
                pixels = render(counter)
                writer.write(pixels, counter, t_device_ns=time.monotonic_ns())
                written.value += 1
            counter += 1
    finally:
        writer.close(unlink=True)


def _terminated(signum: int, _frame: object) -> None:
    raise SystemExit(128 + signum)


class ShmProducer:
    """A simulated camera: a separate process writing a frame ring at a paced or free rate.

    Args:
        name: ring name.
        width, height, slots: ring geometry.
        render: picklable callable ``render(counter) -> uint16 array (height, width)``; a
            top-level class with ``__call__`` (e.g. :class:`RandomPattern`).
        fps: frames per second, or ``None`` for as fast as possible.
        first_counter: the camera counter of the first frame after each start.
        drop_counters: counters never published (the reader must see them as drops).
        max_frames: stop publishing after this many frames (then ``done`` is set).
        clock: a shared ``multiprocessing`` double of camera seconds (the module docstring);
            with it, frame k is published once it reads ``k / fps``.
        initializer: a picklable callable the process runs first (e.g. one that binds its
            life to the parent's, ``snrmon.drivers.lifetime.die_with_parent``).
    """

    def __init__(
        self,
        name: str,
        width: int,
        height: int,
        render: Callable[[int], np.ndarray],
        *,
        fps: float | None = None,
        slots: int = 8,
        first_counter: int = 0,
        drop_counters: Collection[int] = (),
        max_frames: int | None = None,
        clock=None,
        initializer: Callable[[], object] | None = None,
    ) -> None:
        if fps is not None and fps <= 0:
            raise ValueError(f"fps must be positive or None, got {fps}")
        if clock is not None and fps is None:
            raise ValueError("a camera on a shared clock needs its fps")
        self._ctx = mp.get_context("spawn")
        self.name = name
        self._clock = clock
        self._initializer = initializer
        self._args = (
            name,
            width,
            height,
            slots,
            render,
            fps,
            first_counter,
            frozenset(drop_counters),
            max_frames,
        )
        self._proc: mp.process.BaseProcess | None = None
        self._new_sync()

    def _new_sync(self) -> None:
        """Fresh events for each process: a process killed inside ``Event.wait`` leaves that
        event's internal lock and sleeper count broken for good."""
        self.ready = self._ctx.Event()
        self.done = self._ctx.Event()
        self._stop = self._ctx.Event()
        self._paused = self._ctx.Event()
        # Lock-free: only the producer writes them.
        self._written = self._ctx.Value("q", 0, lock=False)
        self._skipped = self._ctx.Value("q", 0, lock=False)

    @property
    def frames_written(self) -> int:
        """Frames published since the last start."""
        return int(self._written.value)

    @property
    def frames_skipped(self) -> int:
        """Counters the camera skipped since the last start because the host fell more than
        ``LAG_LIMIT`` behind its frame clock (a real camera's lost frames; ``drop_counters``
        not included): what a reader must count as the camera's gaps."""
        return int(self._skipped.value)

    @property
    def pid(self) -> int | None:
        return None if self._proc is None else self._proc.pid

    def start(self, timeout_s: float = 20.0) -> None:
        """Start the process and wait until the ring is initialised."""
        if self._proc is not None and self._proc.is_alive():
            raise RuntimeError(f"producer {self.name!r} is already running")
        self._new_sync()
        self._proc = self._ctx.Process(
            target=_produce,
            args=(
                *self._args,
                self.ready,
                self._stop,
                self._paused,
                self.done,
                self._written,
                self._skipped,
                self._clock,
                self._initializer,
            ),
            name=f"shm-camera-{self.name}",
            daemon=True,
        )
        self._proc.start()
        if not self.ready.wait(timeout_s):
            self.kill()
            raise OSError(f"producer {self.name!r} did not start within {timeout_s} s")

    def pause(self) -> None:
        """Stop publishing but keep the process and ring alive (a silent camera)."""
        self._paused.set()

    def resume(self) -> None:
        self._paused.clear()

    def stop(self, timeout_s: float = 10.0) -> None:
        """Clean shutdown: the ring is marked closed and unlinked. A producer already dead
        (killed from outside: the OOM killer, a test) is only reaped: killed inside
        ``Event.wait`` it left that event's sleeper count for good, and setting the event would
        wait for a sleeper that never wakes."""
        if self._proc is not None and not self._proc.is_alive():  # is_alive reaps a zombie
            self._proc = None
            self._new_sync()
            return
        self._stop.set()
        if self._proc is not None:
            self._proc.join(timeout_s)
            if self._proc.is_alive():
                self.kill()
            self._proc = None

    def kill(self) -> None:
        """SIGKILL the producer: a camera lost without goodbye; the ring is left behind."""
        if self._proc is not None:
            self._proc.kill()
            self._proc.join(5.0)
            self._proc = None
            self._new_sync()

    def close(self) -> None:
        """Stop the producer and remove the ring even if the process died."""
        self.stop()
        unlink_ring(self.name)

    def __enter__(self) -> ShmProducer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
