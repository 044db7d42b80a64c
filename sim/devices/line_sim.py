"""Base of the line-oriented serial device simulators (GPS, rangefinders) on a pty.

A :class:`LineSimulator` owns a :class:`snrmon.sim.devices.pty_port.PtyPort` and one thread that
answers command lines (:meth:`LineSimulator.handle`) and streams lines on a schedule
(:meth:`LineSimulator.tick`), passing everything it sends through a
:class:`snrmon.sim.devices.faults.FaultInjector`. Time given to the protocol hooks is seconds since
:meth:`LineSimulator.start`.
"""

from __future__ import annotations

import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from pathlib import Path

from snrmon.sim.devices.faults import FaultInjector
from snrmon.sim.devices.pty_port import PtyPort


def xor_checksum(body: str) -> str:
    """The NMEA/CR400 checksum of the text between ``$`` and ``*``, as two hex digits."""
    value = 0
    for ch in body.encode("ascii"):
        value ^= ch
    return f"{value:02X}"


def sentence(body: str) -> bytes:
    """``$body*hh`` with CR LF."""
    return f"${body}*{xor_checksum(body)}\r\n".encode("ascii")


class LineSimulator(ABC):
    """A simulated serial device on a pty.

    Args:
        baud: simulated line speed (paces output; see :class:`PtyPort`).
        link_path: stable path for the driver to open; a temporary one by default.
        seed: seeds the fault injector.
    """

    eol = b"\r\n"

    def __init__(self, *, baud: int, link_path: str | Path | None = None, seed: int = 0) -> None:
        self.baud = baud
        self.port = PtyPort(baud, link_path)
        self.faults = FaultInjector(seed)
        self.commands: list[str] = []
        self.lines_sent = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._t0 = 0.0
        self._rx = bytearray()
        self._command_event = threading.Condition()
        # gate() False: the device has nothing new to say now (a simulated day whose clock is
        # held: a reading of a frozen flight would look like a hover); the tick is skipped.
        self.gate: Callable[[], bool] | None = None

    @property
    def path(self) -> str:
        """The stable path a driver opens (a symlink to the current ``/dev/pts/N``)."""
        return self.port.path

    @property
    def pts_path(self) -> str:
        return self.port.pts_path

    # protocol hooks -------------------------------------------------------------------------
    def handle(self, command: str, t_s: float) -> list[bytes]:
        """Replies to one command line (without its ending); default: none."""
        return []

    @abstractmethod
    def tick(self, t_s: float) -> list[bytes]:
        """Lines due at ``t_s`` (called about every :attr:`tick_period_s`)."""

    tick_period_s = 0.1

    @property
    def started_monotonic_s(self) -> float:
        """``time.monotonic()`` at :meth:`start`: ``t_s = 0`` of :meth:`tick`."""
        return self._t0

    # control --------------------------------------------------------------------------------
    def start(self) -> LineSimulator:
        self._t0 = time.monotonic()
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name=type(self).__name__, daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)
            self._thread = None
        self.port.close()

    def __enter__(self) -> LineSimulator:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def unplug(self) -> None:
        """The port vanishes (its path disappears; an open driver gets an I/O error)."""
        self.port.vanish()

    def replug(self) -> None:
        """The port returns at the same path (a new ``/dev/pts/N`` behind it)."""
        self.port.restore()

    def wait_for_command(self, command: str, timeout_s: float) -> bool:
        """Block until the driver has sent ``command``; for tests and the demo."""
        with self._command_event:
            return self._command_event.wait_for(lambda: command in self.commands, timeout_s)

    def send_raw(self, data: bytes) -> None:
        """Send bytes as they are (no faults): for odd lines a test wants on the wire."""
        self.port.write(data, self._stop)

    # internals ------------------------------------------------------------------------------
    def _send(self, line: bytes) -> None:
        for out in self.faults.apply(line):
            self.port.write(out, self._stop)
            self.lines_sent += 1

    def _run(self) -> None:
        next_tick = time.monotonic()
        while not self._stop.is_set():
            now = time.monotonic()
            if now >= next_tick:
                if self.gate is None or self.gate():
                    for line in self.tick(now - self._t0):
                        self._send(line)
                next_tick += self.tick_period_s
                if next_tick < now:  # fell behind (paced by a slow baud): do not burst
                    next_tick = now + self.tick_period_s
                continue
            data = self.port.read(min(next_tick - now, 0.05))
            if data:
                self._on_bytes(data)

    def _on_bytes(self, data: bytes) -> None:
        for byte in data:
            if byte in (10, 13, 27):  # ESC ends a command too (LDM stop)
                if byte == 27:
                    self._rx.extend(b"\x1b")
                if self._rx:
                    command = self._rx.decode("ascii", "replace")
                    self._rx.clear()
                    with self._command_event:
                        self.commands.append(command)
                        self._command_event.notify_all()
                    for reply in self.handle(command, time.monotonic() - self._t0):
                        self._send(reply)
            else:
                self._rx.append(byte)
