"""Whether two runs of a table of tests gave the same answers: each test's outcome and the
answer it recorded (``record_property("answer", ...)``), read from their junit XML files,
pytest's temporary folders left out of the comparison.

    python tools/same_answers.py IDLE.xml LOADED.xml

Prints the count of cases and of recorded answers and each case that differs; exit 1 when one
does or a case failed, 0 when every case passed with the same answer in both.
"""

from __future__ import annotations

import re
import sys
import xml.etree.ElementTree as ET

TMP = re.compile(r"/tmp/pytest-of-[^/]+/pytest-\d+/")


def answers(path: str) -> dict[str, tuple[bool, str | None]]:
    """{test id: (passed, its recorded answer or None)}."""
    out = {}
    for case in ET.parse(path).iter("testcase"):
        failed = case.find("failure") is not None or case.find("error") is not None
        props = {p.get("name"): p.get("value") for p in case.iter("property")}
        answer = props.get("answer")
        out[f"{case.get('classname')}::{case.get('name')}"] = (
            not failed,
            None if answer is None else TMP.sub("TMP/", answer),
        )
    return out


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__.split("\n\n")[1].strip(), file=sys.stderr)
        return 2
    first, second = answers(argv[0]), answers(argv[1])
    recorded = sum(answer is not None for _, answer in first.values())
    differ = sorted(k for k in first.keys() | second.keys() if first.get(k) != second.get(k))
    failed = sorted(k for k, (passed, _) in {**first, **second}.items() if not passed)
    print(
        f"{len(first)} and {len(second)} cases, {recorded} with a recorded answer: "
        f"{len(differ)} differ, {len(failed)} failed"
    )
    for k in differ:
        print(f"  differs: {k}: {first.get(k)} / {second.get(k)}")
    for k in failed:
        print(f"  failed: {k}")
    return 1 if differ or failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
