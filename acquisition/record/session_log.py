"""A recording's own log, beside it: ``FILE.log`` next to ``FILE.h5``.

While a session records, every log record of the process at info level and above (device
reconnects, dropped frames, stops, the recorder's own messages, from every thread) is also
written to ``FILE.log``, with UTC timestamps, so a field day leaves the story of each file next
to it. The log starts with what wrote it (program, version, command line) and ends when the
recording stops. Debug records are left out unless the process's logging asks for them.
"""

from __future__ import annotations

import logging
import sys
import time
from pathlib import Path

LOG_FORMAT = "%(asctime)s.%(msecs)03dZ %(levelname)-7s %(threadName)s %(name)s: %(message)s"

log = logging.getLogger(__name__)


def log_path_for(recording: str | Path) -> Path:
    """``FILE.log`` beside ``FILE.h5``."""
    return Path(recording).with_suffix(".log")


class RecordingLog:
    """Attach with :meth:`start` when a recording starts, :meth:`stop` when it ends."""

    def __init__(self, recording: str | Path) -> None:
        self.path = log_path_for(recording)
        self._handler: logging.Handler | None = None
        self._restore: list[tuple[logging.Logger | logging.Handler, int]] = []

    def start(self) -> RecordingLog:
        """Open ``FILE.log`` (appending) and route the process's log records into it. A log that
        cannot be opened is a warning, never a reason not to record."""
        try:
            handler = logging.FileHandler(self.path, mode="a", encoding="utf-8")
        except OSError as exc:
            log.warning("no log beside the recording: %s", exc)
            return self
        fmt = logging.Formatter(LOG_FORMAT, "%Y-%m-%dT%H:%M:%S")
        fmt.converter = time.gmtime
        handler.setFormatter(fmt)
        root = logging.getLogger()
        level = root.getEffectiveLevel()
        handler.setLevel(min(logging.INFO, level))
        if level > logging.INFO:
            # Info from every logger reaches the file even when stderr shows only warnings:
            # the root lets info through, the other handlers keep what they showed before.
            for h in root.handlers:
                if h.level < level:
                    self._restore.append((h, h.level))
                    h.setLevel(level)
            self._restore.append((root, root.level))
            root.setLevel(logging.INFO)
        root.addHandler(handler)
        self._handler = handler
        log.info(
            "recording %s; snrmon %s; %s",
            Path(self.path).with_suffix(".h5").name,
            _version(),
            _command_line(),
        )
        return self

    def stop(self) -> None:
        handler, self._handler = self._handler, None
        if handler is None:
            return
        log.info("recording log closed")
        logging.getLogger().removeHandler(handler)
        handler.close()
        for obj, level in reversed(self._restore):
            obj.setLevel(level)
        self._restore.clear()


def _command_line() -> str:
    return "command: " + (" ".join(sys.argv) if sys.argv else "(none)")


def _version() -> str:
    from importlib import metadata

    try:
        return metadata.version("snrmon")
    except metadata.PackageNotFoundError:
        return "(not installed)"
