"""Write docs/api.md from the public API's docstrings (numpydoc sections), or check it.

``python .ci/api_doc.py`` prints the page; ``--check docs/api.md`` exits 1 when the file differs
from what the docstrings give (``make test`` runs it, so the page follows the code).
"""

from __future__ import annotations

import inspect
import re
import sys
from pathlib import Path

import snrmon
from snrmon import api

HEADER = """# The snrmon Python API

Generated from the docstrings of `snrmon.api` by `.ci/api_doc.py` (do not edit by hand; `make
test` checks the page is current). Every example below runs as a test (doctest).

```python
import snrmon

snrmon.__all__  # {names}
```

`pip install snrmon` is enough for all of it: no Qt, no Dask. The camera files `load_stack`,
`measure_stack` and `track_stack` read, and what they read of each:
[camera-files.md](camera-files.md).
"""


def _markdown(doc: str) -> str:
    """A numpydoc docstring as Markdown: sections as bold headings, examples as code."""
    lines = inspect.cleandoc(doc).splitlines()
    out: list[str] = []
    i = 0
    in_code = False
    listing = False  # in a Parameters / Returns / Raises / Attributes section
    while i < len(lines):
        line = lines[i]
        nxt = lines[i + 1] if i + 1 < len(lines) else ""
        if line.strip() and set(nxt.strip()) == {"-"} and len(nxt.strip()) >= 3:
            if in_code:
                out.append("```")
                in_code = False
            out.append(f"**{line.strip()}**")
            out.append("")
            listing = line.strip() in ("Parameters", "Returns", "Raises", "Attributes")
            if line.strip() == "Examples":
                out.append("```python")
                in_code = True
            i += 2
            continue
        if listing and line.strip():
            # an entry ("name : type") starts a list item, its indented lines continue it
            out.append(f"  {line.strip()}" if line.startswith(" ") else f"- `{line.strip()}`")
        else:
            out.append(line)
        i += 1
    if in_code:
        while out and not out[-1].strip():
            out.pop()
        out.append("```")
    return "\n".join(out)


def _plain(sig: inspect.Signature) -> str:
    """A signature as written in the source (its annotations are strings there)."""
    params = [p.replace(annotation=inspect.Parameter.empty) for p in sig.parameters.values()]
    text = str(sig.replace(parameters=params, return_annotation=inspect.Signature.empty))
    for p in sig.parameters.values():  # put each annotation back, unquoted, after its name
        if p.annotation is not inspect.Parameter.empty:
            stars = "**" if p.kind is p.VAR_KEYWORD else "*" if p.kind is p.VAR_POSITIONAL else ""
            text = re.sub(
                rf"(?<![\w.])({re.escape(stars + p.name)})(?=[=,)])",
                rf"\1: {p.annotation}",
                text,
                count=1,
            )
    if sig.return_annotation is not inspect.Signature.empty:
        text += f" -> {sig.return_annotation}"
    return text.replace(": =", ": ").replace("=", " = ")


def page() -> str:
    parts = [HEADER.format(names=", ".join(snrmon.__all__))]
    for name in snrmon.__all__:
        obj = getattr(api, name)
        if inspect.isclass(obj):
            parts.append(f"## `snrmon.{name}`\n\n{_markdown(obj.__doc__ or '')}\n")
            for meth_name, meth in inspect.getmembers(obj, inspect.isfunction):
                if meth_name.startswith("_") or not meth.__doc__:
                    continue
                sig = inspect.signature(meth)
                parts.append(
                    f"### `{name}.{meth_name}{_plain(sig)}`\n\n{_markdown(meth.__doc__)}\n"
                )
        else:
            sig = inspect.signature(obj)
            parts.append(f"## `snrmon.{name}{_plain(sig)}`\n\n{_markdown(obj.__doc__ or '')}\n")
    return "\n".join(parts).rstrip() + "\n"


def main(argv: list[str]) -> int:
    text = page()
    if argv[:1] == ["--check"]:
        current = Path(argv[1]).read_text(encoding="utf-8")
        if current != text:
            print(
                f"{argv[1]} is not what the docstrings give: python .ci/api_doc.py > {argv[1]}",
                file=sys.stderr,
            )
            return 1
        return 0
    sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
