"""Conventions every command keeps (walked generically, so new commands are held to them):
help text on every option, strict JSON through the one helper, uniform exit codes and message
prefix, internal errors shown as such, logging set up by the CLI."""

from __future__ import annotations

import argparse
import ast
import errno
import io
import json
import logging
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from snrmon import commands
from snrmon.cli import build_parser, iter_parsers, main
from snrmon.output import dumps, strict

COMMANDS_DIR = Path(commands.__file__).parent


def test_every_option_of_every_command_has_help():
    missing = []
    for p in iter_parsers(build_parser()):
        for a in p._actions:
            if isinstance(a, argparse._SubParsersAction):
                missing += [f"{p.prog} {c.dest}" for c in a._choices_actions if not c.help]
            elif not (a.help and a.help.strip()) and a.help is not argparse.SUPPRESS:
                missing.append(f"{p.prog} {'/'.join(a.option_strings) or a.dest}")
    assert not missing, "options without help: " + ", ".join(missing)


def test_logging_options_work_before_and_after_the_command():
    parser = build_parser()
    for argv in (["-v", "devices"], ["devices", "-v"]):
        assert parser.parse_args(argv).verbose == 1
    args = parser.parse_args(["-q", "--log-file", "x.log", "devices"])
    assert args.quiet and args.log_file == "x.log"
    assert parser.parse_args(["devices", "--log-file", "y.log"]).log_file == "y.log"


def _json_calls(tree: ast.AST) -> list[int]:
    return [
        node.lineno
        for node in ast.walk(tree)
        if isinstance(node, ast.Call)
        and isinstance(node.func, ast.Attribute)
        and node.func.attr in ("dump", "dumps")
        and isinstance(node.func.value, ast.Name)
        and node.func.value.id == "json"
    ]


def test_commands_print_json_only_through_the_strict_helper():
    """No command calls json.dump(s) itself (it would let NaN through); every command module
    with a --json option uses snrmon.output."""
    offenders = {}
    for path in sorted(COMMANDS_DIR.glob("*.py")):
        source = path.read_text()
        lines = _json_calls(ast.parse(source))
        if lines:
            offenders[path.name] = lines
        if '"--json"' in source:
            assert "from snrmon.output import" in source, f"{path.name} has --json without it"
    assert not offenders, f"json.dump(s) in commands (use snrmon.output.emit_json): {offenders}"


def test_strict_json_has_no_nan_and_plain_types():
    obj = {
        "a": math.nan,
        "b": [np.float32(1.5), np.inf, -math.inf],
        "c": np.int64(3),
        "d": np.array([[1.0, np.nan]]),
        "e": (Path("/x"), np.bool_(True)),
        7: None,
    }
    assert strict(obj) == {
        "a": None,
        "b": [1.5, None, None],
        "c": 3,
        "d": [[1.0, None]],
        "e": ["/x", True],
        "7": None,
    }
    text = dumps(obj)
    json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in strict JSON"))
    with pytest.raises(TypeError, match="cannot write object"):
        dumps({"x": object()})


def test_an_internal_error_is_shown_as_one_and_traced_under_v(monkeypatch, capsys):
    from snrmon.commands import devices

    def bug():
        return {}["serial"]  # a KeyError from a bug, not from the user's input

    monkeypatch.setattr(devices, "collect", bug)
    assert main(["devices"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "snrmon devices: error: internal error: KeyError: serial (run with -v for the traceback)"
    ]
    assert main(["devices", "-v"]) == 1
    err = capsys.readouterr().err
    assert "internal error: KeyError: serial" in err and "Traceback (most recent call last)" in err
    assert 'return {}["serial"]' in err


@pytest.mark.parametrize(
    ("exc", "code"),
    [
        (ValueError("bad value 7"), 2),
        (FileNotFoundError("x.h5 does not exist"), 2),
        (PermissionError("cannot write /root/x"), 2),
        (OSError(errno.EIO, "the disk failed"), 1),
        (RuntimeError("something unexpected"), 1),
    ],
)
def test_exit_codes_by_kind_of_failure(monkeypatch, capsys, exc, code):
    from snrmon.commands import devices

    def fail():
        raise exc

    monkeypatch.setattr(devices, "collect", fail)
    assert main(["devices"]) == code
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("snrmon devices: error: ")


def test_logging_levels_and_log_file(monkeypatch, capsys, tmp_path):
    from snrmon.commands import devices

    def talk():
        log = logging.getLogger("snrmon.drivers.test")
        log.info("an info line")
        log.warning("a warning line")
        # A library's own line (tifffile logs its complaint before it raises): not on stderr,
        # where snrmon's one error line says what went wrong, unless -v.
        logging.getLogger("tifffile").error("a library's line")
        return {k: {"available": True, "devices": [], "note": ""} for k in devices.SECTIONS}

    monkeypatch.setattr(devices, "collect", talk)
    assert main(["devices"]) == 0
    err = capsys.readouterr().err
    assert "snrmon devices: warning: a warning line" in err and "info line" not in err
    assert "a library's line" not in err
    assert main(["-v", "devices"]) == 0
    err = capsys.readouterr().err
    assert "snrmon devices: info: an info line" in err and "a library's line" in err
    log_file = tmp_path / "day.log"
    assert main(["devices", "-q", "--log-file", str(log_file)]) == 0
    assert capsys.readouterr().err == ""  # -q: errors only
    text = log_file.read_text()
    assert "INFO    MainThread snrmon.drivers.test: an info line" in text
    assert "a warning line" in text and "tifffile: a library's line" in text
    handlers = logging.getLogger().handlers  # the CLI's are removed when the command ends
    assert not any(getattr(h, "baseFilename", "") == str(log_file) for h in handlers)


def test_a_bad_log_file_is_bad_input(capsys, tmp_path):
    assert main(["devices", "--log-file", str(tmp_path / "no" / "x.log")]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("snrmon devices: error: --log-file: ") and "x.log" in line


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bars_only_on_a_terminal(monkeypatch):
    from snrmon import progress

    monkeypatch.setattr(sys, "stderr", io.StringIO())  # piped: no bar, no carriage return
    with progress.frame_progress("replay") as cb:
        assert cb is None
    monkeypatch.setattr(progress, "PLAIN_EVERY_S", 0.0)
    with progress.status_progress(10.0, "recording") as show:
        for t in (0.0, 1.0):
            show(t, f"{t:.0f} s | cam {int(t * 60)} frames")
    lines = sys.stderr.getvalue().splitlines()
    # the prefix of every line on stderr (the CLI sets the command's; "snrmon" outside it)
    assert lines == [
        "snrmon: info: recording: 0 s | cam 0 frames",
        "snrmon: info: recording: 1 s | cam 60 frames",
    ]
    assert "\r" not in sys.stderr.getvalue()

    terminal = _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    with progress.frame_progress("replay") as cb:
        cb(50, 200)
        cb(200, 200)
    assert "replay" in terminal.getvalue() and "200/200" in terminal.getvalue()
    progress.set_quiet(True)  # -q: no bar even on a terminal
    try:
        with progress.frame_progress("replay") as cb:
            assert cb is None
    finally:
        progress.set_quiet(False)
