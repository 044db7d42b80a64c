"""A function run in a forked child process, its result pickled back: the batch replay's second
core (:func:`snrmon.acquisition.replay.batch.replay_session` plays each camera's frames in a
process of its own).

Fork, not spawn: the child starts in milliseconds with everything the parent holds (the imports,
the compiled kernels it loaded, the recording's inputs already read, the engine already built),
where a spawned interpreter takes a second to import. What cannot cross a fork is kept out of the
child: it touches no HDF5 object (the library's state is the parent's copy, its lock possibly
held by another thread at the fork; h5py's own advice is not to use a file opened before a fork
in the child), so the caller hands it only what is in memory or memory-mapped; its cyclic garbage
collector is off, so no object of the parent's (an h5py one) is finalised in it; and it leaves
with ``os._exit``, so no exit handler or finaliser of the parent's runs twice.
"""

from __future__ import annotations

import contextlib
import fcntl
import gc
import os
import pickle
import signal
import threading
import time
import traceback
from collections.abc import Callable
from typing import Generic, TypeVar

T = TypeVar("T")

_CHUNK = 1 << 20
_PIPE_BYTES = 1 << 20  # Linux's default most for an unprivileged process


def can_fork() -> bool:
    """True where a child can be forked and the machine has more than one core."""
    return hasattr(os, "fork") and _cores() > 1


def idle_core(looks: int = 5) -> bool:
    """True when a core is idle: fewer tasks running or waiting to run than there are cores,
    this process included, in one of ``looks`` readings of Linux's ``/proc/loadavg`` a
    millisecond apart (a task that runs for a moment, a shell command or a kernel worker, does
    not keep a core busy; elsewhere a core is assumed idle). A child forked beside another
    running task made a replay slower, not faster, on the 2-core development machine
    (docs/engine.md, "Fast replay")."""
    cores = _cores()
    for look in range(looks):
        if look:
            time.sleep(0.001)  # the next reading, not a synchronisation
        try:
            with open("/proc/loadavg") as fh:
                running = int(fh.read().split()[3].split("/")[0])
        except (OSError, ValueError, IndexError):
            return True
        if running < cores:
            return True
    return False


def _cores() -> int:
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


class Forked(Generic[T]):
    """``fn()`` running in a forked child from construction on; :meth:`result` waits for it
    and returns its value, or raises what it raised (with the child's traceback as a note)."""

    def __init__(self, fn: Callable[[], T]) -> None:
        read_fd, write_fd = os.pipe()
        # A pipe that holds the whole result (hundreds of kB; 64 kB by default): the child
        # writes it and is gone, and the parent need not wait for a busy machine to give the
        # child a core again to write the rest once the parent reads.
        with contextlib.suppress(OSError, AttributeError):
            fcntl.fcntl(write_fd, fcntl.F_SETPIPE_SZ, _PIPE_BYTES)
        pid = os.fork()
        if pid == 0:  # the child: never returns
            os.close(read_fd)
            _child(fn, write_fd)
        os.close(write_fd)
        self.pid = pid
        self._fd: int | None = read_fd

    def result(self) -> T:
        fd = self._fd
        if fd is None:
            raise RuntimeError("the child's result was taken already")
        chunks = []
        try:
            while chunk := os.read(fd, _CHUNK):
                chunks.append(chunk)
        finally:
            os.close(fd)
            self._fd = None
        try:
            kind, value, trace = pickle.loads(b"".join(chunks))
        except Exception:  # nothing, or cut short: the child died
            _, status = os.waitpid(self.pid, 0)
            how = _how(status)
            raise RuntimeError(f"child process {self.pid} ended without a result ({how})") from None
        # Its exit (unmapping the memory it shares with this process: ~7 ms) is not waited for.
        threading.Thread(target=os.waitpid, args=(self.pid, 0), daemon=True).start()
        if kind == "error":
            value.add_note(f"in child process {self.pid}:\n{trace}")
            raise value
        return value

    def cancel(self) -> None:
        """Stop the child (the parent failed): killed and reaped, its result dropped."""
        if self._fd is None:
            return
        with contextlib.suppress(ProcessLookupError):
            os.kill(self.pid, signal.SIGKILL)
        os.close(self._fd)
        self._fd = None
        os.waitpid(self.pid, 0)


def _child(fn: Callable[[], object], fd: int) -> None:
    gc.disable()
    status = 0
    try:
        try:
            payload = pickle.dumps(("ok", fn(), ""), pickle.HIGHEST_PROTOCOL)
        except BaseException as exc:  # everything goes back to the parent, which raises it
            status = 1
            trace = traceback.format_exc()
            try:
                payload = pickle.dumps(("error", exc, trace), pickle.HIGHEST_PROTOCOL)
                pickle.loads(payload)  # an exception that cannot be rebuilt goes as text
            except Exception:
                text = RuntimeError(f"{type(exc).__name__}: {exc}")
                payload = pickle.dumps(("error", text, trace), pickle.HIGHEST_PROTOCOL)
        view = memoryview(payload)
        while view:
            view = view[os.write(fd, view) :]
        os.close(fd)  # the parent reads to the end now, not once this process has exited
    finally:
        os._exit(status)


def _how(status: int) -> str:
    if os.WIFSIGNALED(status):
        return f"killed by signal {os.WTERMSIG(status)}"
    return f"exit status {os.waitstatus_to_exitcode(status)}"
