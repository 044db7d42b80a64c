"""One word, one meaning: every parser walked against the one vocabulary table
(:mod:`snrmon.cli_vocabulary`), the table against docs/cli.md, and each deprecated spelling
still working with its one-line warning."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import numpy as np
import pytest

from snrmon.cli import DeprecatedAlias, build_parser, iter_parsers, main
from snrmon.cli_vocabulary import DEPRECATED, NO_JSON, OPTIONS, POSITIONALS

DOCS = Path(__file__).resolve().parent.parent / "docs" / "cli.md"
NOT_OPTIONS = (argparse._HelpAction, argparse._VersionAction, argparse._SubParsersAction)


def _metavar(a: argparse.Action) -> str | None:
    """What the value looks like: the metavar, the choices as a|b, None for a flag."""
    if a.nargs == 0:
        return None
    if a.metavar is not None:
        return str(a.metavar)
    return "|".join(map(str, a.choices)) if a.choices else a.dest.upper()


def _uses() -> list[tuple[str, str, argparse.Action]]:
    """(command, name, action) of every option and positional of every command."""
    out = []
    for p in iter_parsers(build_parser()):
        for a in p._actions:
            if isinstance(a, (*NOT_OPTIONS, DeprecatedAlias)):
                continue
            name = max(a.option_strings, key=len) if a.option_strings else a.dest
            out.append((p.prog, name, a))
    return out


USES = _uses()


def test_every_option_is_in_the_vocabulary_with_its_one_metavar():
    wrong = []
    for prog, name, a in USES:
        table = OPTIONS if a.option_strings else POSITIONALS
        word = table.get(name)
        if word is None:
            wrong.append(f"{prog} {name}: not in snrmon/cli_vocabulary.py")
        elif _metavar(a) != word.metavar:
            wrong.append(f"{prog} {name}: metavar {_metavar(a)!r}, the vocabulary {word.metavar!r}")
    assert not wrong, "\n".join(wrong)


def test_one_name_one_metavar_across_commands():
    """The table's rule, seen from the parsers (a table entry used two ways fails here too)."""
    seen: dict[str, dict[str | None, list[str]]] = {}
    for prog, name, a in USES:
        seen.setdefault(name, {}).setdefault(_metavar(a), []).append(prog)
    two = {n: m for n, m in seen.items() if len(m) > 1}
    assert not two, two


def test_short_o_is_the_main_output_everywhere():
    for prog, name, a in USES:
        if "-o" in a.option_strings:
            assert name == "--out", prog
        if name == "--out":
            assert "-o" in a.option_strings, f"{prog} --out has no -o"


def test_every_real_default_is_stated_in_the_help():
    unstated = [
        f"{prog} {name} (default {a.default!r})"
        for prog, name, a in USES
        if a.option_strings
        and a.nargs != 0
        and a.default not in (None, argparse.SUPPRESS)
        and "%(default)s" not in (a.help or "")
    ]
    assert not unstated, "defaults not stated: " + ", ".join(unstated)


def test_every_command_that_prints_a_result_takes_json():
    leaves = [p for p in iter_parsers(build_parser()) if p.get_default("func") is not None]
    missing = [
        p.prog for p in leaves if p.prog not in NO_JSON and "--json" not in p._option_string_actions
    ]
    assert not missing, missing
    assert set(NO_JSON) <= {p.prog for p in leaves}  # no stale exemption


def test_the_same_positional_name_for_the_same_thing():
    # a session file is `session` wherever a command takes exactly one
    for prog, name, a in USES:
        if not a.option_strings and a.metavar == "SESSION.h5":
            assert name in ("session", "sessions"), prog


def _doc_rows(heading: str) -> list[list[str]]:
    text = DOCS.read_text()
    section = text.split(f"## {heading}\n", 1)[1].split("\n## ", 1)[0]
    return [
        [c.strip() for c in re.split(r"(?<!\\)\|", line.strip()[1:-1])]
        for line in section.splitlines()
        if line.startswith("| `")
    ]


def _cell(text: str) -> str:
    return text.replace("\\|", "|").strip("`")


def test_docs_list_the_vocabulary_as_the_table_has_it():
    rows = {_cell(r[0]): r for r in _doc_rows("Vocabulary")}
    commands: dict[str, set[str]] = {}
    for prog, name, _ in USES:
        commands.setdefault(name, set()).add(prog.removeprefix("snrmon ") or "snrmon")
    EVERY = {p.prog.removeprefix("snrmon ") or "snrmon" for p in iter_parsers(build_parser())}
    for name, word in {**OPTIONS, **POSITIONALS}.items():
        assert name in rows, f"docs/cli.md does not list {name}"
        metavar, meaning, used_by = (_cell(c) for c in rows[name][1:4])
        assert metavar == (word.metavar or "(flag)"), name
        assert meaning == word.meaning, name
        used = commands.get(name, set())
        assert used_by == "every command" if used == EVERY else set(used_by.split(", ")) == used
    assert set(rows) == set(OPTIONS) | set(POSITIONALS)


def test_docs_list_every_deprecated_spelling():
    rows = {(_cell(r[0]), _cell(r[1])): _cell(r[2]) for r in _doc_rows("Deprecated spellings")}
    expected = {(prog.removeprefix("snrmon "), old): new for (prog, old), new in DEPRECATED.items()}
    assert rows == expected


def test_every_deprecated_spelling_names_a_current_option_of_its_command():
    parsers = {p.prog: p for p in iter_parsers(build_parser())}
    for (prog, old), new in DEPRECATED.items():
        alias = parsers[prog]._option_string_actions[old]
        assert isinstance(alias, DeprecatedAlias) and new in alias.target.option_strings
        assert alias.help is argparse.SUPPRESS  # not in --help


# One command line per deprecated spelling that gets as far as the parsed option: the old
# spelling with a value a check right after parsing refuses (exit 2), so the test shows the
# option reached the command under its new name, without running the command's work.
GEO = ["--site", "0,0,0", "--pointing", "0,0,0"]
PLOT = ["model", "plot", "--sensor", "mwir", "--target", "uav1"]
SIZE_REFUSED = "--window-size must be WxH in pixels (200 to 16384 each), got '5x5'"
ALIAS_CASES = {
    ("snrmon calibrate", "--camera"): (
        ["calibrate", "--camera", "nosuch", "--blackbody", "a.npy:15", "-o", "c.npz"],
        "nosuch",
    ),
    ("snrmon calibrate", "--output"): (
        ["calibrate", "--sensor", "mwir", "--blackbody", "a.npy:15", "--output", "c.txt"],
        "-o/--out must name a .npz file, got 'c.txt'",
    ),
    ("snrmon campaign", "--frames"): (
        ["campaign", "missing.h5", "--out", "o", "--frames", "--workers", "-1"],
        "--workers must be 0 or more",
    ),
    ("snrmon characterize", "--frames"): (
        ["characterize", "s.h5", "--camera", "mwir", "--stop", "1", "--frames", "0"],
        "--n-frames must be >= 1, got 0",
    ),
    ("snrmon demo", "--size"): (["demo", "--size", "5x5", "--headless"], SIZE_REFUSED),
    ("snrmon geo pixel", "--camera"): (
        ["geo", "pixel", *GEO, "--target-at", "0,0,0", "--camera", "1,2"],
        "--intrinsics must be F_M,PITCH_UM,W,H",
    ),
    ("snrmon geo pixel", "--target"): (
        ["geo", "pixel", *GEO, "--sensor", "mwir", "--target", "x"],
        "--target-at",
    ),
    ("snrmon geo calibrate", "--camera"): (
        ["geo", "calibrate", "--site", "0,0,0", "--pairs", "p.csv", "--camera", "1,2"],
        "--intrinsics must be F_M,PITCH_UM,W,H",
    ),
    ("snrmon gui", "--size"): (["gui", "--size", "5x5"], SIZE_REFUSED),
    ("snrmon hil", "--camera"): (["hil", "--camera", "swir"], "--cameras must name mwir"),
    ("snrmon hil", "--window"): (
        ["hil", "--window", "100x100", "--cameras", "swir"],
        "--cameras must name mwir",
    ),
    ("snrmon measure", "--window"): (
        ["measure", "s.npy", "--at", "4,4", "--window", "5", "--box", "17"],
        "--box 17 is larger than the 9x9 frames",
    ),
    ("snrmon model snr", "--background-temp-c"): (
        ["model", "snr", "--sensor", "mwir", "--target", "uav1", "--background-temp-c", "-300"],
        "--sky-temp-c must be above -273.15",
    ),
    ("snrmon model netd", "--background-temp-c"): (
        ["model", "netd", "--sensor", "mwir", "--background-temp-c", "-300"],
        "--sky-temp-c must be above -273.15",
    ),
    ("snrmon model plot", "--background-temp-c"): (
        [*PLOT, "-o", "p.png", "--background-temp-c", "-300"],
        "--sky-temp-c must be above -273.15",
    ),
    ("snrmon model plot", "--output"): (
        [*PLOT, "--output", "p.txt"],
        "-o/--out p.txt: must end in .png",
    ),
    ("snrmon record", "--roi"): (
        ["record", "--config", "c.toml", "--out", "s.h5", "--roi", "mwir"],
        "--click must be CAMERA:X,Y, got 'mwir'",
    ),
    ("snrmon replay", "--track"): (["replay", "r.npy", "--track", "off"], "r.npy does not exist"),
    ("snrmon report", "--output"): (["report", "s.h5", "--output", "r.txt"], "-o/--out r.txt"),
}


@pytest.mark.parametrize("key", sorted(DEPRECATED), ids=lambda k: f"{k[0][7:]} {k[1]}")
def test_a_deprecated_spelling_still_works_and_warns_on_one_line(
    key, tmp_path, monkeypatch, capsys
):
    prog, old = key
    new = DEPRECATED[key]
    argv, says = ALIAS_CASES[key]
    monkeypatch.chdir(tmp_path)
    np.save(tmp_path / "s.npy", np.full((2, 9, 9), 100.0, np.float32))
    if prog in ("snrmon gui", "snrmon demo"):
        pytest.importorskip("PySide6")  # the console's extra, checked before the options
    assert main(argv) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[0] == f"{prog}: warning: {old} is deprecated, use {new}"
    assert len(err) == 2 and err[1].startswith(f"{prog}: error: ")
    assert says in err[1]


def test_the_new_spellings_do_not_warn(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["hil", "--size", "100x100", "--cameras", "swir"]) == 2
    err = capsys.readouterr().err
    assert "deprecated" not in err and "--cameras must name mwir" in err


def test_a_required_option_given_by_its_old_spelling_is_given(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["report", "s.h5", "--output", "r.pdf"]) == 2
    err = capsys.readouterr().err
    assert "required" not in err and "session file s.h5 does not exist" in err
    with pytest.raises(SystemExit) as refused:  # and without either, still required
        main(["report", "s.h5"])
    assert refused.value.code == 2
    assert re.search(r"required: -o/--out", capsys.readouterr().err)
