"""The simulated day's clock: as fast as asked, never faster than the console takes the frames.

A simulated collection day has no real time to keep. Its clock (camera seconds: 0 when the
cameras start, the flight's time plus the pre-roll) runs at ``speed`` x the host's monotonic
clock, but never more than ``LEAD_S`` camera seconds ahead of the newest frame the console has
received from the slowest camera. The camera processes publish frame k when the clock reads
``k / fps`` (:class:`snrmon.sim.devices.shm_camera.ShmProducer` with a shared ``clock``), the
rangefinder and GPS simulators report the flight at the clock's time, so when the console is
busy (the recorder's disk, the measurement, another program on the machine) the whole day slows
down with it: the pipeline waits for the ring and the recorder (their back-pressure, a lossless
:class:`snrmon.acquisition.runtime.session.Session`), the console stops taking frames, the clock
stops, every simulated device waits. No frame is dropped, and a frame still arrives within
``LEAD_S`` of the flight time the serial devices report with it, so the ranges the console
pairs with each frame are the flight's.

The console's time base stays the host's monotonic clock at receipt (every reading is stamped
when it arrives); the mapping from host time to the day's clock is kept (:meth:`FlightClock.at`)
and recorded with the session (``hil_clock`` events), so the truth can be rebuilt from the file.
"""

from __future__ import annotations

import bisect
import logging
import multiprocessing as mp
import threading
import time
from collections.abc import Callable, Mapping

log = logging.getLogger(__name__)

MAX_SPEED = 8.0
"""``--speed max``: the fastest the clock may run (the serial devices' 10 Hz must still give
each stop a few readings); the console's pace holds it back from there."""
LEAD_S = 0.1
"""How far (camera seconds) the cameras may run ahead of the console's newest frame: a few
frames, so the console is never starved, and a frame is never paired with a range more than
0.1 s of flight away (0.8 m in a transit at 8 m/s)."""
TICK_S = 0.001
RECORD_EVERY_NS = 2_000_000  # the host -> clock table: at most one point per 2 ms


class FlightClock:
    """The day's clock (module docstring) for cameras of the given frame rates.

    Args:
        speed: camera seconds per host second when nothing holds the clock back.
        cameras: name -> (frame rate, a callable giving the newest camera counter the console
            has received from it, None before the first); more with :meth:`watch`.
    """

    def __init__(
        self,
        speed: float,
        cameras: Mapping[str, tuple[float, Callable[[], int | None]]] | None = None,
        *,
        lead_s: float = LEAD_S,
    ) -> None:
        if not speed > 0:
            raise ValueError(f"speed must be positive, got {speed}")
        self.speed = float(speed)
        self.lead_s = float(lead_s)
        self._cameras = dict(cameras or {})
        # Shared with the camera processes (spawned): one writer, here.
        self.shared = mp.get_context("spawn").Value("d", 0.0, lock=False)
        self._lock = threading.Lock()
        self._tau = 0.0
        self._host: list[int] = []
        self._taus: list[float] = []
        self._held_ns = 0  # host time during which the console held the clock back
        self._held = False
        self._start_ns: int | None = None
        self._last_ns = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def set_speed(self, speed: float) -> None:
        """The clock's free rate from now on (camera seconds per host second)."""
        if not speed > 0:
            raise ValueError(f"speed must be positive, got {speed}")
        with self._lock:
            self.speed = float(speed)

    def watch(self, name: str, fps: float, newest: Callable[[], int | None]) -> None:
        """Hold the clock to camera ``name`` too (frame rate ``fps``; ``newest()``: the newest
        counter the console received from it)."""
        self._cameras[name] = (float(fps), newest)

    # ------------------------------------------------------------------ running
    def start(self) -> None:
        """The clock starts at 0 now and runs until :meth:`stop`."""
        now = time.monotonic_ns()
        with self._lock:
            self._start_ns = self._last_ns = now
            self._host, self._taus = [now], [0.0]
        self._thread = threading.Thread(target=self._run, name="flight-clock", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)

    def _limit(self) -> float:
        limit = float("inf")
        for fps, newest in self._cameras.values():
            counter = newest()
            if counter is not None:
                limit = min(limit, (counter + 1) / fps + self.lead_s)
        return limit

    def _run(self) -> None:
        while not self._stop.wait(TICK_S):
            self.tick()

    def tick(self) -> float:
        """Advance the clock to now (the thread calls it every ``TICK_S``); the clock's time."""
        now = time.monotonic_ns()
        limit = self._limit()
        with self._lock:
            if self._start_ns is None:  # not started: the day has not begun
                return 0.0
            free = self._tau + (now - self._last_ns) * self.speed / 1e9
            tau = max(self._tau, min(free, limit))
            held = tau < free
            if held:
                self._held_ns += now - self._last_ns
            # A point where the clock's rate changes, and one every 2 ms: the table is exact
            # where the console held the clock, and linear where it ran free.
            if held != self._held or now - self._host[-1] >= RECORD_EVERY_NS:
                self._host.append(self._last_ns)
                self._taus.append(self._tau)
            self._tau, self._last_ns, self._held = tau, now, held
        self.shared.value = tau
        return tau

    # ------------------------------------------------------------------ reading
    def now(self) -> float:
        """The clock's time now, camera seconds."""
        with self._lock:
            return self._tau

    def at(self, host_ns: int) -> float:
        """The clock's time at host time ``host_ns``, exactly as the recorded table
        (:meth:`table_since`) will give it: a moment not reached by the last tick is ticked to
        first, and the clock's state now becomes a point of the table."""
        with self._lock:
            if self._start_ns is None:
                return 0.0
            behind = host_ns > self._last_ns
        if behind:
            self.tick()
        with self._lock:
            if self._host[-1] < self._last_ns:
                self._host.append(self._last_ns)
                self._taus.append(self._tau)
            if host_ns >= self._host[-1]:
                return self._taus[-1]
            i = bisect.bisect_right(self._host, host_ns)
            if i == 0:
                return 0.0
            h0, h1 = self._host[i - 1], self._host[i]
            t0, t1 = self._taus[i - 1], self._taus[i]
            return t0 + (t1 - t0) * (host_ns - h0) / max(h1 - h0, 1)

    def table_since(self, k: int) -> tuple[list[int], list[float]]:
        """The host -> clock points from the ``k``-th on (for the recording's events)."""
        with self._lock:
            return self._host[k:], self._taus[k:]

    def achieved(self) -> dict:
        """How fast the day ran: camera seconds per host second over its whole run, and how
        long the console held it back."""
        with self._lock:
            if self._start_ns is None:
                return {"speed": self.speed, "achieved": None, "held_back_s": 0.0}
            wall = (self._last_ns - self._start_ns) / 1e9
            return {
                "speed": self.speed,
                "achieved": self._tau / wall if wall > 0 else None,
                "held_back_s": self._held_ns / 1e9,
                "wall_s": wall,
            }
