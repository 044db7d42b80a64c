"""Print the constraints file: the exact version of every installed distribution that snrmon
and its extras need (the requirement closure of ``snrmon[EXTRAS]`` in this environment), as
``make constraints`` writes it to constraints.txt after a green ``make test``.

A plain ``pip freeze`` would also pin whatever else lies in the venv; this keeps only what the
package asks for, directly or through its dependencies.
"""

from __future__ import annotations

import sys
from importlib import metadata

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

EXTRAS = ("dev", "mavlink", "compress", "aravis", "tiff")


def closure(root: str, extras: tuple[str, ...]) -> dict[str, str]:
    """{canonical name: installed version} of ``root`` and everything it requires."""
    found: dict[str, str] = {}
    todo = [(root, set(extras))]
    while todo:
        name, wanted = todo.pop()
        try:
            dist = metadata.distribution(name)
        except metadata.PackageNotFoundError:
            continue  # an optional extra that is not installed here (e.g. PyGObject)
        key = canonicalize_name(dist.metadata["Name"])
        if key in found and not wanted:
            continue
        found[key] = dist.version
        for text in dist.requires or []:
            req = Requirement(text)
            envs = [{"extra": e} for e in wanted] or [{"extra": ""}]
            if req.marker is None or any(req.marker.evaluate(env) for env in envs):
                todo.append((req.name, set(req.extras)))
    return found


def main() -> int:
    pins = closure("snrmon", EXTRAS)
    pins.pop("snrmon", None)
    print(
        "# The exact versions `make test` passed with (Python "
        f"{sys.version_info.major}.{sys.version_info.minor}, Linux x86-64)."
    )
    print("# Regenerate with `make constraints` after a green `make test`; pyproject.toml keeps")
    print("# the ranges, this file the tested point (pip install -c constraints.txt ...).")
    for name in sorted(pins):
        print(f"{name}=={pins[name]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
