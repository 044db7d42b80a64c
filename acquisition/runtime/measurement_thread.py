"""A camera pipeline's measurement thread: it pops EVERY frame from its ring reader, in order,
and hands each to the pipeline; stopped, it drains what is left in the ring first
(:class:`snrmon.acquisition.runtime.camera_pipeline.CameraPipeline`). It also takes the
statistics the camera's status carries (the error of the running mean, the noise figures, the
latency's percentiles), :data:`STATISTICS_EVERY_S` apart while frames come and once more when
they pause: the console's thread, which asks for a status five times a second, computes none.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Generic, TypeVar

from snrmon.acquisition.stage_clock import StageClock
from snrmon.acquisition.streams.ring import Reader, RingFrame

log = logging.getLogger(__name__)

STATISTICS_EVERY_S = 0.2
"""How often (s of the host's clock) the statistics are taken while frames come: as often as the
console shows a status, a few hundred microseconds each."""
IDLE_WAIT_S = 0.1  # how long the thread waits for a frame before it looks at its stop

S = TypeVar("S")


class MeasurementThread(Generic[S]):
    """``process(frame)`` for every frame ``reader`` gives, then ``done()`` (whatever
    ``process`` did: a measurement bug must not stop acquisition), on a thread of its own whose
    time ``stages`` clocks; ``statistics()`` taken after a frame when :data:`STATISTICS_EVERY_S`
    have passed since the last, and after the last frame before a pause or the end, kept in
    :attr:`statistics` (None before the first frame)."""

    def __init__(
        self,
        name: str,
        reader: Reader,
        process: Callable[[RingFrame], None],
        done: Callable[[], None],
        stages: StageClock,
        *,
        statistics: Callable[[], S],
    ) -> None:
        self.name = name
        self.reader = reader
        self._process = process
        self._done = done
        self._stages = stages
        self._take_statistics = statistics
        # Replaced whole by this thread, read by any (one reference: no lock needed).
        self.statistics: S | None = None
        self._statistics_due: float | None = None  # monotonic s; None: taken after the last frame
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name=f"measure-{self.name}", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Let the thread drain what is in the ring, then end (waits up to 10 s)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(10.0)

    def _run(self) -> None:
        self._stages.attach()
        try:
            self._measure_all()
        finally:
            self._stages.detach()

    def _measure_all(self) -> None:
        reader = self.reader
        while True:
            item = reader.pop_next(timeout=IDLE_WAIT_S)
            if item is None:
                if self._statistics_due is not None:  # frames paused: the statistics of all
                    self._publish_statistics()
                if self._stop.is_set() and reader.lag == 0:
                    return
                continue
            try:
                self._process(item)
            except Exception:  # a measurement bug must not stop acquisition
                log.exception("%s: measurement failed on frame %d", self.name, item.counter)
            finally:
                self._done()
            now = time.monotonic()
            if self._statistics_due is None:
                self._statistics_due = now + STATISTICS_EVERY_S
            elif now >= self._statistics_due:
                self._publish_statistics()
                self._statistics_due = now + STATISTICS_EVERY_S

    def _publish_statistics(self) -> None:
        try:
            self.statistics = self._take_statistics()
        except Exception:  # a statistics bug must not stop the measurement either
            log.exception("%s: the status's statistics failed", self.name)
        self._statistics_due = None
