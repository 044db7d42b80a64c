"""The ``snrmon`` command: finds the subcommands and runs one.

Every module in :mod:`snrmon.commands` that defines ``register(subparsers)``
adds one subcommand. ``register`` must set ``func`` on its parser with
``parser.set_defaults(func=run)``; ``run(args) -> int`` returns the exit code.

Errors meant for the user are raised as :class:`UsageError` (or any
``ValueError``/``OSError`` subclass the packages raise for bad input) and are
printed as one line on stderr with a non-zero exit, never as a traceback.

SIGTERM (``kill``, a service manager stopping it, a closed terminal's SIGHUP) is taken as
Ctrl-C: the command's ``finally`` blocks run, so a recording is closed whole and the camera
processes and temporary files are cleaned up, instead of Python's default of dying on the spot.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import signal
import sys
import threading
from collections.abc import Sequence

from snrmon import __version__, commands


class UsageError(Exception):
    """A problem with what the user asked for; printed as one line, exit code 2."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="snrmon",
        description=(
            "Live infrared peak-pixel SNR of unresolved drones, measured (paper Eq. 4) "
            "beside the sensor model's prediction (Eqs. 1-3)."
        ),
    )
    parser.add_argument("--version", action="version", version=f"snrmon {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{commands.__name__}.{info.name}")
        register = getattr(module, "register", None)
        if register is not None:
            register(sub)
    return parser


def _interrupt(signum: int, _frame: object) -> None:
    raise KeyboardInterrupt(signal.Signals(signum).name)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "func", None) is None:
        parser.print_help()
        return 2
    previous: dict[int, object] = {}
    if threading.current_thread() is threading.main_thread():  # only it may set handlers
        for sig in (signal.SIGTERM, signal.SIGHUP):
            previous[sig] = signal.signal(sig, _interrupt)
    try:
        return _run(args)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _run(args: argparse.Namespace) -> int:
    try:
        return int(args.func(args) or 0)
    except UsageError as exc:
        print(f"snrmon {args.command}: {exc}", file=sys.stderr)
        return 2
    except (ValueError, OSError, KeyError) as exc:
        # Bad input from the packages (a malformed file, a missing port, an
        # unknown preset): one line naming the thing, no traceback.
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"snrmon {args.command}: error: {msg}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
