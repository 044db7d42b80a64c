"""Line-oriented serial devices: the pyserial link under every rangefinder and NMEA GPS driver.

:class:`SerialLineDevice` opens its port with ``serial.serial_for_url``, so a configuration can
name ``/dev/ttyUSB0``, ``/dev/pts/7`` (a simulator), ``socket://host:port`` (a TCP serial server),
``rfc2217://host:port`` or ``loop://``. It frames bytes into lines (CR, LF or CRLF; real devices
use all three), refuses lines longer than ``max_line_bytes`` (counted, never fatal), and hands each
line with its host receive time to :meth:`SerialLineDevice._parse_line`. Commands go out with
:meth:`SerialLineDevice.send`. Reconnect and the watchdog come from
:class:`snrmon.drivers.device.Device`.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Iterable

import serial

from snrmon.drivers.device import Device, R
from snrmon.drivers.errors import ParseError

SERIAL_BAUD_RATES = (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400, 460800, 921600)


class SerialLineDevice(Device[R]):
    """A device that speaks ASCII lines over a serial link.

    Args:
        name: the device's name in status lines.
        url: a path or pyserial URL (``/dev/ttyUSB0``, ``socket://h:p``, ``rfc2217://h:p``).
        baudrate: line speed in bit/s (ignored by sockets and ptys, which do not pace).
        max_line_bytes: longest line accepted; longer ones are counted as parse errors. Real
            NMEA receivers exceed the standard's 82 bytes, so the default is generous.
        read_timeout_s: how long one read waits for bytes (bounds the reader thread's latency
            to close() and to the watchdog).
        eol: line ending appended by :meth:`send`.
        **device_kwargs: passed to :class:`snrmon.drivers.device.Device` (watchdog, back-off).
    """

    def __init__(
        self,
        name: str,
        url: str,
        *,
        baudrate: int = 9600,
        max_line_bytes: int = 512,
        read_timeout_s: float = 0.1,
        eol: bytes = b"\r\n",
        **device_kwargs,
    ) -> None:
        device_kwargs.setdefault("backoff_s", (0.1, 1.0))
        super().__init__(name, **device_kwargs)
        if not url:
            raise ValueError(f"{name}: serial port URL is empty")
        if baudrate <= 0:
            raise ValueError(f"{name}: baud rate must be positive, got {baudrate}")
        if max_line_bytes < 8:
            raise ValueError(f"{name}: max_line_bytes must be >= 8, got {max_line_bytes}")
        self.url = url
        self.baudrate = baudrate
        self.max_line_bytes = max_line_bytes
        self.read_timeout_s = read_timeout_s
        self.eol = eol
        self._port: serial.SerialBase | None = None
        self._port_lock = threading.Lock()
        self._buf = bytearray()
        self._discarding = False  # inside an over-long line: drop bytes until its end

    # ----------------------------------------------------------------- driver hooks
    def _parse_line(self, line: bytes, t_host_ns: int) -> Iterable[R]:
        """Decode one line (without its ending) into readings; raise ParseError if it is bad."""
        raise NotImplementedError

    def _on_connected(self) -> None:
        """Called on the reader thread after every (re)open, e.g. to start streaming."""

    # ----------------------------------------------------------------- public
    def send(self, line: str) -> None:
        """Write one command line (the line ending is added). Raises OSError when the link is
        down, so a caller knows the command did not go out."""
        data = line.encode("ascii") + self.eol
        with self._port_lock:
            if self._port is None:
                raise OSError(f"{self.name}: not connected to {self.url}")
            self._port.write(data)
            self._port.flush()

    @property
    def connected(self) -> bool:
        return self._port is not None

    # ----------------------------------------------------------------- Device hooks
    def _connect(self) -> None:
        port = serial.serial_for_url(self.url, baudrate=self.baudrate, timeout=self.read_timeout_s)
        with self._port_lock:
            self._port = port
        self._buf.clear()
        self._discarding = False
        self._on_connected()

    def _disconnect(self) -> None:
        with self._port_lock:
            port, self._port = self._port, None
        if port is not None:
            # Closing a port whose device vanished may fail; it is gone anyway.
            with contextlib.suppress(Exception):
                port.close()

    def _read(self) -> list[R]:
        port = self._port
        if port is None:
            raise OSError(f"{self.name}: port closed")
        chunk = port.read(1)
        if not chunk:
            return []
        waiting = port.in_waiting
        if waiting:
            chunk += port.read(waiting)
        t_host_ns = time.monotonic_ns()
        readings: list[R] = []
        for line in self._split_lines(chunk):
            try:
                readings.extend(self._parse_line(line, t_host_ns))
            except ParseError as exc:
                self._count_error(exc)
        return readings

    def _split_lines(self, chunk: bytes) -> list[bytes]:
        lines = []
        for byte in chunk.translate(None, b"\x00"):
            if byte in (10, 13):  # LF or CR ends a line; CRLF gives one empty line, skipped
                if self._discarding:
                    self._discarding = False
                elif self._buf:
                    lines.append(bytes(self._buf))
                self._buf.clear()
            elif self._discarding:
                continue
            elif len(self._buf) >= self.max_line_bytes:
                self._count_error(
                    ParseError(
                        f"{self.name}: line longer than {self.max_line_bytes} bytes: "
                        f"{bytes(self._buf[:40])!r}..."
                    )
                )
                self._buf.clear()
                self._discarding = True
            else:
                self._buf.append(byte)
        return lines
