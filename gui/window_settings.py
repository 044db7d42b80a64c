"""What the console remembers between starts (QSettings): window geometry and dock layout, the
SNR-versus-range tab, and the applied model options (target, curves shown, background K).

Values are stored as plain strings or byte arrays so that the INI and native formats read back
the same. A damaged entry is reported by name through the window's ``report`` and the default
stays; nothing here computes a number.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from PySide6.QtCore import QByteArray, QSettings

from snrmon.gui.model_curves import ModelOptions, parse_background_temp

if TYPE_CHECKING:
    from snrmon.gui.main_window import ConsoleWindow


def save_model_options(settings: QSettings, options: ModelOptions) -> None:
    """Remember the applied choices for the next start (plain strings: INI-safe)."""
    settings.setValue("model/target", options.target)
    settings.setValue("model/shown", ",".join(options.shown))
    bg = options.background_temp_k
    settings.setValue("model/background_temp_k", "" if bg is None else repr(bg))


def saved_model_options(settings: QSettings) -> ModelOptions | None:
    """The choices remembered by :func:`save_model_options`; None when there are none.
    A damaged entry is a ValueError naming it (the window reports it and keeps the default)."""
    target = settings.value("model/target", None)
    if target is None:
        return None
    shown = str(settings.value("model/shown", ""))
    return ModelOptions(
        target=str(target),
        shown=tuple(n for n in shown.split(",") if n),
        background_temp_k=parse_background_temp(str(settings.value("model/background_temp_k", ""))),
    )


def restore_window(win: ConsoleWindow) -> None:
    """Geometry, docks, tab and model options as they were saved (defaults where not)."""
    s = win.settings
    geometry = s.value("window/geometry")
    if isinstance(geometry, QByteArray) and not geometry.isEmpty():
        win.restoreGeometry(geometry)
    else:
        win.resize(1600, 1000)
    state = s.value("window/state")
    if isinstance(state, QByteArray) and not state.isEmpty():
        win.restoreState(state)
    tab = s.value("view/range_tab", 0, type=int)
    win.range_tabs.setCurrentIndex(min(int(tab), win.range_tabs.count() - 1))
    if win.model is None:
        return
    try:
        options = saved_model_options(s)
    except ValueError as exc:
        win.report(f"saved model options ignored: {exc}")
        return
    if options is not None:
        # the day's met readings are the session's, never a former day's
        options = dataclasses.replace(options, weather=win.model.options.weather)
    if options is not None and options != win.model.options:
        win.apply_model_options(options)


def save_window(win: ConsoleWindow) -> None:
    """Geometry, docks and tab (the model options are saved when they are applied)."""
    s = win.settings
    s.setValue("window/geometry", win.saveGeometry())
    s.setValue("window/state", win.saveState())
    s.setValue("view/range_tab", win.range_tabs.currentIndex())
    s.sync()
