"""The command line's start: CPU seconds of ``snrmon --help``, ``snrmon --version`` and every
``snrmon COMMAND --help`` (subcommands too), each in a fresh interpreter as a user types it.

A command module imports what its work needs when it runs, not when the parser is built, so
each of these costs the interpreter and argparse only. The CPU time (user + system) of each
child is read from ``resource.getrusage(RUSAGE_CHILDREN)`` around it: the wall time on a shared
machine measures the other processes as much as this one. Each command line is run ``REPEATS``
times and its median kept.
"""

from __future__ import annotations

import resource
import statistics
import subprocess
import sys

KEY = "cli"
REPEATS = 3


def command_lines() -> list[list[str]]:
    """``--version``, ``--help`` and ``WORDS --help`` for every (sub)command of the parser."""
    from snrmon.cli import build_parser, iter_parsers

    lines = [["--version"], ["--help"]]
    for p in iter_parsers(build_parser()):
        words = p.prog.split()[1:]
        if words:
            lines.append([*words, "--help"])
    return lines


def child_cpu_s(argv: list[str]) -> float:
    """CPU seconds (user + system) of ``python -m snrmon ARGV`` run to its end."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(
        [sys.executable, "-m", "snrmon", *argv],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        check=True,
    )
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def run(duration_s: float) -> dict:
    """``cpu_s``: {command line: median CPU seconds}; ``max_cpu_s`` and ``slowest``: the
    costliest of them (the goal's figure). ``duration_s`` does not apply: each line runs
    ``REPEATS`` times."""
    cpu = {
        "snrmon " + " ".join(argv): statistics.median(child_cpu_s(argv) for _ in range(REPEATS))
        for argv in command_lines()
    }
    slowest = max(cpu, key=cpu.__getitem__)
    return {"cpu_s": cpu, "max_cpu_s": cpu[slowest], "slowest": slowest, "repeats": REPEATS}


def format_text(figures: dict) -> str:
    """One line per command line, its median CPU seconds, and the slowest."""
    lines = [f"  {line:40s} {cpu:6.3f} s" for line, cpu in figures["cpu_s"].items()]
    lines.append(
        f"  slowest: {figures['slowest']} {figures['max_cpu_s']:.3f} s CPU "
        f"(median of {figures['repeats']})"
    )
    return "\n".join(lines)
