"""The ``snrmon`` command: finds the subcommands and runs one.

Every module in :mod:`snrmon.commands` that defines ``register(subparsers)``
adds one subcommand. ``register`` must set ``func`` on its parser with
``parser.set_defaults(func=run)``; ``run(args) -> int`` returns the exit code. Every option
needs a ``help`` text (a test walks the parser); ``--json`` output goes through
:func:`snrmon.output.emit_json`.

Exit codes, the same for every command (docs/cli.md):

* 0: done.
* 1: a runtime failure: a device that does not answer, a disk that fills, a recording that
  stops early; or an internal error (a bug), shown as ``internal error`` with the exception's
  type, and its traceback under ``-v``.
* 2: bad input or usage: an unknown option, a value of the wrong type, a missing or unreadable
  file, an unknown preset, a malformed config (:class:`UsageError`, ``ValueError`` and the
  ``OSError`` subclasses that name a path: :data:`BAD_INPUT`).
* 130: interrupted (Ctrl-C) before the command could finish its own way.

Every message has the one prefix ``snrmon COMMAND: error: ...`` (``warning:``, ``info:`` for
log lines), on one line, never a traceback unless ``-v``.

A closed pipe on standard output (``snrmon measure ... --json | head -c 10``) ends the output
quietly with exit 0, as ``cat`` and ``grep`` do: the reader has what it asked for.

SIGTERM (``kill``, a service manager stopping it, a closed terminal's SIGHUP) is taken as
Ctrl-C: the command's ``finally`` blocks run, so a recording is closed whole and the camera
processes and temporary files are cleaned up, instead of Python's default of dying on the spot.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import pkgutil
import re
import select
import signal
import sys
import threading
import traceback
from collections.abc import Iterator, Sequence

from snrmon import __version__, commands, logs, progress

EXIT_OK, EXIT_FAILURE, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130

log = logging.getLogger("snrmon")


class UsageError(Exception):
    """A problem with what the user asked for; printed as one line, exit code 2."""


BAD_INPUT: tuple[type[BaseException], ...] = (
    UsageError,
    argparse.ArgumentTypeError,
    ValueError,  # includes drivers.errors.ConfigError/ParseError, tomllib and json errors
    FileNotFoundError,
    FileExistsError,
    IsADirectoryError,
    NotADirectoryError,
    PermissionError,
)
"""Exceptions that mean "what you gave me is wrong": exit 2."""


class Parser(argparse.ArgumentParser):
    """argparse with snrmon's one-line errors: ``snrmon CMD: error: ...`` and exit 2, without
    the usage block (``--help`` has it).

    A value that starts with a minus and a digit is a value, not an option: argparse's own rule
    takes only a plain negative number, so ``--stops -100,200`` or ``--offset-s -1e-3`` was
    refused as "expected one argument" before the command could say what is wrong with it
    (``-inf`` and ``-nan`` too: a number, refused by the option's range).
    """

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r"^-(\.?\d|inf|nan)", re.IGNORECASE)

    def parse_known_args(self, args=None, namespace=None):  # type: ignore[override]
        # A required option given by its deprecated spelling is given: argparse counts only
        # the action it saw, so the new spelling is not required while the old one is used.
        words = list(sys.argv[1:] if args is None else args)
        relaxed = [
            a.target
            for a in self._actions
            if isinstance(a, DeprecatedAlias)
            and a.target.required
            and any(w == s or w.startswith(f"{s}=") for w in words for s in a.option_strings)
        ]
        for target in relaxed:
            target.required = False
        try:
            return super().parse_known_args(words, namespace)
        finally:
            for target in relaxed:
                target.required = True

    def error(self, message: str):  # type: ignore[override]
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _add_common(p: argparse.ArgumentParser, top: bool) -> None:
    # On the top level and on every subcommand, so both `snrmon -v record` and
    # `snrmon record -v` work; SUPPRESS keeps a subcommand from resetting the top level's value.
    # A subcommand that defines one of these itself keeps its own.
    g = p.add_argument_group("logging")
    for flags, kw in (
        (
            ("-v", "--verbose"),
            {
                "action": "count",
                "default": 0,
                "help": "more on stderr: -v info, -vv debug (and tracebacks of errors)",
            },
        ),
        (
            ("-q", "--quiet"),
            {
                "action": "store_true",
                "default": False,
                "help": "errors only on stderr, no progress bars",
            },
        ),
        (
            ("--log-file",),
            {
                "metavar": "FILE",
                "default": None,
                "help": "also write the log (info, or debug with -vv) to FILE",
            },
        ),
    ):
        if any(f in p._option_string_actions for f in flags):
            continue
        if not top:
            kw = {**kw, "default": argparse.SUPPRESS}
        g.add_argument(*flags, **kw)


class DeprecatedAlias(argparse.Action):
    """An old spelling of an option: hidden from ``--help``, it warns on one line and does
    what the new option does (the same type, choices and action)."""

    def __init__(self, option_strings: list[str], dest: str, *, target: argparse.Action):
        super().__init__(
            option_strings,
            dest,
            nargs=target.nargs,
            const=target.const,
            default=argparse.SUPPRESS,
            type=target.type,
            choices=target.choices,
            metavar=target.metavar,
            help=argparse.SUPPRESS,
        )
        self.target = target

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        new = max(self.target.option_strings, key=len)
        print(f"{parser.prog}: warning: {option_string} is deprecated, use {new}", file=sys.stderr)
        self.target(parser, namespace, values, new)


def add_deprecated_alias(parser: argparse.ArgumentParser, old: str, new: str) -> None:
    """``old`` as a deprecated spelling of ``parser``'s option ``new``."""
    target = parser._option_string_actions[new]
    parser.add_argument(old, action=DeprecatedAlias, dest=target.dest, target=target)


def iter_parsers(
    parser: argparse.ArgumentParser,
) -> Iterator[argparse.ArgumentParser]:
    """``parser`` and every subcommand's parser below it, depth first."""
    yield parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            seen: set[int] = set()
            for sub in action.choices.values():
                if id(sub) not in seen:  # aliases map to the same parser
                    seen.add(id(sub))
                    yield from iter_parsers(sub)


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="snrmon",
        description=(
            "Live infrared peak-pixel SNR of unresolved drones, measured (paper Eq. 4) "
            "beside the sensor model's prediction (Eqs. 1-3)."
        ),
        epilog="Exit codes: 0 ok, 1 runtime failure or internal error, 2 bad input or usage.",
    )
    parser.add_argument("--version", action="version", version=f"snrmon {__version__}")
    _add_common(parser, top=True)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{commands.__name__}.{info.name}")
        register = getattr(module, "register", None)
        if register is not None:
            register(sub)
    from snrmon.cli_vocabulary import DEPRECATED

    for p in iter_parsers(parser):
        for (prog, old), new in DEPRECATED.items():
            if prog == p.prog:
                add_deprecated_alias(p, old, new)
        if p is not parser:
            _add_common(p, top=False)
            p.set_defaults(prog=p.prog)  # the message prefix of the (sub)command that runs
    return parser


def _fill_optional_positionals(
    leaf: argparse.ArgumentParser, args: argparse.Namespace, extra: list[str]
) -> list[str]:
    """What is left of ``extra`` once the command's optional positionals (``nargs="?"``) that
    are still empty took their values from it, in order: argparse fills positionals from the
    first run of them only, so ``gps-import S.h5 --replace LOG`` left LOG unrecognized while
    ``gps-import S.h5 LOG --replace`` worked."""
    rest = list(extra)
    for action in leaf._actions:
        if action.option_strings or action.nargs != "?" or getattr(args, action.dest) is not None:
            continue
        value = next((v for v in rest if not v.startswith("-")), None)
        if value is None:
            break
        rest.remove(value)
        setattr(args, action.dest, action.type(value) if callable(action.type) else value)
    return rest


def _interrupt(signum: int, _frame: object) -> None:
    raise KeyboardInterrupt(signal.Signals(signum).name)


def stdout_closed() -> bool:
    """True when standard output is a pipe or socket whose reader is gone (``| head``): a
    BrokenPipeError is then the end of the output, not a device's or a link's failure."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):  # captured or replaced: no descriptor
        return False
    poller = select.poll()
    poller.register(fd, select.POLLOUT)
    return any(events & (select.POLLERR | select.POLLHUP) for _, events in poller.poll(0))


def _silence_stdout() -> None:
    """Standard output to the null device, so the interpreter's own flush at exit does not
    fail on the closed pipe again (the Python documentation's recipe, signal module)."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)


def main(argv: Sequence[str] | None = None) -> int:
    try:
        code = _main(argv)
        sys.stdout.flush()  # here, not at exit: a closed pipe is handled as below
        return code
    except BrokenPipeError:
        if not stdout_closed():
            raise
        _silence_stdout()
        return EXIT_OK


def _main(argv: Sequence[str] | None) -> int:
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    prog = getattr(args, "prog", "")
    leaf = next((p for p in iter_parsers(parser) if p.prog == prog), parser)
    extra = _fill_optional_positionals(leaf, args, extra)
    if extra:  # refused by the (sub)command they were given to, in its own words
        leaf.error(f"unrecognized arguments: {' '.join(extra)}")
    if getattr(args, "func", None) is None:
        parser.print_help()
        return EXIT_USAGE
    prog = getattr(args, "prog", "snrmon")
    previous: dict[int, object] = {}
    if threading.current_thread() is threading.main_thread():  # only it may set handlers
        for sig in (signal.SIGTERM, signal.SIGHUP):
            previous[sig] = signal.signal(sig, _interrupt)
    try:
        with logs.configured(prog, verbose=args.verbose, quiet=args.quiet, log_file=args.log_file):
            progress.set_quiet(args.quiet, verbose=args.verbose >= 1, prog=prog)
            return _run(args, prog)
    except BrokenPipeError:
        raise
    except OSError as exc:  # the --log-file itself cannot be opened
        print(f"{prog}: error: --log-file: {exc}", file=sys.stderr)
        return EXIT_USAGE
    finally:
        progress.set_quiet(False)
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _first_line(exc: BaseException) -> str:
    text = str(exc.args[0]) if isinstance(exc, KeyError) and exc.args else str(exc)
    lines = text.strip().splitlines()
    return lines[0] if lines else type(exc).__name__


def _run(args: argparse.Namespace, prog: str) -> int:
    verbose = args.verbose >= 1
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED
    except BAD_INPUT as exc:
        _report(prog, _first_line(exc), exc, verbose)
        return EXIT_USAGE
    except OSError as exc:
        if isinstance(exc, BrokenPipeError) and stdout_closed():
            raise  # the reader of the output is gone: main() ends quietly
        # A device, a link or a disk failed while working: a runtime failure.
        _report(prog, _first_line(exc), exc, verbose)
        return EXIT_FAILURE
    except Exception as exc:
        # Anything else is a bug, not the user's input: say so, with the traceback under -v.
        hint = "" if verbose else " (run with -v for the traceback)"
        message = f"internal error: {type(exc).__name__}: {_first_line(exc)}{hint}"
        _report(prog, message, exc, verbose)
        return EXIT_FAILURE


def _report(prog: str, message: str, exc: BaseException, show_traceback: bool) -> None:
    """The one error line on stderr (and the traceback with -v); the log file, if any, gets
    the line and the traceback whatever the verbosity."""
    print(f"{prog}: error: {message}", file=sys.stderr)
    if show_traceback:
        traceback.print_exception(exc, file=sys.stderr)
    log.error(message, exc_info=exc, extra={logs.FILE_ONLY: True})
