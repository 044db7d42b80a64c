"""Every device's health, watched while a session runs: a device that stops delivering is a
:class:`DeviceLoss` (logged, recorded as a ``device_lost`` event, and ``device_back`` when it
streams again), never silent; and the start-up wait for every device's first reading.
"""

from __future__ import annotations

import dataclasses
import logging
import threading
import time
from collections.abc import Mapping
from datetime import UTC, datetime
from typing import Any, Protocol

from snrmon.acquisition.streams.timebase import ClockMap
from snrmon.drivers.device import LOST_STATES, Device, DeviceState, DeviceStatus

log = logging.getLogger(__name__)


class DeviceError(OSError):
    """A device the session needs did not deliver at the start or was lost while it ran: a
    runtime failure (exit 1 on the command line), never a quiet end."""


@dataclasses.dataclass(frozen=True, slots=True)
class DeviceLoss:
    """A device that stopped delivering while the session ran: when (host clock and UTC), the
    state it went to and its last error, and when it streamed again (None: it did not)."""

    device: str
    t_host_ns: int
    utc_ns: int
    state: str
    error: str
    back_t_host_ns: int | None = None
    back_utc_ns: int | None = None

    def as_dict(self) -> dict[str, Any]:
        """For a JSON summary: the times as ISO 8601 UTC (null: not back)."""
        return {
            "device": self.device,
            "lost_utc": _iso_utc(self.utc_ns),
            "lost_t_host_ns": self.t_host_ns,
            "state": self.state,
            "error": self.error,
            "back_utc": None if self.back_utc_ns is None else _iso_utc(self.back_utc_ns),
        }

    def describe(self) -> str:
        """One line: the device, the time it was lost and why, and whether it came back."""
        back = "" if self.back_utc_ns is None else f", back at {_iso_utc(self.back_utc_ns)}"
        why = f": {self.error}" if self.error else ""
        return f"{self.device} lost at {_iso_utc(self.utc_ns)} ({self.state}{why}{back})"


def _iso_utc(utc_ns: int) -> str:
    return datetime.fromtimestamp(utc_ns / 1e9, tz=UTC).isoformat(timespec="milliseconds")


class RecordEvent(Protocol):
    """An event into the session's recording, if one is on
    (:meth:`snrmon.acquisition.runtime.current_recording.CurrentRecording.event`)."""

    def __call__(
        self, kind: str, *, payload: dict | None = None, t_host_ns: int | None = None
    ) -> None: ...


class DeviceWatch:
    """The devices' states as they report them (:meth:`on_status`, on their threads), the
    losses since :meth:`start`, and the wait for every device's first reading."""

    def __init__(self, clock: ClockMap, record: RecordEvent) -> None:
        self.clock = clock
        self._record = record
        self._lock = threading.Lock()
        self._delivered = threading.Condition(self._lock)  # a device started streaming
        self._watching = False
        self._started_ns = 0
        self._states: dict[str, DeviceState] = {}
        self._losses: list[DeviceLoss] = []

    def start(self) -> None:
        """From now on a streaming device that stops delivering is lost; the start-up
        timeouts run from now."""
        self._started_ns = time.monotonic_ns()
        self._watching = True

    def stop(self) -> None:
        """Closing a device is not losing it."""
        self._watching = False

    def losses(self) -> list[DeviceLoss]:
        """The devices lost since :meth:`start`, in the order they were lost."""
        with self._lock:
            return list(self._losses)

    def wait_delivering(
        self, devices: Mapping[str, Device], timeouts_s: Mapping[str, float]
    ) -> None:
        """Return once every one of ``devices`` has delivered a reading; raise
        :class:`DeviceError` naming each that gave none within its timeout (s, from
        :meth:`start`), with its last error."""
        pending = dict(devices)
        with self._delivered:  # notified when a device starts streaming (its first reading)
            while True:
                pending = {n: d for n, d in pending.items() if d.status().readings == 0}
                if not pending:
                    return
                waited_s = (time.monotonic_ns() - self._started_ns) / 1e9
                late = [n for n in pending if waited_s > timeouts_s[n]]
                if late:
                    raise DeviceError(
                        "; ".join(_silent(pending[n], n, timeouts_s[n]) for n in late)
                    )
                self._delivered.wait(min(timeouts_s[n] for n in pending) - waited_s + 0.001)

    def on_status(self, status: DeviceStatus) -> None:
        """A device's state changed (on its thread): a streaming device that stops is lost,
        logged with its time and recorded as a ``device_lost`` event; back: ``device_back``."""
        now = time.monotonic_ns()
        with self._lock:
            prev = self._states.get(status.name)
            self._states[status.name] = status.state
            if status.state is DeviceState.STREAMING:
                self._delivered.notify_all()
            if not self._watching:
                return
            change = self._change(status, prev, now)
            if change is None:
                return
            kind, loss = change
        log.warning("%s%s", loss.describe(), "; retrying" if kind == "device_lost" else "")
        self._record(kind, payload=loss.as_dict(), t_host_ns=now)

    def _change(
        self, status: DeviceStatus, prev: DeviceState | None, now: int
    ) -> tuple[str, DeviceLoss] | None:
        """The loss ``status`` starts or ends (caller holds the lock), as its event's kind."""
        open_loss = next(
            (
                i
                for i, x in enumerate(self._losses)
                if x.device == status.name and x.back_t_host_ns is None
            ),
            None,
        )
        if prev is DeviceState.STREAMING and status.state in LOST_STATES:
            if open_loss is not None:
                return None
            loss = DeviceLoss(
                status.name, now, self.clock.utc_ns(now), str(status.state), status.last_error
            )
            self._losses.append(loss)
            return "device_lost", loss
        if status.state is DeviceState.STREAMING and open_loss is not None:
            loss = dataclasses.replace(
                self._losses[open_loss], back_t_host_ns=now, back_utc_ns=self.clock.utc_ns(now)
            )
            self._losses[open_loss] = loss
            return "device_back", loss
        return None


def _silent(device: Device, name: str, timeout_s: float) -> str:
    st = device.status()
    why = f" ({st.last_error})" if st.last_error else f" (state {st.state})"
    return f"{name}: no reading within {timeout_s:g} s of the start{why}"
