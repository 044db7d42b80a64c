"""FrameRing: every frame reaches a reader that keeps up, losses are counted, peek never waits."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from snrmon.acquisition.streams.ring import RING_OVERRUN, FrameRing, OverflowPolicy
from snrmon.drivers.camera.frame import Frame

H, W = 64, 80


def frame(i: int, camera: str = "lwir") -> Frame:
    pixels = np.full((H, W), i % 65536, np.uint16)
    pixels[0, 0] = (i * 7) % 65536
    return Frame(pixels, camera, counter=1000 + i, t_host_ns=10_000 + i * 1000, t_device_ns=i)


def test_reader_sees_every_frame_in_order_with_metadata() -> None:
    ring = FrameRing(8, H, W, name="lwir")
    reader = ring.reader("recorder")
    for i in range(5):
        assert ring.push(frame(i))
    got = [reader.pop_next(timeout=0) for _ in range(5)]
    assert [g.seq for g in got] == [0, 1, 2, 3, 4]
    assert [g.counter for g in got] == [1000, 1001, 1002, 1003, 1004]
    assert [g.t_host_ns for g in got] == [10_000, 11_000, 12_000, 13_000, 14_000]
    assert [g.t_device_ns for g in got] == [0, 1, 2, 3, 4]
    for i, g in enumerate(got):
        np.testing.assert_array_equal(g.pixels, frame(i).pixels)
        assert g.camera == "lwir"
    assert reader.pop_next(timeout=0) is None
    assert reader.overruns == 0 and not ring.overflow


def test_zero_copy_acquire_finalize_and_missing_device_time() -> None:
    ring = FrameRing(4, H, W)
    reader = ring.reader("m")
    slot = ring.acquire_slot()
    assert slot is not None and slot.shape == (H, W)
    slot[:] = 123
    assert ring.finalize_slot(counter=7, t_host_ns=99) == 0
    got = reader.pop_next(timeout=0)
    assert got.counter == 7 and got.t_host_ns == 99 and got.t_device_ns is None
    assert int(got.pixels.max()) == 123 and int(got.pixels.min()) == 123
    with pytest.raises(RuntimeError):
        ring.finalize_slot(1, 1)


def test_slow_reader_overrun_is_counted_flagged_and_skipped() -> None:
    ring = FrameRing(4, H, W)
    slow = ring.reader("recorder")
    fast = ring.reader("measure")
    for i in range(10):
        ring.push(frame(i))
        assert fast.pop_next(timeout=0).seq == i  # keeps up, loses nothing
    # slow read nothing: frames 0..5 were overwritten, 6..9 are still in the ring
    got = [slow.pop_next(timeout=0) for _ in range(4)]
    assert [g.seq for g in got] == [6, 7, 8, 9]
    assert slow.overruns == 6
    assert slow.stats().lost == {RING_OVERRUN: 6}
    assert fast.overruns == 0
    assert ring.overflow
    stats = ring.stats()
    assert stats.pushed == 10 and stats.dropped_full == 0
    assert {r.name: r.overruns for r in stats.readers} == {"recorder": 6, "measure": 0}


def test_drop_newest_policy_refuses_new_frames_and_keeps_unread_ones() -> None:
    ring = FrameRing(4, H, W, policy=OverflowPolicy.DROP_NEWEST)
    reader = ring.reader("recorder")
    accepted = [ring.push(frame(i)) for i in range(6)]
    assert accepted == [True, True, True, True, False, False]
    assert ring.stats().dropped_full == 2 and ring.overflow
    assert [reader.pop_next(timeout=0).counter for _ in range(4)] == [1000, 1001, 1002, 1003]
    assert reader.overruns == 0
    assert ring.push(frame(6))  # room again once read
    assert reader.pop_next(timeout=0).counter == 1006


def test_cancelled_slot_counts_as_lost_for_a_reader_behind() -> None:
    ring = FrameRing(2, H, W)
    reader = ring.reader("r")
    ring.push(frame(0))
    ring.push(frame(1))
    assert ring.acquire_slot() is not None  # starts overwriting frame 0's slot
    ring.cancel_slot()
    assert reader.pop_next(timeout=0).seq == 1
    assert reader.overruns == 1


def test_peek_last_returns_newest_without_consuming_and_never_waits() -> None:
    ring = FrameRing(4, H, W)
    assert ring.peek_last() is None  # empty: returns at once
    reader = ring.reader("r")
    for i in range(3):
        ring.push(frame(i))
    out = np.empty((H, W), np.uint16)
    last = ring.peek_last(out=out)
    assert last.seq == 2 and last.pixels is out and int(out[1, 1]) == 2
    assert reader.pop_next(timeout=0).seq == 0  # peek consumed nothing
    # peek while the producer holds a slot open: still returns the last complete frame
    assert ring.acquire_slot() is not None
    assert ring.peek_last().seq == 2
    ring.finalize_slot(5, 5)


def test_shape_mismatch_is_one_clear_error() -> None:
    ring = FrameRing(4, H, W)
    bad = Frame(np.zeros((H, W + 1), np.uint16), "mwir", 0, 0)
    with pytest.raises(ValueError, match=r"\(64, 81\).*'mwir'"):
        ring.push(bad)
    with pytest.raises(ValueError, match="capacity"):
        FrameRing(1, H, W)


def test_pop_next_times_out_and_close_wakes_a_waiting_reader() -> None:
    ring = FrameRing(4, H, W)
    reader = ring.reader("r")
    assert reader.pop_next(timeout=0.01) is None
    result: list = []
    started = threading.Event()

    def wait_forever() -> None:
        started.set()
        result.append(reader.pop_next(timeout=None))

    t = threading.Thread(target=wait_forever)
    t.start()
    assert started.wait(5)
    reader.close()
    t.join(5)
    assert not t.is_alive() and result == [None]
    assert ring.stats().readers == []


def test_producer_thread_with_two_readers_and_a_peeker_loses_nothing() -> None:
    """Thread safety: every frame arrives intact (pixel pattern matches seq) at both readers."""
    n = 3000
    ring = FrameRing(n + 1, 16, 16, policy=OverflowPolicy.DROP_NEWEST)
    readers = [ring.reader("recorder"), ring.reader("measure")]
    seen: dict[str, list[int]] = {r.name: [] for r in readers}
    torn: list[int] = []
    done = threading.Event()

    def consume(r) -> None:
        out = np.empty((16, 16), np.uint16)
        while len(seen[r.name]) < n:
            item = r.pop_next(timeout=5, out=out)
            if item is None:
                return
            if not (out == item.counter % 65536).all():
                torn.append(item.seq)
            seen[r.name].append(item.seq)

    def peek() -> None:
        while not done.is_set():
            item = ring.peek_last()
            if item is not None and not (item.pixels == item.counter % 65536).all():
                torn.append(item.seq)

    threads = [threading.Thread(target=consume, args=(r,)) for r in readers]
    threads.append(threading.Thread(target=peek))
    for t in threads:
        t.start()
    for i in range(n):
        slot = ring.acquire_slot()
        assert slot is not None
        slot[:] = i % 65536
        ring.finalize_slot(i, i)
    for t in threads[:2]:
        t.join(20)
    done.set()
    threads[2].join(5)
    assert torn == []
    for name in seen:
        assert seen[name] == list(range(n))
    assert not ring.overflow


def test_overwriting_producer_thread_never_hands_out_a_torn_frame() -> None:
    """A reader far slower than the producer: losses counted, every returned frame intact."""
    rng = np.random.default_rng(6)
    ring = FrameRing(3, 32, 32)
    reader = ring.reader("slow")
    n = 2000
    got: list[int] = []
    bad: list[int] = []
    finished = threading.Event()

    def produce() -> None:
        for i in range(n):
            slot = ring.acquire_slot()
            slot[:] = i % 65536
            ring.finalize_slot(i, i)
        finished.set()

    t = threading.Thread(target=produce)
    t.start()
    while True:
        item = reader.pop_next(timeout=0.05)
        if item is None:
            if finished.is_set() and reader.lag == 0:
                break
            continue
        if not (item.pixels == item.counter % 65536).all():
            bad.append(item.seq)
        got.append(item.seq)
        if rng.random() < 0.1:
            finished.wait(0.001)  # lets the producer run ahead now and then
    t.join(5)
    assert bad == []
    assert got == sorted(got) and len(set(got)) == len(got)
    assert got[-1] == n - 1
    assert len(got) + reader.overruns == n  # every frame accounted for


def test_the_ring_is_resident_from_the_start():
    """Preallocated means committed: the ring's pages are written at construction, so the first
    pass of acquisition takes no page faults and a short machine fails at start-up."""
    import subprocess
    import sys

    # In a fresh interpreter: after a long test session the allocator may hand back pages that
    # are already resident, and RSS would not show the commit.
    code = (
        "import psutil\n"
        "from acquisition.streams.ring import FrameRing\n"
        "proc = psutil.Process()\n"
        "before = proc.memory_info().rss\n"
        "ring = FrameRing(32, 1024, 1024)  # 64 MiB by mmap: fresh, untouched pages\n"
        "print(proc.memory_info().rss - before, ring.slots.pixels.nbytes)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    grown, nbytes = (int(v) for v in out.stdout.split())
    assert grown >= 0.9 * nbytes
