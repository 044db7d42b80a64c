"""Functions by lines of code: each function's lines, less blank lines, comment-only lines and
docstrings (its own and those of the functions and classes inside it).

    python tools/function_lengths.py [--over N] FOLDER_OR_FILE ...

prints ``LINES  path:line  qualified.name`` for every function longer than N lines of code
(default 80), longest first. A nested function counts in its own right and inside its parent.
"""

from __future__ import annotations

import argparse
import ast
import io
import tokenize
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class FunctionLength:
    path: Path
    line: int
    name: str
    lines_of_code: int


def code_lines(source: str) -> set[int]:
    """The line numbers holding a token other than a comment or a line break (a string token
    spanning lines holds each of them)."""
    skip = {tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT}
    lines: set[int] = set()
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type not in skip and tok.type != tokenize.ENDMARKER:
            lines.update(range(tok.start[0], tok.end[0] + 1))
    return lines


def docstring_lines(tree: ast.AST) -> set[int]:
    """The line numbers of every module, class and function docstring in ``tree``."""
    lines: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            first = body[0] if body else None
            if (
                isinstance(first, ast.Expr)
                and isinstance(first.value, ast.Constant)
                and isinstance(first.value.value, str)
            ):
                lines.update(range(first.lineno, (first.end_lineno or first.lineno) + 1))
    return lines


def function_lengths(path: Path) -> Iterator[FunctionLength]:
    """Every function (and method) in the file at ``path`` with its lines of code."""
    source = path.read_text(encoding="utf-8")
    tree = ast.parse(source, str(path))
    counted = code_lines(source) - docstring_lines(tree)

    def visit(node: ast.AST, prefix: str) -> Iterator[FunctionLength]:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                name = f"{prefix}{child.name}"
                span = range(child.lineno, (child.end_lineno or child.lineno) + 1)
                yield FunctionLength(path, child.lineno, name, len(counted.intersection(span)))
                yield from visit(child, f"{name}.")
            elif isinstance(child, ast.ClassDef):
                yield from visit(child, f"{prefix}{child.name}.")
            else:
                yield from visit(child, prefix)

    yield from visit(tree, "")


def long_functions(roots: list[Path], over: int) -> list[FunctionLength]:
    """The functions under ``roots`` (folders or files) longer than ``over`` lines of code,
    longest first."""
    files = sorted(f for root in roots for f in ([root] if root.is_file() else root.rglob("*.py")))
    found = [fn for f in files for fn in function_lengths(f) if fn.lines_of_code > over]
    return sorted(found, key=lambda fn: (-fn.lines_of_code, str(fn.path), fn.line))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("roots", nargs="+", type=Path)
    parser.add_argument("--over", type=int, default=80, help="lines of code allowed (default 80)")
    args = parser.parse_args()
    for fn in long_functions(args.roots, args.over):
        print(f"{fn.lines_of_code:5d}  {fn.path}:{fn.line}  {fn.name}")


if __name__ == "__main__":
    main()
