"""Can the console's window open on this display? Qt's xcb platform plugin, probed for real.

Qt 6.5+ needs system libraries that a minimal desktop install lacks (``libxcb-cursor0`` first of
all); without them Qt aborts with "no Qt platform plugin could be initialized". The probe
starts a child Python that creates a ``QGuiApplication`` on the ``xcb`` platform (the child may
abort; this process never does), and ``ldd`` on the plugin names every library the loader cannot
find. :data:`PACKAGES` turns library names into the Debian/Ubuntu packages that provide them.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path

from snrmon.doctor import FAIL, PASS, SKIP, Check

# Library soname -> Debian/Ubuntu package (the xcb plugin's dependencies and theirs).
PACKAGES = {
    "libxcb-cursor.so.0": "libxcb-cursor0",
    "libxcb-icccm.so.4": "libxcb-icccm4",
    "libxcb-keysyms.so.1": "libxcb-keysyms1",
    "libxcb-image.so.0": "libxcb-image0",
    "libxcb-render-util.so.0": "libxcb-render-util0",
    "libxcb-xkb.so.1": "libxcb-xkb1",
    "libxkbcommon-x11.so.0": "libxkbcommon-x11-0",
    "libxkbcommon.so.0": "libxkbcommon0",
    "libxcb-shape.so.0": "libxcb-shape0",
    "libxcb-randr.so.0": "libxcb-randr0",
    "libxcb-xfixes.so.0": "libxcb-xfixes0",
    "libxcb-sync.so.1": "libxcb-sync1",
    "libxcb-shm.so.0": "libxcb-shm0",
    "libxcb-render.so.0": "libxcb-render0",
    "libxcb-xinerama.so.0": "libxcb-xinerama0",
    "libxcb-xinput.so.0": "libxcb-xinput0",
    "libxcb-util.so.1": "libxcb-util1",
    "libxcb.so.1": "libxcb1",
    "libX11-xcb.so.1": "libx11-xcb1",
    "libX11.so.6": "libx11-6",
    "libSM.so.6": "libsm6",
    "libICE.so.6": "libice6",
    "libEGL.so.1": "libegl1",
    "libGL.so.1": "libgl1",
    "libOpenGL.so.0": "libopengl0",
    "libGLX.so.0": "libglx0",
    "libfontconfig.so.1": "libfontconfig1",
    "libfreetype.so.6": "libfreetype6",
    "libdbus-1.so.3": "libdbus-1-3",
    "libglib-2.0.so.0": "libglib2.0-0",
}
DESKTOP_PACKAGES = (
    "libxcb-cursor0 libxcb-icccm4 libxcb-keysyms1 libxcb-image0 libxcb-render-util0 "
    "libxcb-xkb1 libxkbcommon-x11-0 libxcb-shape0 libxcb-randr0 libxcb-xinerama0 libegl1"
)
"""What README's set-up section lists for a desktop (Qt's documented xcb requirements)."""

PROBE = """
import sys
from PySide6.QtGui import QGuiApplication
app = QGuiApplication([sys.argv[0], "-platform", "xcb"])
size = app.primaryScreen().size()
print("SCREEN", size.width(), size.height(), flush=True)
"""
_LIB = re.compile(r"(lib[A-Za-z0-9_.+-]*?\.so(?:\.\d+)*)")


def xcb_plugin() -> Path:
    """PySide6's xcb platform plugin (``libqxcb.so``)."""
    from PySide6.QtCore import QLibraryInfo

    plugins = Path(QLibraryInfo.path(QLibraryInfo.LibraryPath.PluginsPath))
    return plugins / "platforms" / "libqxcb.so"


def unloadable_libraries(plugin: Path, env: Mapping[str, str] | None = None) -> list[str]:
    """Sonames ``ldd`` cannot resolve or load for ``plugin`` ("not found", or a file the
    loader refuses), in the order ldd gives them."""
    try:
        out = subprocess.run(
            ["ldd", str(plugin)], capture_output=True, text=True, env=env, timeout=30, check=False
        )
    except (OSError, subprocess.TimeoutExpired):
        return []
    found = []
    for line in (out.stdout + "\n" + out.stderr).splitlines():
        if "not found" in line or "error while loading shared libraries" in line:
            found += [Path(m).name for m in _LIB.findall(line.split("=>")[0].split(": ", 1)[-1])]
    return list(dict.fromkeys(lib for lib in found if lib != plugin.name))


def libraries_in_message(text: str) -> list[str]:
    """Sonames in Qt's plugin-loader messages (``QT_DEBUG_PLUGINS=1``): "Cannot load library
    .../libqxcb.so: (libxcb-cursor.so.0: cannot open shared object file ...)". Qt's hint "From
    6.5.0, xcb-cursor0 or libxcb-cursor0 is needed" is printed for any failure of the plugin,
    a display that does not answer included, so it is not taken as evidence."""
    names = []
    for line in text.splitlines():
        if "Cannot load library" in line:
            reason = line.rsplit("libqxcb.so", 1)[-1]
            names += [Path(m).name for m in _LIB.findall(reason)]
    return list(dict.fromkeys(names))


def packages_for(libraries: list[str]) -> list[str]:
    """Debian packages for sonames (a name that is already a package is kept)."""
    out = []
    for lib in libraries:
        pkg = PACKAGES.get(lib)
        if pkg is None and ".so" not in lib:
            pkg = lib
        out.append(pkg or f"(the package providing {lib}: apt-file search {lib})")
    return list(dict.fromkeys(out))


def _install_fix(libraries: list[str]) -> str:
    if not libraries:
        return f"sudo apt-get install {DESKTOP_PACKAGES}   (what Qt's xcb platform needs)"
    return (
        f"sudo apt-get install {' '.join(packages_for(libraries))}   (Qt's xcb platform needs "
        f"them; a desktop needs all of: {DESKTOP_PACKAGES})"
    )


def check_qt_display(
    env: Mapping[str, str] | None = None, *, needed: bool = True, timeout_s: float = 60.0
) -> Check:
    """Open Qt's xcb platform on ``env``'s display (default: this process's environment)."""
    env = dict(os.environ if env is None else env)
    name = "qt-display"
    plugin = xcb_plugin()
    if not plugin.is_file():
        return Check(
            name,
            FAIL,
            f"PySide6 has no xcb platform plugin at {plugin}",
            "reinstall PySide6-Essentials in the venv (make setup)",
            needed,
        )
    missing = unloadable_libraries(plugin, env)
    display = env.get("DISPLAY", "")
    if not display:
        return _without_display(name, missing)
    env["QT_QPA_PLATFORM"] = "xcb"
    env["QT_DEBUG_PLUGINS"] = "1"  # the loader's own reason when the plugin does not load
    try:
        proc = subprocess.run(
            [sys.executable, "-c", PROBE],
            capture_output=True,
            text=True,
            env=env,
            timeout=timeout_s,
            check=False,
        )
    except subprocess.TimeoutExpired:
        return Check(
            name,
            FAIL,
            f"Qt did not open display {display} within {timeout_s:g} s",
            "check the X server (xdpyinfo) and XAUTHORITY",
            needed,
        )
    return _probe_verdict(name, proc, display, missing, needed)


def _without_display(name: str, missing: list[str]) -> Check:
    """No display to open: a skip, or a failure when the plugin's libraries are missing too
    (a display added later would not help)."""
    detail = "no X display here (DISPLAY unset): the console can run only --headless"
    if missing:
        return Check(
            name,
            FAIL,
            f"{detail}; and Qt's xcb platform could not load {', '.join(missing)}",
            _install_fix(missing),
            needed=False,
            data={"missing": missing},
        )
    return Check(name, SKIP, detail, needed=False, data={"missing": []})


def _probe_verdict(
    name: str,
    proc: subprocess.CompletedProcess,
    display: str,
    missing: list[str],
    needed: bool,
) -> Check:
    """What the probe's run says: the screen it opened, or why it could not (the libraries it
    could not load, the display that refused it, else its last line)."""
    screen = re.search(r"SCREEN (\d+) (\d+)", proc.stdout)
    if proc.returncode == 0 and screen:
        w, h = int(screen[1]), int(screen[2])
        return Check(
            name,
            PASS,
            f"Qt's xcb platform opens on {display} ({w}x{h})",
            needed=needed,
            data={"display": display, "width": w, "height": h, "missing": []},
        )
    libs = list(dict.fromkeys(missing + libraries_in_message(proc.stderr)))
    if not libs and "could not connect to display" in proc.stderr:
        return Check(
            name,
            FAIL,
            f"cannot connect to X display {display}",
            "is the X server running, and may this user use it (XAUTHORITY, xhost)?",
            needed,
            data={"display": display, "missing": []},
        )
    if libs:
        return Check(
            name,
            FAIL,
            f"Qt's xcb platform cannot load on {display}: missing or unloadable {', '.join(libs)}",
            _install_fix(libs),
            needed,
            data={"display": display, "missing": libs},
        )
    last = next((ln for ln in reversed(proc.stderr.splitlines()) if ln.strip()), "no message")
    return Check(
        name,
        FAIL,
        f"Qt's xcb platform failed on {display}: {last}",
        f"QT_DEBUG_PLUGINS=1 snrmon gui ... shows why; else {_install_fix([])}",
        needed,
        data={"display": display, "missing": []},
    )
