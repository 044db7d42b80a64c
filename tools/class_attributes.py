"""Classes by attributes: each class's data attributes, the fields it declares in its body
(annotated names, ``ClassVar`` excluded) and every ``self.NAME`` its own methods assign.

    python tools/class_attributes.py [--over N] FOLDER_OR_FILE ...

prints ``ATTRIBUTES  path:line  ClassName`` for every class with more than N attributes
(default 15), most first. Properties, methods and plain class constants are not attributes; a
nested class counts for itself only. Exit 1 when any class is listed, so that it can gate.
"""

from __future__ import annotations

import argparse
import ast
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class ClassAttributes:
    path: Path
    line: int
    name: str
    attributes: frozenset[str]


def _is_class_var(annotation: ast.expr) -> bool:
    node = annotation.value if isinstance(annotation, ast.Subscript) else annotation
    return (isinstance(node, ast.Name) and node.id == "ClassVar") or (
        isinstance(node, ast.Attribute) and node.attr == "ClassVar"
    )


def _own_nodes(node: ast.AST) -> Iterator[ast.AST]:
    """The nodes under ``node`` that are not inside a nested class."""
    for child in ast.iter_child_nodes(node):
        if isinstance(child, ast.ClassDef):
            continue
        yield child
        yield from _own_nodes(child)


def _self_targets(node: ast.AST) -> Iterator[str]:
    if isinstance(node, ast.Assign):
        targets = node.targets
    elif isinstance(node, ast.AnnAssign | ast.AugAssign):
        targets = [node.target]
    else:
        return
    for target in targets:
        for part in ast.walk(target):
            if (
                isinstance(part, ast.Attribute)
                and isinstance(part.value, ast.Name)
                and part.value.id == "self"
            ):
                yield part.attr


def class_attributes(path: Path) -> Iterator[ClassAttributes]:
    tree = ast.parse(path.read_text(), filename=str(path))
    for cls in ast.walk(tree):
        if not isinstance(cls, ast.ClassDef):
            continue
        names = {
            stmt.target.id
            for stmt in cls.body
            if isinstance(stmt, ast.AnnAssign)
            and isinstance(stmt.target, ast.Name)
            and not _is_class_var(stmt.annotation)
        }
        for node in _own_nodes(cls):
            names.update(_self_targets(node))
        yield ClassAttributes(path, cls.lineno, cls.name, frozenset(names))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--over", type=int, default=15)
    parser.add_argument("roots", nargs="+", type=Path)
    args = parser.parse_args(argv)
    found = [
        c
        for root in args.roots
        for p in sorted(root.rglob("*.py") if root.is_dir() else [root])
        for c in class_attributes(p)
        if len(c.attributes) > args.over
    ]
    for c in sorted(found, key=lambda c: -len(c.attributes)):
        print(f"{len(c.attributes):5d}  {c.path}:{c.line}  {c.name}")
    return 1 if found else 0


if __name__ == "__main__":
    raise SystemExit(main())
