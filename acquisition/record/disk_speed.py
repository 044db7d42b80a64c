"""How fast a disk takes a recording: a plain sequential write measured past the write cache.

A VM's or a laptop's write-back cache takes the first gigabyte or two at several GB/s and then
falls to what the disk sustains, so a short timed write says nothing about a recording of an hour.
:func:`sequential_write` writes frame-sized blocks with an ``fsync`` every ``sync_every_mb`` (as
the recorder fsyncs at each flush) and counts the time of the final ``fsync`` too, so the figure
is what reached the disk, not the cache. The recorder's benchmark, ``snrmon hil --speed max
--out`` and the preflight check all use this one measurement.
"""

from __future__ import annotations

import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

MB = 1e6


@dataclass(frozen=True)
class DiskSpeed:
    """A sequential write: MB/s over ``written_mb`` MB in ``seconds`` (final fsync included)."""

    mb_per_s: float
    written_mb: float
    seconds: float
    directory: str


def sequential_write(
    directory: str | os.PathLike,
    *,
    total_mb: float = 512.0,
    block_bytes: int = 1280 * 720 * 2,
    sync_every_mb: float = 64.0,
    max_seconds: float = 10.0,
) -> DiskSpeed:
    """Write ``total_mb`` (or for ``max_seconds``, whichever comes first) to a temporary file in
    ``directory`` and delete it. Blocks are incompressible (random) so a compressing filesystem
    cannot flatter the figure. A directory that cannot be written is an OSError naming it."""
    d = Path(directory)
    if not d.is_dir():
        raise OSError(f"recording directory {d} does not exist")
    block = os.urandom(block_bytes)
    fd, name = tempfile.mkstemp(prefix=".snrmon-disk-", dir=d)
    written = 0
    try:
        t0 = time.perf_counter()
        next_sync = sync_every_mb * MB
        while written < total_mb * MB and time.perf_counter() - t0 < max_seconds:
            written += os.write(fd, block)
            if written >= next_sync:
                os.fsync(fd)
                next_sync += sync_every_mb * MB
        os.fsync(fd)
        seconds = time.perf_counter() - t0
    finally:
        os.close(fd)
        os.unlink(name)
    return DiskSpeed(written / MB / seconds, written / MB, seconds, str(d))
