"""Every operator action's key is in the Help list and in docs/console.md's key table (the one
table, gui/actions.py ACTIONS, is their source)."""

from __future__ import annotations

import re
from pathlib import Path

from PySide6.QtGui import QKeySequence

from snrmon.gui.actions import ACTIONS, shortcuts_text

DOC = Path(__file__).resolve().parents[2] / "docs" / "console.md"


def test_every_key_is_listed_in_help_and_in_the_docs():
    keys = DOC.read_text().split("## Keys", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in keys.splitlines() if line.startswith("| ")]
    shown = set(re.split(r"[\s/]+", " ".join(row.split("|")[1] for row in rows)))
    help_text = shortcuts_text()
    for spec in ACTIONS:
        assert not QKeySequence(spec.shortcut).isEmpty(), spec.shortcut
        assert spec.shortcut in shown, spec.shortcut
        assert spec.shortcut in help_text and spec.text.replace("&", "") in help_text
    # the operator's frequent acts each have a key
    wanted = {"record_start", "record_stop", "event", "reselect", "release", "switch_camera"}
    wanted |= {"enlarge_range", "daylight", "font_larger", "font_smaller", "copy_stops"}
    assert wanted <= {spec.key for spec in ACTIONS}
    assert len({spec.shortcut for spec in ACTIONS}) == len(ACTIONS)  # no key does two things
