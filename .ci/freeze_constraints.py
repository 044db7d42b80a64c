"""Print the constraints file, or check it: the exact version of every installed distribution
that snrmon and its extras need (the requirement closure of ``snrmon[EXTRAS]`` in this
environment), as ``make constraints`` writes it to constraints.txt after a green ``make test``.

A plain ``pip freeze`` would also pin whatever else lies in the venv; this keeps only what the
package asks for, directly or through its dependencies (extras of dependencies included, e.g.
``dask[distributed]``).

``--check FILE`` exits 1, naming each difference, when FILE does not pin exactly what this
environment holds: ``make test`` runs it, so CI fails when a dependency was added without
being pinned.
"""

from __future__ import annotations

import sys
from importlib import metadata
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

EXTRAS = (
    "gui",
    "campaign",
    "dev",
    "mavlink",
    "compress",
    "flightlogs",
    "aravis",
    "tiff",
    "tables",
    "flir",
)
# Installed by the Makefile without their requirements (test-only independent readers whose
# own requirements conflict with the pins here): pinned when installed, their needs not followed.
TEST_ONLY = ("flirpy",)


def closure(root: str, extras: tuple[str, ...]) -> dict[str, str]:
    """{canonical name: installed version} of ``root`` (with ``extras``) and everything it
    requires, each dependency with the extras it is asked for."""
    found: dict[str, str] = {}
    seen: set[tuple[str, str]] = set()
    todo: list[tuple[str, str]] = [(canonicalize_name(root), "")]
    todo += [(canonicalize_name(root), e) for e in extras]
    while todo:
        name, extra = todo.pop()
        if (name, extra) in seen:
            continue
        seen.add((name, extra))
        try:
            dist = metadata.distribution(name)
        except metadata.PackageNotFoundError:
            continue  # an optional extra that is not installed here (e.g. PyGObject)
        found[canonicalize_name(dist.metadata["Name"])] = dist.version
        for text in dist.requires or []:
            req = Requirement(text)
            if req.marker is not None and not req.marker.evaluate({"extra": extra}):
                continue
            dep = canonicalize_name(req.name)
            todo.append((dep, ""))
            todo += [(dep, e) for e in req.extras]
    return found


def pins() -> dict[str, str]:
    found = closure("snrmon", EXTRAS)
    found.pop("snrmon", None)
    for name in TEST_ONLY:
        try:
            found[canonicalize_name(name)] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return found


def read_pins(path: str) -> dict[str, str]:
    out = {}
    for line in Path(path).read_text(encoding="utf-8").splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            name, _, version = line.partition("==")
            out[canonicalize_name(name)] = version
    return out


def main(argv: list[str]) -> int:
    now = pins()
    if argv[:1] == ["--check"]:
        pinned = read_pins(argv[1])
        problems = [
            f"{name}: installed {now[name]}, pinned {pinned.get(name, 'not')}"
            for name in sorted(now)
            if now[name] != pinned.get(name)
        ]
        for p in problems:
            print(f"constraints: {p} (run `make constraints`)", file=sys.stderr)
        return 1 if problems else 0
    print(
        "# The exact versions `make test` passed with (Python "
        f"{sys.version_info.major}.{sys.version_info.minor}, Linux x86-64)."
    )
    print("# Regenerate with `make constraints` after a green `make test`; pyproject.toml keeps")
    print("# the ranges, this file the tested point (pip install -c constraints.txt ...).")
    for name in sorted(now):
        print(f"{name}=={now[name]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
