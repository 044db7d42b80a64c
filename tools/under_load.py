"""Run a command with busy loops on the machine: the answers of a test that assumes an idle
machine (a timeout, a deadline) change under load; these must not.

    python tools/under_load.py [--loops N] -- COMMAND [ARG ...]

Starts N processes spinning ``while True: pass`` (default 2, the cores of the development
machine), runs COMMAND, stops the loops (by their own process ids) however it ends, and prints on
stderr how much CPU each loop took meanwhile and the command's wall time: a loop that took
little CPU means the command did not run under the load asked. Exits with COMMAND's code.
``make bad-input-under-load`` runs the bad-input table this way.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

BUSY = "while True: pass"


def _cpu_s(pid: int) -> float:
    """User + system CPU seconds of a running process (Linux ``/proc``)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--loops", type=int, default=2, help="busy loops to run (default: 2)")
    p.add_argument("command", nargs=argparse.REMAINDER, help="-- COMMAND [ARG ...]")
    args = p.parse_args(argv)
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not command or args.loops < 1:
        p.error("needs --loops N >= 1 and a COMMAND after --")
    loops = [subprocess.Popen([sys.executable, "-c", BUSY]) for _ in range(args.loops)]
    t0 = time.monotonic()
    try:
        code = subprocess.call(command)
    finally:
        wall_s = time.monotonic() - t0
        spent = []
        for loop in loops:
            try:
                spent.append(_cpu_s(loop.pid))
            except OSError:  # it died on its own: no figure
                spent.append(None)
            loop.kill()
            loop.wait()
    figures = ", ".join("?" if s is None else f"{s:.1f} s" for s in spent)
    print(
        f"under_load: {args.loops} busy loops took {figures} of CPU while the command ran "
        f"{wall_s:.1f} s (exit {code})",
        file=sys.stderr,
    )
    return code


if __name__ == "__main__":
    sys.exit(main())
