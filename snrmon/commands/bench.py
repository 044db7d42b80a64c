"""``snrmon bench``: speed and memory figures of this machine (see ``benchmarks/``), each
benchmark in a fresh interpreter (``benchmarks/fresh_process.py``), and the goals they are held
to (``benchmarks/goals.py``)."""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import platform
import sys

from snrmon.cli import EXIT_FAILURE, EXIT_OK, UsageError
from snrmon.extras import MissingExtraError, require
from snrmon.output import emit_json
from snrmon.progress import say


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench", help="measure throughput, latency and memory on this machine")
    p.add_argument(
        "--duration",
        type=float,
        default=10.0,
        metavar="S",
        help="seconds of sustained acquisition, an hour is the soak test (default: %(default)s)",
    )
    p.add_argument(
        "--only",
        metavar="KEYS",
        help="comma-separated benchmark keys to run (default: all)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def _modules() -> dict:
    """{key: module} of every ``benchmarks/bench_*.py``."""
    from snrmon import benchmarks

    out = {}
    for info in sorted(pkgutil.iter_modules(benchmarks.__path__), key=lambda m: m.name):
        if info.name.startswith("bench_"):
            module = importlib.import_module(f"{benchmarks.__name__}.{info.name}")
            out[getattr(module, "KEY", info.name.removeprefix("bench_"))] = module
    return out


def run(args: argparse.Namespace) -> int:
    from snrmon.benchmarks.fresh_process import BenchmarkError, figures_in_fresh_process

    if not args.duration > 0:
        raise UsageError(f"--duration must be positive, got {args.duration}")
    only = {k.strip() for k in (args.only or "").split(",") if k.strip()}
    modules = _modules()
    unknown = sorted(only - set(modules))
    if unknown:
        raise UsageError(f"--only {','.join(unknown)}: unknown; known: {', '.join(modules)}")
    result: dict = {
        "machine": {
            "python": platform.python_version(),
            "processor": platform.processor() or platform.machine(),
        }
    }
    texts: dict[str, str] = {}
    failed: list[str] = []
    for key, module in modules.items():
        if only and key not in only:
            continue
        extra = getattr(module, "EXTRA", None)  # e.g. "gui": the console's benchmark
        if extra is not None:
            if only:
                require(extra, f"bench --only {key}")
            else:
                try:
                    require(extra, f"the {key} benchmark")
                except MissingExtraError as exc:
                    print(f"{args.prog}: warning: skipped: {exc}", file=sys.stderr)
                    continue
        if not args.json:
            say(f"running {key} ...")
        try:
            figures = figures_in_fresh_process(module, args.duration)
        except BenchmarkError as exc:  # the others' figures are still worth their minutes
            print(f"{args.prog}: error: {exc}", file=sys.stderr, flush=True)
            failed.append(key)
            continue
        if getattr(module, "TOP_LEVEL", False):
            # A module that reports several top-level sections (acquisition and replay).
            for section, values in figures.items():
                result.setdefault(section, {}).update(values)
        else:
            result.setdefault(key, {}).update(figures)
        if hasattr(module, "format_text"):  # a table rather than name/value lines
            texts[key] = module.format_text(figures)
    from snrmon.benchmarks.goals import format_goals, goal_rows

    goals = goal_rows(result)
    status = EXIT_FAILURE if failed else EXIT_OK
    if args.json:
        emit_json({**result, "goals": goals, "failed": failed}, indent=2)
        return status
    for key, figures in result.items():
        print(f"[{key}]")
        if key in texts:
            print(texts[key])
            continue
        for name, value in figures.items():
            shown = f"{value:.4g}" if isinstance(value, float) else value
            print(f"  {name:32s} {shown}")
    if goals:
        print("[goals]")
        print(format_goals(goals))
    if failed:
        print(f"[failed]\n  {', '.join(failed)}")
    return status
