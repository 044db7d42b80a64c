"""What the console remembers between starts (QSettings): window geometry and dock layout, the
SNR-versus-range tab, whether the box insets are shown, the theme and font scale, and the
applied model options (target, curves shown, background K; not the met readings nor the
noise choice: those are the session's). The first start (nothing saved) fills the screen the
window opens on.

Values are stored as plain strings or byte arrays so that the INI and native formats read back
the same. A damaged entry is reported by name through the window's ``report`` and the default
stays; nothing here computes a number.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from PySide6.QtCore import QByteArray, QSettings, Qt
from PySide6.QtGui import QGuiApplication

from snrmon.gui.model_curves import ModelOptions, parse_background_temp
from snrmon.gui.theme import check_font_scale, theme_named

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


def save_view(settings: QSettings, theme: str, font_scale: float) -> None:
    settings.setValue("view/theme", theme)
    settings.setValue("view/font_scale", repr(float(font_scale)))


def restore_window(win: ConsoleWindow) -> bool:
    """Geometry, docks, tab, theme, font scale and model options as they were saved (defaults
    where not); True at a first start (no saved layout: the window fills the available screen
    and its docks are still to be fitted to it)."""
    s = win.settings
    first = True
    geometry = s.value("window/geometry")
    if isinstance(geometry, QByteArray) and not geometry.isEmpty():
        win.restoreGeometry(geometry)
    else:
        fill_screen(win)
    state = s.value("window/state")
    if isinstance(state, QByteArray) and not state.isEmpty():
        first = not win.restoreState(state)
    insets = s.value("view/insets")
    if insets is not None:
        win.set_insets(str(insets) == "true")
    tab = s.value("view/range_tab", 0, type=int)
    win.range_tabs.setCurrentIndex(min(int(tab), win.range_tabs.count() - 1))
    theme = str(s.value("view/theme", win.theme_name))
    try:
        scale = float(str(s.value("view/font_scale", "1.0")))
        theme_named(theme)
        check_font_scale(scale)
    except ValueError as exc:
        win.report(f"saved theme or font scale ignored: {exc}")
    else:
        win.theme_name, win.font_scale = theme, scale
    if win.model is None:
        return first
    try:
        options = saved_model_options(s)
    except ValueError as exc:
        win.report(f"saved model options ignored: {exc}")
        return first
    if options is not None:
        # the day's met readings are the session's, never a former day's; the measured noise
        # is this session's cameras' (not remembered either)
        options = dataclasses.replace(
            options, weather=win.model.options.weather, noise=win.model.options.noise
        )
    if options is not None and options != win.model.options:
        win.apply_model_options(options)
    return first


def fill_screen(win: ConsoleWindow) -> None:
    """The window over the whole available area of its screen (maximised where a window
    manager honours it; the geometry itself where none does, e.g. a bare X server)."""
    screen = win.screen() or QGuiApplication.primaryScreen()
    if screen is None:
        return
    win.setGeometry(screen.availableGeometry())
    win.setWindowState(win.windowState() | Qt.WindowState.WindowMaximized)


def save_window(win: ConsoleWindow) -> None:
    """Geometry, docks, tab and insets (the model options, theme and font scale are saved when
    they are chosen)."""
    s = win.settings
    s.setValue("window/geometry", win.saveGeometry())
    s.setValue("window/state", win.saveState())
    s.setValue("view/range_tab", win.range_tabs.currentIndex())
    s.setValue("view/insets", "true" if win.insets_shown else "false")
    s.sync()
