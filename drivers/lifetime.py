"""A child process's lifetime bound to its parent's (Linux's parent-death signal).

A console killed without warning (SIGKILL, the OOM killer, a test runner's timeout) runs no
handler: children it spawned (a simulated camera, the model's worker) would keep running, holding
shared memory and a core. ``prctl(PR_SET_PDEATHSIG)`` asks the kernel to signal the child the
moment its parent ends, whatever the parent's way of ending.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys

PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def die_with_parent(parent_pid: int, sig: int = signal.SIGTERM) -> bool:
    """Called in a child right after it starts: the kernel sends it ``sig`` when the thread that
    spawned it ends (its process killed, or that thread finished: spawn children from a thread
    that lives as long as they should). If the parent ``parent_pid`` is already gone, the child
    exits at once. False where the platform has no parent-death signal (not Linux)."""
    if not sys.platform.startswith("linux"):
        return False
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(PR_SET_PDEATHSIG, int(sig), 0, 0, 0) != 0:
        return False
    if os.getppid() != parent_pid:  # the parent ended before the signal was armed
        os._exit(0)
    return True
