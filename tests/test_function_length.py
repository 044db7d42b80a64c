"""No function longer than one idea: at most MAX_LINES lines of code (blank, comment-only and
docstring lines not counted, by tools/function_lengths.py) in the layers and the folders of
snrmon below (the commands, the simulated rig, the doctor's checks)."""

from __future__ import annotations

import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("model", "drivers", "sim", "snrmon/commands", "snrmon/rig", "snrmon/doctor")
MAX_LINES = 80


@pytest.fixture(scope="module")
def lengths():
    sys.path.insert(0, str(ROOT / "tools"))
    try:
        import function_lengths
    finally:
        sys.path.remove(str(ROOT / "tools"))
    return function_lengths


def test_no_function_in_the_layers_is_over_the_limit(lengths):
    offenders = lengths.long_functions([ROOT / layer for layer in LAYERS], MAX_LINES)
    listing = "\n".join(
        f"  {fn.path.relative_to(ROOT)}:{fn.line} {fn.name}: {fn.lines_of_code} lines of code"
        for fn in offenders
    )
    assert not offenders, f"functions over {MAX_LINES} lines of code:\n{listing}"


def test_lines_of_code_leave_out_docstrings_comments_and_blank_lines(lengths, tmp_path):
    source = tmp_path / "sample.py"
    source.write_text(
        textwrap.dedent(
            '''\
            """Module docstring."""


            def outer(x):
                """A docstring
                over two lines."""
                # a comment

                y = (
                    x + 1
                )  # a trailing comment: the line counts

                def inner():
                    """Inner's docstring."""
                    return "a string
            over two lines"

                return y, inner


            class Box:
                """Class docstring."""

                def size(self):
                    return 1
            '''
        ).replace('"a string\nover two lines"', '"""a string\nover two lines"""')
    )
    found = {fn.name: fn.lines_of_code for fn in lengths.function_lengths(source)}
    # outer: def, y = (, x + 1, ), def inner, return (2 lines), return y -> 8; inner: 3
    assert found == {"outer": 8, "outer.inner": 3, "Box.size": 2}
    assert [fn.name for fn in lengths.long_functions([source], 2)] == ["outer", "outer.inner"]
