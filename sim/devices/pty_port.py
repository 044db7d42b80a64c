"""The simulator side of a virtual serial port: a pseudo-terminal master with a stable path.

A driver opens :attr:`PtyPort.path` exactly as it would open ``/dev/ttyUSB0``. The path is a
symlink that this class points at the current ``/dev/pts/N``; :meth:`PtyPort.vanish` closes the
pty and removes the link (an unplugged USB adapter), :meth:`PtyPort.restore` opens a new pty and
points the link at it (replugged), so a driver that reopens the same path recovers.

Lessons measured on this machine (notes sec. 4): the slave is put in raw mode right after
``openpty`` (a fresh slave echoes and maps CR to NL); this class keeps its own slave fd open so
the master never sees EIO when the application closes; writes are non-blocking and dropped when
the pty buffer is full (an application that stops reading must not hang the simulator); and no
pty paces bytes, so :meth:`PtyPort.write` sleeps ten bit-times per byte at the configured baud.
"""

from __future__ import annotations

import contextlib
import errno
import os
import select
import tempfile
import threading
import time
import tty
import warnings
from pathlib import Path

BITS_PER_BYTE = 10  # 8N1: start bit, 8 data bits, stop bit


class BaudBudgetWarning(UserWarning):
    """A simulator configuration sends more bytes per second than its baud rate carries."""


def bytes_per_s_capacity(baud: int) -> float:
    """Bytes per second an 8N1 link carries at ``baud``."""
    return baud / BITS_PER_BYTE


def check_baud_budget(bytes_per_s: float, baud: int, what: str) -> float:
    """Fraction of the link ``bytes_per_s`` uses; warns (:class:`BaudBudgetWarning`) above 1."""
    load = bytes_per_s / bytes_per_s_capacity(baud)
    if load > 1.0:
        warnings.warn(
            f"{what}: {bytes_per_s:.0f} B/s needs {bytes_per_s * BITS_PER_BYTE:.0f} bit/s, "
            f"more than {baud} baud carries ({load:.0%}); raise the baud rate or lower the rate",
            BaudBudgetWarning,
            stacklevel=3,
        )
    return load


class PtyPort:
    """A pty whose slave an application opens by :attr:`path`.

    Args:
        baud: the simulated line speed used to pace :meth:`write` (``None``: no pacing).
        link_path: where the stable symlink goes; a fresh temporary directory by default.
    """

    def __init__(self, baud: int | None = 9600, link_path: str | Path | None = None) -> None:
        self.baud = baud
        if link_path is None:
            self._tmpdir = tempfile.mkdtemp(prefix="snrmon-pty-")
            link_path = Path(self._tmpdir) / "tty"
        else:
            self._tmpdir = None
        self.path = str(link_path)
        self._master: int | None = None
        self._slave: int | None = None
        self.pts_path = ""
        self._lock = threading.Lock()
        self._line_free_t = 0.0
        self.bytes_written = 0
        self.bytes_dropped = 0
        self.restore()

    @property
    def present(self) -> bool:
        return self._master is not None

    def restore(self) -> None:
        """Open a new pty (raw) and point :attr:`path` at it."""
        with self._lock:
            if self._master is not None:
                return
            master, slave = os.openpty()
            tty.setraw(slave)
            os.set_blocking(master, False)
            self._master, self._slave = master, slave
            self.pts_path = os.ttyname(slave)
            tmp = self.path + ".new"
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
            os.symlink(self.pts_path, tmp)
            os.replace(tmp, self.path)  # atomic: a reader never sees a missing link here

    def vanish(self) -> None:
        """Close the pty and remove :attr:`path`, as when a USB serial adapter is unplugged."""
        with self._lock:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.path)
            for fd in (self._master, self._slave):
                if fd is not None:
                    with contextlib.suppress(OSError):
                        os.close(fd)
            self._master = self._slave = None

    def close(self) -> None:
        self.vanish()
        if self._tmpdir is not None:
            with contextlib.suppress(OSError):
                os.rmdir(self._tmpdir)

    def write(self, data: bytes, stop: threading.Event | None = None) -> int:
        """Send ``data``, paced at the baud rate; returns bytes accepted (0 when vanished).

        Bytes that do not fit the pty buffer are dropped and counted in ``bytes_dropped``.
        """
        if self.baud:
            now = time.monotonic()
            start = max(now, self._line_free_t)
            self._line_free_t = start + len(data) * BITS_PER_BYTE / self.baud
            wait = self._line_free_t - now
            if wait > 0:
                # The line is busy until the last bit is out; an interruptible wait.
                (stop or threading.Event()).wait(wait)
        with self._lock:
            if self._master is None:
                return 0
            try:
                n = os.write(self._master, data)
            except BlockingIOError:
                n = 0
            except OSError as exc:
                if exc.errno != errno.EIO:
                    raise
                n = 0
        self.bytes_written += n
        self.bytes_dropped += len(data) - n
        return n

    def read(self, timeout_s: float) -> bytes:
        """Bytes the application sent, waiting at most ``timeout_s``; ``b""`` if none."""
        master = self._master
        if master is None:
            if timeout_s > 0:
                threading.Event().wait(timeout_s)  # vanished: nothing can arrive
            return b""
        try:
            ready, _, _ = select.select([master], [], [], timeout_s)
        except (OSError, ValueError):  # closed under us by vanish()
            return b""
        if not ready:
            return b""
        with self._lock:
            if self._master is None:
                return b""
            try:
                return os.read(self._master, 4096)
            except (BlockingIOError, OSError):
                return b""

    def __enter__(self) -> PtyPort:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
