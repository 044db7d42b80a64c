"""The one contract every device follows (in the spirit of python-microscope and ophyd-async).

A :class:`Device` owns one reader thread. Public methods (:meth:`Device.open`,
:meth:`Device.close`, :meth:`Device.subscribe`, :meth:`Device.status`) are the same for every
camera, rangefinder and GPS; a driver implements only the template hooks ``_connect``,
``_disconnect`` and ``_read``.

The reader thread runs a reconnect state machine::

    disconnected -> connecting -> streaming -> stale -> (reopen) connecting -> ...
                         \\-> failed (after max_attempts, if set)

* A link failure (``OSError``, which includes ``serial.SerialException``) closes the link and
  reopens it with exponential back-off; pyserial never reconnects by itself.
* A data-age watchdog marks the device ``stale`` when no reading arrived for ``stale_after_s``
  and reopens it after ``reopen_after_s``: a power-cycled receiver can leave a port that gives
  neither data nor an error.
* A :class:`snrmon.drivers.errors.ParseError` is counted (checksum errors separately) and survived.

Readings are delivered to subscribers on the reader thread; subscribers must be quick (put the
reading in a queue or a ring) and must not raise. Status changes go to status subscribers.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, replace
from enum import StrEnum
from typing import Generic, TypeVar

from snrmon.drivers.errors import ChecksumError, ParseError

log = logging.getLogger(__name__)

R = TypeVar("R")


class DeviceState(StrEnum):
    DISCONNECTED = "disconnected"
    CONNECTING = "connecting"
    STREAMING = "streaming"
    STALE = "stale"
    FAILED = "failed"


LOST_STATES = frozenset({DeviceState.STALE, DeviceState.DISCONNECTED, DeviceState.FAILED})
"""The states of a device that has stopped delivering (a session records it lost; the console's
header shows it red)."""


@dataclass(frozen=True, slots=True)
class DeviceStatus:
    """A snapshot of a device's health, safe to hand to any thread.

    ``last_reading_age_s`` is ``None`` until the first reading. ``dropped`` counts readings the
    device itself says it lost (for cameras: gaps in the camera's own frame counter).
    """

    name: str
    state: DeviceState = DeviceState.DISCONNECTED
    last_reading_age_s: float | None = None
    readings: int = 0
    parse_errors: int = 0
    checksum_errors: int = 0
    reconnects: int = 0
    dropped: int = 0
    last_error: str = ""


class Device(ABC, Generic[R]):
    """Base class of every driver: a reader thread with reconnect, watchdog and counters.

    Args:
        name: the device's name in status lines and recordings.
        stale_after_s: no reading for this long while streaming -> ``stale``; ``None`` disables
            the watchdog (event-driven devices such as a hand-held rangefinder that speaks only
            when fired).
        reopen_after_s: stale for this long -> close and reopen the link (counts a reconnect).
        backoff_s: (first, max) delay between reconnect attempts; doubles each failure.
        max_attempts: consecutive failed connects before ``failed``; ``None`` retries forever.
    """

    def __init__(
        self,
        name: str,
        *,
        stale_after_s: float | None = 2.0,
        reopen_after_s: float = 1.0,
        backoff_s: tuple[float, float] = (0.1, 2.0),
        max_attempts: int | None = None,
    ) -> None:
        self.name = name
        self.stale_after_s = stale_after_s
        self.reopen_after_s = reopen_after_s
        self.backoff_s = backoff_s
        self.max_attempts = max_attempts
        self._lock = threading.Lock()
        self._status = DeviceStatus(name=name)
        self._last_reading_ns: int | None = None
        self._subscribers: list[Callable[[R], None]] = []
        self._status_subscribers: list[Callable[[DeviceStatus], None]] = []
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._ever_connected = False

    # ----------------------------------------------------------------- template hooks
    @abstractmethod
    def _connect(self) -> None:
        """Open the link. Raise ``OSError`` when it cannot be opened."""

    @abstractmethod
    def _disconnect(self) -> None:
        """Close the link; must not raise."""

    @abstractmethod
    def _read(self) -> Iterable[R]:
        """Wait at most a short time (about 0.1 s) and return the readings that arrived.

        Raise ``OSError`` when the link failed, :class:`ParseError` for bytes that do not decode
        (the base counts it and goes on).
        """

    # ----------------------------------------------------------------- public contract
    def open(self) -> None:
        """Start the reader thread; connection happens (and is retried) there."""
        if self._thread is not None and self._thread.is_alive():
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name=f"dev-{self.name}", daemon=True)
        self._thread.start()

    def close(self, timeout_s: float = 5.0) -> None:
        """Stop the reader thread and close the link."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout_s)
            self._thread = None
        self._set(state=DeviceState.DISCONNECTED)

    def __enter__(self) -> Device[R]:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def subscribe(self, callback: Callable[[R], None]) -> Callable[[], None]:
        """Call ``callback(reading)`` on the reader thread for every reading; returns an
        unsubscribe function."""
        with self._lock:
            self._subscribers.append(callback)
        return lambda: self._unsubscribe(self._subscribers, callback)

    def subscribe_status(self, callback: Callable[[DeviceStatus], None]) -> Callable[[], None]:
        """Call ``callback(status)`` whenever the state changes or an error is counted."""
        with self._lock:
            self._status_subscribers.append(callback)
        return lambda: self._unsubscribe(self._status_subscribers, callback)

    def iter_readings(self, timeout_s: float | None = None) -> Iterator[R]:
        """Yield readings as they arrive (the device must be open); stops after ``timeout_s``
        without a reading, or never when ``None``. Close the generator to unsubscribe."""
        q: queue.Queue[R] = queue.Queue()
        unsubscribe = self.subscribe(q.put)
        try:
            while True:
                try:
                    yield q.get(timeout=timeout_s)
                except queue.Empty:
                    return
        finally:
            unsubscribe()

    def status(self) -> DeviceStatus:
        """The current status, with the age of the last reading computed now."""
        with self._lock:
            st = self._status
            last = self._last_reading_ns
        age = None if last is None else (time.monotonic_ns() - last) / 1e9
        return replace(st, last_reading_age_s=age)

    # ----------------------------------------------------------------- internals
    def _unsubscribe(self, lst: list, callback: Callable) -> None:
        with self._lock:
            if callback in lst:
                lst.remove(callback)

    def _set(self, **changes: object) -> None:
        with self._lock:
            old = self._status
            self._status = replace(old, **changes)
            new = self._status
            subs = list(self._status_subscribers)
        if new != old:
            for cb in subs:
                try:
                    cb(self.status())
                except Exception:  # a subscriber's bug must not kill the device thread
                    log.exception("status subscriber of %s failed", self.name)

    def _count(self, counter: str, error: str = "") -> None:
        with self._lock:
            value = getattr(self._status, counter) + 1
            last_error = error or self._status.last_error
        self._set(**{counter: value, "last_error": last_error})

    def _count_error(self, exc: ParseError) -> None:
        """Count a bad line without interrupting a batch (checksum errors separately)."""
        if isinstance(exc, ChecksumError):
            self._count("checksum_errors", str(exc))
        else:
            self._count("parse_errors", str(exc))

    def _mark_alive(self) -> None:
        """The device spoke (an acknowledgement, a status reply) without giving a reading: feed
        the watchdog but do not count a reading."""
        with self._lock:
            self._last_reading_ns = time.monotonic_ns()

    def _publish(self, reading: R) -> None:
        now = time.monotonic_ns()
        with self._lock:
            self._last_reading_ns = now
            self._status = replace(self._status, readings=self._status.readings + 1)
            subs = list(self._subscribers)
        if self._status.state is not DeviceState.STREAMING:
            self._set(state=DeviceState.STREAMING)
        for cb in subs:
            try:
                cb(reading)
            except Exception:
                log.exception("subscriber of %s failed", self.name)

    def _run(self) -> None:
        delay = self.backoff_s[0]
        failures = 0
        while not self._stop.is_set():
            self._set(state=DeviceState.CONNECTING)
            try:
                self._connect()
            except (ValueError, TypeError) as exc:
                # A configuration the link layer rejects (bad URL, bad baud rate) cannot heal
                # by retrying.
                self._set(state=DeviceState.FAILED, last_error=f"cannot open: {exc}")
                return
            except OSError as exc:
                failures += 1
                self._set(last_error=f"cannot open: {exc}")
                if self.max_attempts is not None and failures >= self.max_attempts:
                    self._set(state=DeviceState.FAILED)
                    return
                self._stop.wait(delay)
                delay = min(delay * 2, self.backoff_s[1])
                continue
            if self._ever_connected:
                self._count("reconnects")
            self._ever_connected = True
            failures = 0
            delay = self.backoff_s[0]
            # The watchdog counts from the (re)open, not from a reading before it.
            self._stream(time.monotonic_ns())
            self._disconnect()
            # A short pause before reopening keeps a link that fails at once from spinning.
            self._stop.wait(self.backoff_s[0])
        self._disconnect()

    def _stream(self, opened_ns: int) -> None:
        """Read until the link fails, the watchdog reopens it, or close() is called."""
        while not self._stop.is_set():
            try:
                for reading in self._read():
                    self._publish(reading)
            except ParseError as exc:
                self._count_error(exc)
            except OSError as exc:
                self._set(state=DeviceState.DISCONNECTED, last_error=f"link lost: {exc}")
                return
            except Exception as exc:  # a driver bug: report it and reopen rather than die
                log.exception("reader of %s failed", self.name)
                self._set(state=DeviceState.DISCONNECTED, last_error=f"driver error: {exc!r}")
                return
            if self.stale_after_s is None:
                continue
            with self._lock:
                last = self._last_reading_ns
            since = max(last or 0, opened_ns)
            age_s = (time.monotonic_ns() - since) / 1e9
            if age_s > self.stale_after_s:
                if self._status.state is not DeviceState.STALE:
                    self._set(state=DeviceState.STALE, last_error=f"no data for {age_s:.1f} s")
                if age_s > self.stale_after_s + self.reopen_after_s:
                    return
