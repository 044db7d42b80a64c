"""One benchmark run in a fresh interpreter, as ``snrmon bench`` runs each of them.

Run one after another in one process, a benchmark measured what the earlier ones left behind as
much as its own subject: their threads, the BLAS pool a model call woke, a heap grown by
hundreds of MB that makes every full garbage collection longer. The console, the replay and the
recorder each run in their own process in the field, so each benchmark does here:
``python -m snrmon.benchmarks.fresh_process KEY DURATION_S OUT.json`` runs ``KEY``'s module and
writes its figures to ``OUT.json``.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np


class BenchmarkError(RuntimeError):
    """A benchmark's process ended with an error (its traceback is on standard error)."""


def figures_in_fresh_process(module: ModuleType, duration_s: float) -> dict:
    """``module.run(duration_s)`` in a new interpreter; its figures as JSON gives them back
    (tuples as lists). What the benchmark prints (its warnings) goes to standard error."""
    with tempfile.TemporaryDirectory(prefix="snrmon-bench-") as tmp:
        out = Path(tmp) / "figures.json"
        argv = [sys.executable, "-m", __name__, module.__name__, repr(duration_s), str(out)]
        proc = subprocess.run(argv, capture_output=True, text=True, check=False)
        sys.stderr.write(proc.stdout + proc.stderr)
        if proc.returncode != 0 or not out.exists():
            raise BenchmarkError(
                f"benchmark {module.__name__.rsplit('.', 1)[-1]} failed "
                f"(exited with {proc.returncode})"
            )
        return json.loads(out.read_text())


def plain(value: Any) -> Any:
    """A figure JSON cannot write as it is, as plain Python: a NumPy scalar its value, an array
    its list, anything else its text. NaN stays NaN (json writes it; the parent reads it)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


def main(argv: list[str]) -> int:
    import importlib

    name, duration, out = argv
    figures = importlib.import_module(name).run(float(duration))
    Path(out).write_text(json.dumps(figures, default=plain))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
