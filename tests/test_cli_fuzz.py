"""Every command, fed bad arguments, exits 2 with one line naming the thing and never a
traceback. The commands and their options come from walking the parser, so a command added
later (by its ``register``) is fuzzed too.

Bad values per option: an unknown option; a word where a number is expected; a choice that is
not one; a custom-typed value that does not parse; a path that cannot exist (under a regular
file) for options that take files; an unknown preset for --sensor/--target; and each command
with its required arguments missing. The other required arguments get plausible values
(:data:`SAMPLES`), so that the bad one is what the command meets.
"""

from __future__ import annotations

import argparse
import signal

import numpy as np
import pytest

from snrmon.cli import DeprecatedAlias, build_parser, iter_parsers, main

TIMEOUT_S = 60  # a command that starts working instead of refusing would hang the suite

# Options whose odd value is legitimately accepted or waited for, with the reason.
EXEMPT = {
    ("listen", "port"): "a port that is not there yet is waited for (hot-plug); "
    "tests/drivers/test_listen_cli.py covers it (exit 1 at --timeout)",
    ("characterize", "target_name"): "any text is a name",
}


# Extra arguments that make a command get as far as the option under test.
EXTRA = {
    ("geo", "pixel"): ["--sensor", "mwir"],
    ("geo", "calibrate"): ["--sensor", "mwir"],
    ("model", "pvf"): ["--f-number", "2.0", "--pitch-um", "15"],
}
OUTPUT_SUFFIX = {("model", "plot"): ".png", ("report",): ".pdf", ("calibrate",): ".npz"}
# Commands whose samples above are complete: the error must name the very option under test.
# A command added later is held to one line naming some argument it was given.
STRICT = {
    "bench",
    "calibrate",
    "characterize",
    "demo",
    "devices",
    "doctor",
    "geo",
    "gui",
    "hil",
    "listen",
    "measure",
    "model",
    "record",
    "replay",
    "report",
}


def _leaves() -> list[tuple[tuple[str, ...], argparse.ArgumentParser]]:
    out = []
    for p in iter_parsers(build_parser()):
        words = tuple(p.prog.split()[1:])
        if words and p.get_default("func") is not None:
            out.append((words, p))
    return out


LEAVES = _leaves()


def _value_actions(p: argparse.ArgumentParser) -> list[argparse.Action]:
    skip = (
        argparse._HelpAction,
        argparse._VersionAction,
        argparse._StoreTrueAction,
        argparse._StoreFalseAction,
        argparse._CountAction,
        argparse._SubParsersAction,
    )
    return [
        a
        for a in p._actions
        if not isinstance(a, (*skip, DeprecatedAlias)) and a.dest != "log_file"
    ]


@pytest.fixture
def samples(tmp_path):
    stack = tmp_path / "stack.npy"
    np.save(stack, np.random.default_rng(0).integers(900, 1100, (4, 16, 16)).astype(np.uint16))
    not_a_dir = tmp_path / "a-file.txt"
    not_a_dir.write_text("a file, not a folder")
    bad_path = str(not_a_dir / "missing.dat")
    values = {
        "stack": str(stack),
        "at": "5,5",
        "camera": "mwir",
        "sensor": "mwir",
        "target": "uav1",
        "blackbody": f"{stack}:15",
        "out": str(tmp_path / "out.npz"),
        "site": "32,-106,1200",
        "pointing": "40,8,0",
        "band": "3,5",
        "temp_k": "300",
        "psf": "airy",
        "kind": "gps",
        "port": "/dev/null",
        "stop": "1",
    }
    return values, bad_path


def _argv(words, p, samples, override: dict[str, str]) -> list[str]:
    """The command with its required arguments: ``override`` first, else a sample, else the
    bad path (some commands have nothing plausible to offer without real files)."""
    values, bad_path = samples
    values = dict(values)
    out = values.pop("out")
    if words in OUTPUT_SUFFIX:  # the others' outputs get the path that cannot exist
        values["out"] = out.replace(".npz", OUTPUT_SUFFIX[words])
    argv = list(words) + EXTRA.get(words, [])
    for a in _value_actions(p):
        value = override.get(a.dest)
        if value is None and not a.required and a.option_strings:
            continue
        if value is None:
            value = values.get(a.dest, bad_path)
            if a.choices and value not in a.choices:
                value = sorted(a.choices)[0]
        if a.option_strings:
            argv += [a.option_strings[-1], value]
        else:
            argv.append(value)
    return argv


def _run(argv: list[str], capsys) -> tuple[int, str]:
    def hung(*_):
        raise TimeoutError(f"`snrmon {' '.join(argv)}` did not refuse within {TIMEOUT_S} s")

    old = signal.signal(signal.SIGALRM, hung)
    signal.alarm(TIMEOUT_S)
    try:
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse's own refusal
            code = exc.code
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    captured = capsys.readouterr()
    return code, captured.err


def _assert_one_line(code, err, argv, *names):
    lines = err.strip().splitlines()
    assert code == 2, f"snrmon {' '.join(argv)} -> exit {code}: {err}"
    assert len(lines) == 1 and "Traceback" not in err, f"snrmon {' '.join(argv)}:\n{err}"
    assert lines[0].startswith("snrmon ") and ": error: " in lines[0], lines[0]
    assert any(n in lines[0] for n in names), f"{lines[0]!r} names none of {names}"


def _cases():
    for words, p in LEAVES:
        yield pytest.param(words, None, "unknown", id=f"{'-'.join(words)}:unknown-option")
        if any(a.required for a in _value_actions(p)):
            yield pytest.param(words, None, "missing", id=f"{'-'.join(words)}:missing-required")
        for a in _value_actions(p):
            if (words[0], a.dest) in EXEMPT:
                continue
            yield pytest.param(words, a.dest, "bad", id=f"{'-'.join(words)}:{a.dest}")
            if a.dest in ("sensor", "target"):
                yield pytest.param(words, a.dest, "preset", id=f"{'-'.join(words)}:{a.dest}-preset")


@pytest.mark.parametrize(("words", "dest", "case"), list(_cases()))
def test_bad_arguments_exit_2_with_one_line(words, dest, case, samples, capsys):
    p = dict(LEAVES)[words]
    if case == "unknown":
        argv = [*_argv(words, p, samples, {}), "--no-such-option"]
        code, err = _run(argv, capsys)
        return _assert_one_line(code, err, argv, "--no-such-option")
    if case == "missing":
        argv = list(words)
        code, err = _run(argv, capsys)
        return _assert_one_line(code, err, argv, "required")
    action = next(a for a in _value_actions(p) if a.dest == dest)
    _, bad_path = samples
    if case == "preset":
        bad = "no-such-preset"
    elif action.choices:
        bad = "no-such-choice"
    elif action.type in (int, float):
        bad = "not-a-number"
    elif (
        action.type is not None
        and action.type is not str
        and getattr(action.type, "__name__", "") != "Path"
    ):
        bad = "@@garbage@@"  # a custom parser (X,Y, STACK:TEMP_C, odd integers, ...)
    else:
        bad = bad_path  # a file, folder or free text: a path that cannot exist
    argv = _argv(words, p, samples, {dest: bad})
    code, err = _run(argv, capsys)
    names = [bad, *action.option_strings, action.dest, "a-file.txt"]
    if words[0] not in STRICT:
        names += [t for t in argv if t not in words]
    _assert_one_line(code, err, argv, *names)


def test_every_command_is_fuzzed():
    """The walk finds the commands (a broken walk would fuzz nothing)."""
    names = {words[0] for words, _ in LEAVES}
    assert {"doctor", "measure", "record", "replay", "report", "model", "geo", "hil"} <= names
    assert ("model", "snr") in dict(LEAVES) and ("geo", "pixel") in dict(LEAVES)
