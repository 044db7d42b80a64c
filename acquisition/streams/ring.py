"""The per-camera frame ring: one producer, readers that see every frame, a latest-frame peek.

Design after pymmcore-plus ``SequenceBuffer``: a preallocated pool of frame
slots (pixels plus counter, host and device time), written in place by the acquisition thread
through ``acquire_slot``/``finalize_slot`` (zero-copy) or ``push``. Consumers:

- the display calls ``peek_last()`` at its own rate and only ever gets the newest frame; it never
  queues frames and never blocks the producer;
- the recorder and the measurement each hold a ``Reader`` whose ``pop_next(timeout)`` returns
  every frame in order, as long as they keep up.

The producer never waits for a consumer. What happens when a reader falls a full ring behind is
an explicit policy:

- ``OverflowPolicy.OVERWRITE_OLDEST`` (default): the newest frame always goes in; the slow reader
  loses the oldest frames, counted in its ``overruns`` with the reason ``"ring_overrun"``;
- ``OverflowPolicy.DROP_NEWEST``: nothing a reader has not yet read is overwritten; the new frame
  is refused (``acquire_slot`` returns ``None``) and counted in ``dropped_full``;
- ``OverflowPolicy.WAIT``: the producer waits until the slowest reader has read the slot it needs
  (back-pressure, for a producer that can wait: a simulated camera, a file); after ``wait_s``
  without progress (a consumer that died) it overwrites the oldest as ``OVERWRITE_OLDEST`` does,
  so a stuck consumer never stops acquisition for good.

Either way a lost frame sets the ring's ``overflow`` flag, which stays set. Readers copy a
frame out and then check that the producer did not start overwriting its slot during the copy
(a seqlock-style check); a torn copy is discarded and counted as an overrun, never returned.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

from snrmon.drivers.camera.frame import Frame

NO_DEVICE_TIME = np.iinfo(np.int64).min
"""Stored in ``t_device_ns`` when the camera gives no timestamp of its own."""

RING_OVERRUN = "ring_overrun"
"""Reason for frames a reader lost because the producer overwrote them before it read them."""


class OverflowPolicy(StrEnum):
    """What the producer does when the slot it needs has not been read by every reader."""

    OVERWRITE_OLDEST = "overwrite_oldest"
    DROP_NEWEST = "drop_newest"
    WAIT = "wait"


@dataclass(frozen=True, slots=True)
class RingFrame:
    """One frame copied out of the ring.

    ``seq`` is the ring's own sequence number (0 for the first frame pushed, no gaps), so a
    consumer can tell console drops (``seq`` gaps) from camera drops (``counter`` gaps).
    ``t_ring_ns``: when the frame was published in the ring (monotonic; 0 for a frame not
    from a ring), so a consumer can tell the producer's push from its own wait.
    """

    pixels: np.ndarray
    seq: int
    counter: int
    t_host_ns: int
    t_device_ns: int | None
    camera: str = ""
    t_ring_ns: int = 0


@dataclass(frozen=True, slots=True)
class ReaderStats:
    """Counts of one reader: frames returned, frames lost and why."""

    name: str
    popped: int
    overruns: int
    lost: dict[str, int]
    lag: int


@dataclass(frozen=True, slots=True)
class RingStats:
    """Public status of a ring (frames pushed, refused, overflow flag, per-reader counts)."""

    capacity: int
    pushed: int
    dropped_full: int
    overflow: bool
    readers: list[ReaderStats] = field(default_factory=list)


class RingSlots:
    """The ring's preallocated storage: each slot's pixels and the metadata published with them
    (camera counter, host time, device time, when it was published). Indexed by slot; the ring
    says which slot holds which frame and guards them with its lock."""

    def __init__(self, capacity: int, shape: tuple[int, int], dtype: np.dtype) -> None:
        self.shape = shape
        self.pixels = np.empty((capacity, *shape), dtype)
        # Write every page now: the OS commits untouched memory lazily, so without this the
        # ring's first pass takes a page fault per 4 kB inside acquisition (MWIR: 27,000 a
        # second for the first two seconds) and a machine short of memory fails mid-session
        # instead of at start-up.
        self.pixels.fill(0)
        self.counter = np.zeros(capacity, np.int64)
        self.t_host = np.zeros(capacity, np.int64)
        self.t_device = np.full(capacity, NO_DEVICE_TIME, np.int64)
        self.t_ring = np.zeros(capacity, np.int64)

    def publish(self, i: int, counter: int, t_host_ns: int, t_device_ns: int | None) -> None:
        """Slot ``i``'s metadata, stamped with the time it is published (monotonic)."""
        self.counter[i] = counter
        self.t_host[i] = t_host_ns
        self.t_device[i] = NO_DEVICE_TIME if t_device_ns is None else t_device_ns
        self.t_ring[i] = time.monotonic_ns()


class FrameRing:
    """A preallocated ring of ``capacity`` frames of ``height`` x ``width`` pixels."""

    def __init__(
        self,
        capacity: int,
        height: int,
        width: int,
        dtype: np.dtype | type = np.uint16,
        *,
        policy: OverflowPolicy | str = OverflowPolicy.OVERWRITE_OLDEST,
        name: str = "",
        wait_s: float = 10.0,
    ) -> None:
        if int(capacity) < 2:
            raise ValueError(f"ring capacity must be at least 2 frames, got {capacity}")
        if int(height) < 1 or int(width) < 1:
            raise ValueError(f"ring frame shape must be positive, got {height} x {width}")
        self.capacity = int(capacity)
        self.policy = OverflowPolicy(policy)
        self.wait_s = float(wait_s)
        self.name = name
        self.slots = RingSlots(self.capacity, (int(height), int(width)), np.dtype(dtype))
        self._cond = threading.Condition(threading.Lock())
        self._next_seq = 0  # sequence number of the next frame to be finalized
        self._writing = False  # a slot is acquired and being filled
        self._floor = 0  # frames below this were (or are being) overwritten, even if cancelled
        self._dropped_full = 0
        self._overflow = False
        self._readers: list[Reader] = []

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, columns) of every frame the ring holds."""
        return self.slots.shape

    @property
    def dtype(self) -> np.dtype:
        return self.slots.pixels.dtype

    # -- producer -------------------------------------------------------------------------------

    def acquire_slot(self) -> np.ndarray | None:
        """The pixel array of the next slot to fill in place, or ``None`` if the frame must be
        dropped (``DROP_NEWEST`` policy with a reader a full ring behind). Call
        ``finalize_slot`` (or ``cancel_slot``) before acquiring again."""
        with self._cond:
            if self._writing:
                raise RuntimeError("acquire_slot called twice without finalize_slot")
            seq = self._next_seq
            if seq >= self.capacity and self.policy is OverflowPolicy.WAIT:
                # Back-pressure: wait for the slowest reader to leave the slot this frame needs.
                deadline = time.monotonic() + self.wait_s
                while any(r._cursor <= seq - self.capacity for r in self._readers):
                    remaining = deadline - time.monotonic()
                    if remaining <= 0:
                        break  # a stuck consumer: overwrite, counted as its overrun
                    self._cond.wait(min(remaining, 0.1))
            if seq >= self.capacity:
                oldest_needed = seq - self.capacity  # the frame this slot still holds
                behind = [r for r in self._readers if r._cursor <= oldest_needed]
                if behind:
                    self._overflow = True
                    if self.policy is OverflowPolicy.DROP_NEWEST:
                        self._dropped_full += 1
                        return None
            self._writing = True
            self._floor = max(self._floor, seq + 1 - self.capacity)
            return self.slots.pixels[seq % self.capacity]

    def finalize_slot(self, counter: int, t_host_ns: int, t_device_ns: int | None = None) -> int:
        """Publish the acquired slot with its metadata; returns its sequence number."""
        with self._cond:
            if not self._writing:
                raise RuntimeError("finalize_slot called without acquire_slot")
            seq = self._next_seq
            self.slots.publish(seq % self.capacity, counter, t_host_ns, t_device_ns)
            self._next_seq = seq + 1
            self._writing = False
            self._cond.notify_all()
            return seq

    def cancel_slot(self) -> None:
        """Give up the acquired slot (the camera read failed). In ``OVERWRITE_OLDEST`` mode the
        frame the slot held is already gone; readers account for it as an overrun."""
        with self._cond:
            self._writing = False

    def push(self, frame: Frame) -> bool:
        """Copy a driver ``Frame`` into the ring; ``False`` if it was dropped (policy)."""
        if frame.pixels.shape != self.shape:
            raise ValueError(
                f"frame shape {frame.pixels.shape} from {frame.camera!r} does not match the "
                f"ring's {self.shape}"
            )
        slot = self.acquire_slot()
        if slot is None:
            return False
        try:
            np.copyto(slot, frame.pixels, casting="same_kind")
        except BaseException:
            self.cancel_slot()
            raise
        self.finalize_slot(frame.counter, frame.t_host_ns, frame.t_device_ns)
        return True

    # -- consumers ------------------------------------------------------------------------------

    def reader(self, name: str, *, from_latest: bool = True) -> Reader:
        """A new cursor that sees every frame from now on (``from_latest``) or from the oldest
        frame still in the ring."""
        with self._cond:
            start = self._next_seq if from_latest else self._low_seq()
            r = Reader(self, name, start)
            self._readers.append(r)
            return r

    def peek_last(
        self, out: np.ndarray | None = None, *, unless_seq: int | None = None
    ) -> RingFrame | None:
        """The newest complete frame (a copy, into ``out`` if given), or ``None`` if there is
        none yet, or if its ``seq`` is ``unless_seq`` (a display that has it already: nothing
        is copied). Never waits for the producer and never consumes anything."""
        for _ in range(3):  # a torn copy means a newer frame exists: take that one
            with self._cond:
                if self._next_seq == 0 or self._low_seq() >= self._next_seq:
                    return None
                seq = self._next_seq - 1
                if seq == unless_seq:
                    return None
            item = self._copy_out(seq, out)
            if item is not None:
                return item
        return None

    @property
    def overflow(self) -> bool:
        """True once any frame was lost by a reader or refused by the ring."""
        with self._cond:
            return self._overflow

    @property
    def pushed(self) -> int:
        """Frames published so far."""
        with self._cond:
            return self._next_seq

    @property
    def newest_counter(self) -> int | None:
        """The camera counter of the newest frame published (None before the first): cheap, no
        pixels copied."""
        with self._cond:
            if self._next_seq == 0:
                return None
            return int(self.slots.counter[(self._next_seq - 1) % self.capacity])

    def stats(self) -> RingStats:
        """A snapshot of the ring's counters and of every open reader's."""
        with self._cond:
            readers = [r._stats_locked() for r in self._readers]
            return RingStats(
                self.capacity, self._next_seq, self._dropped_full, self._overflow, readers
            )

    # -- internals (callers hold no lock unless noted) --------------------------------------------

    def _low_seq(self) -> int:
        """Oldest sequence number still intact in the ring (caller holds the lock)."""
        return max(0, self._floor, self._next_seq - self.capacity)

    def _copy_out(self, seq: int, out: np.ndarray | None) -> RingFrame | None:
        i = seq % self.capacity
        slots = self.slots
        pixels = slots.pixels[i].copy() if out is None else out
        if out is not None:
            np.copyto(out, slots.pixels[i])
        with self._cond:
            counter = int(slots.counter[i])
            t_host = int(slots.t_host[i])
            t_dev = int(slots.t_device[i])
            t_ring = int(slots.t_ring[i])
            intact = seq >= self._low_seq()
        if not intact:
            return None
        return RingFrame(
            pixels,
            seq,
            counter,
            t_host,
            None if t_dev == NO_DEVICE_TIME else t_dev,
            self.name,
            t_ring,
        )

    def _remove(self, reader: Reader) -> None:
        with self._cond:
            if reader in self._readers:
                self._readers.remove(reader)
            self._cond.notify_all()


class Reader:
    """A consumer's cursor on a ``FrameRing``; use it from one thread only."""

    def __init__(self, ring: FrameRing, name: str, start_seq: int) -> None:
        self.ring = ring
        self.name = name
        self._cursor = start_seq
        self._popped = 0
        self._lost: dict[str, int] = {}
        self._closed = False

    def pop_next(
        self, timeout: float | None = None, out: np.ndarray | None = None
    ) -> RingFrame | None:
        """The next frame in order (copied, into ``out`` if given), waiting up to ``timeout``
        seconds (``None``: forever); ``None`` on timeout or once the reader is closed. Frames
        overwritten before they could be read are skipped and counted as overruns."""
        ring = self.ring
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            with ring._cond:
                while not self._closed and self._cursor >= ring._next_seq:
                    remaining = None if deadline is None else deadline - time.monotonic()
                    if remaining is not None and remaining <= 0:
                        return None
                    ring._cond.wait(remaining)
                if self._closed:
                    return None
                self._skip_overwritten_locked()
                seq = self._cursor
            item = ring._copy_out(seq, out)
            with ring._cond:
                if item is None:  # overwritten while copying
                    self._skip_overwritten_locked()
                    continue
                self._cursor = seq + 1
                self._popped += 1
                if ring.policy is OverflowPolicy.WAIT:
                    ring._cond.notify_all()  # a producer may be waiting for this slot
                return item

    @property
    def overruns(self) -> int:
        """Frames this reader lost because the producer overwrote them first."""
        with self.ring._cond:
            return self._lost.get(RING_OVERRUN, 0)

    @property
    def lag(self) -> int:
        """Frames published but not yet read by this reader."""
        with self.ring._cond:
            return self.ring._next_seq - self._cursor

    def stats(self) -> ReaderStats:
        with self.ring._cond:
            return self._stats_locked()

    def close(self) -> None:
        """Detach from the ring (wakes a ``pop_next`` waiting in another thread)."""
        with self.ring._cond:
            self._closed = True
        self.ring._remove(self)

    def _skip_overwritten_locked(self) -> None:
        low = self.ring._low_seq()
        if self._cursor < low:
            self._lost[RING_OVERRUN] = self._lost.get(RING_OVERRUN, 0) + low - self._cursor
            self.ring._overflow = True
            self._cursor = low

    def _stats_locked(self) -> ReaderStats:
        return ReaderStats(
            self.name,
            self._popped,
            self._lost.get(RING_OVERRUN, 0),
            dict(self._lost),
            self.ring._next_seq - self._cursor,
        )
