"""The house's limits, gated so that they cannot regress:

- no function longer than one idea: at most MAX_LINES lines of code (blank, comment-only and
  docstring lines not counted, by tools/function_lengths.py) in any product package;
- no class in acquisition/ with more than MAX_ATTRIBUTES attributes (declared fields and
  ``self.NAME`` assignments, by tools/class_attributes.py).
"""

from __future__ import annotations

import re
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PRODUCT = ("acquisition", "benchmarks", "gui", "model", "drivers", "sim", "snrmon")
"""The product's packages (setup.py's package-dir mapping of the snrmon namespace)."""
MAX_LINES = 80
MAX_ATTRIBUTES = 15
ATTRIBUTES_GATED = ("acquisition",)


def _tool(name: str):
    sys.path.insert(0, str(ROOT / "tools"))
    try:
        return __import__(name)
    finally:
        sys.path.remove(str(ROOT / "tools"))


@pytest.fixture(scope="module")
def lengths():
    return _tool("function_lengths")


@pytest.fixture(scope="module")
def attributes():
    return _tool("class_attributes")


def test_the_product_packages_are_all_gated():
    """Every package folder setup.py maps into the snrmon namespace is in PRODUCT."""
    mapped = set(re.findall(r'"snrmon\.\w+": "(\w+)"', (ROOT / "setup.py").read_text()))
    assert len(mapped) >= 6 and mapped <= set(PRODUCT), mapped


def test_no_function_in_the_product_is_over_the_limit(lengths):
    offenders = lengths.long_functions([ROOT / package for package in PRODUCT], MAX_LINES)
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


def test_no_class_in_acquisition_is_over_the_attribute_limit(attributes, capsys):
    roots = [str(ROOT / package) for package in ATTRIBUTES_GATED]
    code = attributes.main(["--over", str(MAX_ATTRIBUTES), *roots])
    assert code == 0, f"classes over {MAX_ATTRIBUTES} attributes:\n{capsys.readouterr().out}"


def test_attributes_count_declared_fields_and_self_assignments_not_class_vars(attributes, tmp_path):
    source = tmp_path / "sample.py"
    source.write_text(
        textwrap.dedent(
            """\
            from typing import ClassVar

            class Row:
                a: int
                b: str = ""
                K: ClassVar[int] = 1
                LIMIT = 3

                def __init__(self):
                    self.c = 1
                    self.a = 2

                @property
                def d(self):
                    return self.c

                class Inner:
                    x: int
            """
        )
    )
    found = {c.name: set(c.attributes) for c in attributes.class_attributes(source)}
    assert found == {"Row": {"a", "b", "c"}, "Inner": {"x"}}
    assert attributes.main(["--over", "2", str(source)]) == 1  # Row has 3
    assert attributes.main(["--over", "3", str(source)]) == 0
