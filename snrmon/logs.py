"""Logging as the CLI sets it up: stderr by ``-v``/``-q``, an optional ``--log-file``.

Levels on stderr: warnings and errors by default, ``-v`` adds info, ``-vv`` debug, ``-q`` leaves
errors only. Lines on stderr carry the one message prefix of every snrmon message
(``snrmon COMMAND: warning: ...``). ``--log-file`` gets info (debug with ``-vv``) with UTC
timestamps and thread names, whatever ``-q`` says: a field day's log is for reading afterwards.
Python ``warnings`` (e.g. a simulator's baud budget) go through logging too.

A session's own log beside its recording is :mod:`snrmon.acquisition.record.session_log`.
"""

from __future__ import annotations

import logging
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

FILE_FORMAT = "%(asctime)s.%(msecs)03dZ %(levelname)-7s %(threadName)s %(name)s: %(message)s"
DATE_FORMAT = "%Y-%m-%dT%H:%M:%S"
FILE_ONLY = "snrmon_file_only"
OURS = ("snrmon", "py.warnings")
"""Loggers whose records reach stderr without ``-v``: snrmon's own and Python's warnings. A
library's own log line (tifffile's "corrupted tag list" before it raises, dask's cluster chatter)
goes to ``--log-file`` and to stderr with ``-v``: without it the one line snrmon prints says what
went wrong."""
"""``extra={FILE_ONLY: True}``: a record for log files only (the CLI's error line, with its
traceback, which it has already printed on stderr its own way)."""


def file_formatter() -> logging.Formatter:
    """The format of every log file snrmon writes (UTC ISO 8601 times)."""
    fmt = logging.Formatter(FILE_FORMAT, DATE_FORMAT)
    fmt.converter = time.gmtime
    return fmt


class _PrefixFormatter(logging.Formatter):
    def __init__(self, prog: str) -> None:
        super().__init__()
        self.prog = prog

    def format(self, record: logging.LogRecord) -> str:
        msg = record.getMessage()
        if record.levelno <= logging.DEBUG:
            msg = f"{record.name}: {msg}"
        text = f"{self.prog}: {record.levelname.lower()}: {msg}"
        if record.exc_info and record.levelno >= logging.ERROR:
            text += "\n" + self.formatException(record.exc_info)
        return text


def stderr_level(verbose: int, quiet: bool) -> int:
    """The stderr threshold for ``-v`` (count) and ``-q``."""
    if quiet:
        return logging.ERROR
    return {0: logging.WARNING, 1: logging.INFO}.get(verbose, logging.DEBUG)


@contextmanager
def configured(
    prog: str, *, verbose: int = 0, quiet: bool = False, log_file: str | Path | None = None
) -> Iterator[None]:
    """Install the CLI's handlers on the root logger for the duration of one command, and
    remove them afterwards (``main`` may run many times in one process, as in the tests)."""
    root = logging.getLogger()
    level = stderr_level(verbose, quiet)
    handlers: list[logging.Handler] = []
    err = logging.StreamHandler(sys.stderr)
    err.setLevel(level)
    err.setFormatter(_PrefixFormatter(prog))
    err.addFilter(lambda record: not getattr(record, FILE_ONLY, False))
    if verbose < 1:
        err.addFilter(lambda record: record.name.split(".")[0] in OURS)
    handlers.append(err)
    if log_file is not None:
        fh = logging.FileHandler(log_file, encoding="utf-8")
        fh.setLevel(logging.DEBUG if verbose >= 2 else logging.INFO)
        fh.setFormatter(file_formatter())
        handlers.append(fh)
    old_level = root.level
    root.setLevel(min(h.level for h in handlers))
    for h in handlers:
        root.addHandler(h)
    logging.captureWarnings(True)
    try:
        yield
    finally:
        logging.captureWarnings(False)
        for h in handlers:
            root.removeHandler(h)
            h.close()
        root.setLevel(old_level)
