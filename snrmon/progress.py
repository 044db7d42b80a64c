"""Progress bars for long commands (replay, report, record, ...), on a terminal only.

A bar is drawn with tqdm on stderr when stderr is a terminal and ``-q`` was not given; piped
or redirected output (a log file, CI, ``nohup``) gets no carriage returns: long commands print a
plain line now and then instead (see ``snrmon record``).
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager

log = logging.getLogger(__name__)
_QUIET = False
_VERBOSE = False
_PROG = "snrmon"


def set_quiet(quiet: bool, verbose: bool = False, prog: str = "snrmon") -> None:
    """``-q``: no bars and no status lines; ``-v``: status lines come through the log;
    ``prog``: the prefix of every line on stderr (the CLI calls this per command)."""
    global _QUIET, _VERBOSE, _PROG
    _QUIET, _VERBOSE, _PROG = quiet, verbose, prog


def say(text: str, level: str = "info") -> None:
    """One line for the operator on stderr, with the prefix of every snrmon message
    (``snrmon COMMAND: info: ...``, or ``warning:``); none under ``-q`` (errors only). Log
    files (``--log-file``, a recording's log) keep it whatever ``-q`` says."""
    from snrmon.logs import FILE_ONLY

    log.log(logging.getLevelName(level.upper()), "%s", text, extra={FILE_ONLY: True})
    if not _QUIET:
        print(f"{_PROG}: {level}: {text}", file=sys.stderr, flush=True)


def on_terminal() -> bool:
    """True when a bar may be drawn: stderr is a terminal and ``-q`` is off."""
    isatty = getattr(sys.stderr, "isatty", None)
    return not _QUIET and bool(isatty and isatty())


@contextmanager
def frame_progress(desc: str, unit: str = "frame") -> Iterator[Callable[[int, int], None] | None]:
    """A ``progress(done, total)`` callback drawing one tqdm bar, or None off a terminal (the
    callers' ``progress=None`` then costs nothing). The bar is made at the first call, so an
    input that fails before any work leaves no bar behind."""
    if not on_terminal():
        yield None
        return
    bars = []

    def progress(done: int, total: int) -> None:
        if not bars:
            from tqdm import tqdm

            bars.append(tqdm(total=total, unit=unit, desc=desc, file=sys.stderr, leave=False))
        bar = bars[0]
        if bar.total != total:
            bar.total = total
        bar.n = done
        bar.refresh()

    try:
        yield progress
    finally:
        for bar in bars:
            bar.close()


PLAIN_EVERY_S = 5.0
"""Off a terminal, a status line every this many seconds (a log, not an animation)."""


@contextmanager
def status_progress(total_s: float | None, desc: str) -> Iterator[Callable[[float, str], None]]:
    """``show(elapsed_s, status_line)`` for a command that runs for ``total_s`` seconds (None:
    until interrupted): a tqdm bar with the status line on a terminal; elsewhere the line,
    newline-terminated, every :data:`PLAIN_EVERY_S` (never carriage returns in a log). Every
    :data:`PLAIN_EVERY_S` the line is also logged at info level, so a recording's own log
    (``FILE.log``) and ``--log-file`` keep it."""
    import time

    bar = None
    last_plain = [-float("inf")]

    def show(elapsed_s: float, line: str) -> None:
        nonlocal bar
        if on_terminal():
            if bar is None:
                from tqdm import tqdm

                bar = tqdm(
                    total=total_s,
                    unit="s",
                    desc=desc,
                    file=sys.stderr,
                    bar_format="{desc}: {n:.0f}/{total_fmt} s |{bar}| {postfix}"
                    if total_s
                    else "{desc}: {n:.0f} s {postfix}",
                )
            bar.n = min(elapsed_s, total_s) if total_s else elapsed_s
            bar.set_postfix_str(line, refresh=True)
        if time.monotonic() - last_plain[0] < PLAIN_EVERY_S:
            return
        last_plain[0] = time.monotonic()
        log.info("%s: %s", desc, line)
        if not (_QUIET or _VERBOSE or on_terminal()):  # with -v the log line is on stderr
            print(f"{_PROG}: info: {desc}: {line}", file=sys.stderr, flush=True)

    try:
        yield show
    finally:
        if bar is not None:
            bar.close()
