"""A camera pipeline's measurement thread: it pops EVERY frame from its ring reader, in order,
and hands each to the pipeline; stopped, it drains what is left in the ring first
(:class:`snrmon.acquisition.runtime.camera_pipeline.CameraPipeline`).
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable

from snrmon.acquisition.stage_clock import StageClock
from snrmon.acquisition.streams.ring import Reader, RingFrame

log = logging.getLogger(__name__)


class MeasurementThread:
    """``process(frame)`` for every frame ``reader`` gives, then ``done()`` (whatever
    ``process`` did: a measurement bug must not stop acquisition), on a thread of its own whose
    time ``stages`` clocks."""

    def __init__(
        self,
        name: str,
        reader: Reader,
        process: Callable[[RingFrame], None],
        done: Callable[[], None],
        stages: StageClock,
    ) -> None:
        self.name = name
        self.reader = reader
        self._process = process
        self._done = done
        self._stages = stages
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
            item = reader.pop_next(timeout=0.1)
            if item is None:
                if self._stop.is_set() and reader.lag == 0:
                    return
                continue
            try:
                self._process(item)
            except Exception:  # a measurement bug must not stop acquisition
                log.exception("%s: measurement failed on frame %d", self.name, item.counter)
            finally:
                self._done()
