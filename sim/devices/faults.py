"""Faults a simulated serial device can inject into the lines it sends.

One-shot faults are queued and applied to the next lines sent; silence holds until cleared.
The port vanishing and returning is :meth:`snrmon.sim.devices.line_sim.LineSimulator.unplug` (it is
a property of the port, not of a line).
"""

from __future__ import annotations

import random
import threading
from collections import deque


def corrupt_checksum(line: bytes) -> bytes:
    """The same sentence with a wrong ``*hh`` (or a flipped body byte if it has none)."""
    star = line.rfind(b"*")
    if star >= 0 and len(line) >= star + 3:
        value = int(line[star + 1 : star + 3], 16) ^ 0x5A
        return line[: star + 1] + b"%02X" % value + line[star + 3 :]
    return line[:1] + bytes([line[1] ^ 0x01]) + line[2:] if len(line) > 2 else line


def truncate(line: bytes, rng: random.Random) -> bytes:
    """The first part of a line and its line ending, as when bytes are lost mid-sentence."""
    body = line.rstrip(b"\r\n")
    cut = rng.randint(1, max(1, len(body) - 4))
    return body[:cut] + b"\r\n"


def garbage(rng: random.Random, n: int = 32) -> bytes:
    """Random bytes ending in a line break (line noise, a baud-rate mismatch)."""
    return bytes(rng.randrange(256) for _ in range(n)) + b"\r\n"


class FaultInjector:
    """Thread-safe fault requests consulted by a simulator for every line it sends.

    Args:
        seed: for the truncation points and garbage bytes.
    """

    def __init__(self, seed: int = 0) -> None:
        self._rng = random.Random(seed)
        self._lock = threading.Lock()
        self._queue: deque[str] = deque()
        self._silent = threading.Event()
        self._no_target = 0
        self.applied: dict[str, int] = {}

    # requests -------------------------------------------------------------------------------
    def corrupt_checksum(self, n: int = 1) -> None:
        self._push("checksum", n)

    def truncate(self, n: int = 1) -> None:
        self._push("truncate", n)

    def garbage(self, n: int = 1) -> None:
        """Send ``n`` lines of random bytes before the next real line."""
        self._push("garbage", n)

    def no_target(self, n: int = 1) -> None:
        """The next ``n`` rangefinder shots find no target."""
        with self._lock:
            self._no_target += n

    def silence(self, on: bool = True) -> None:
        """Stop sending anything (the port stays open: the power-cycled receiver case)."""
        if on:
            self._silent.set()
        else:
            self._silent.clear()

    @property
    def silent(self) -> bool:
        return self._silent.is_set()

    # use by simulators ----------------------------------------------------------------------
    def take_no_target(self) -> bool:
        with self._lock:
            if self._no_target:
                self._no_target -= 1
                self._note("no_target")
                return True
            return False

    def apply(self, line: bytes) -> list[bytes]:
        """What actually goes on the wire for ``line`` (nothing while silent)."""
        if self._silent.is_set():
            self._note("silenced")
            return []
        with self._lock:
            kind = self._queue.popleft() if self._queue else None
            if kind is not None:
                self._note(kind)
            if kind == "checksum":
                return [corrupt_checksum(line)]
            if kind == "truncate":
                return [truncate(line, self._rng)]
            if kind == "garbage":
                return [garbage(self._rng), line]
        return [line]

    def _push(self, kind: str, n: int) -> None:
        with self._lock:
            self._queue.extend([kind] * n)

    def _note(self, kind: str) -> None:
        self.applied[kind] = self.applied.get(kind, 0) + 1
