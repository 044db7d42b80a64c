"""The live session's recording in progress: its recorder (any thread reads it, one at a time
attaches or detaches it), the log file beside it, its write-rate meter, and the summary of the
last recording closed.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

from snrmon.acquisition.protocols import RecordingWriter
from snrmon.acquisition.record.recorder_status import WriteRate
from snrmon.acquisition.record.session_log import RecordingLog


class CurrentRecording:
    """The recorder the session's events go to now (None: not recording)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._recorder: RecordingWriter | None = None
        self._log: RecordingLog | None = None
        self._rate: tuple[Any, WriteRate] | None = None  # (recorder, its meter)
        self.last_summary: Any = None  # the summary of the last recording closed

    def recorder(self) -> RecordingWriter | None:
        with self._lock:
            return self._recorder

    def log_beside(self, path: str | Path) -> None:
        """The recording's log, FILE.log beside FILE.h5, from now on."""
        self._log = RecordingLog(path).start()

    def attach(self, rec: RecordingWriter) -> None:
        """Events go to ``rec`` from now on; its write rate is measured from now."""
        with self._lock:
            self._recorder = rec
            self._rate = (rec, WriteRate(time.monotonic()))  # the recording's clock

    def detach(self) -> None:
        with self._lock:
            self._recorder = None

    def close_log(self) -> None:
        log, self._log = self._log, None
        if log is not None:
            log.stop()

    def write_rate(self, rec: RecordingWriter) -> WriteRate:
        """The write-rate meter of recording ``rec`` (a new one for each recording)."""
        with self._lock:
            if self._rate is None or self._rate[0] is not rec:
                self._rate = (rec, WriteRate(time.monotonic()))
            return self._rate[1]

    def event(
        self,
        kind: str,
        *,
        camera: str = "",
        payload: dict | None = None,
        t_host_ns: int | None = None,
    ) -> None:
        """An event into the recording (nothing when not recording)."""
        rec = self.recorder()
        if rec is not None:
            rec.add_event(kind, camera=camera, payload=payload or {}, t_host_ns=t_host_ns)
