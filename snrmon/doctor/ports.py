"""Each configured serial port: does it exist, and may this user read and write it?

On Debian/Ubuntu a USB serial adapter is ``crw-rw---- root:dialout``: a user outside the
``dialout`` group cannot open it, and one added to the group only gets it at the next login. The
check says which of these it is, from the device node's owner, group and mode and the user's
identity (``uid``/``gids`` may be given, to ask for another user).
"""

from __future__ import annotations

import grp
import os
import pwd
import stat
from typing import TYPE_CHECKING

from snrmon.doctor import FAIL, PASS, SKIP, Check

if TYPE_CHECKING:
    from snrmon.drivers.config import DeviceSettings

SERIAL_PROTOCOLS = ("nmea", "trupulse", "ldm", "mavlink")


def port_path(settings: DeviceSettings) -> str | None:
    """The filesystem path of a device table's serial port; None for network links (pyserial
    URLs such as ``socket://``, gpsd's host:port, MAVLink's ``udpin:``)."""
    port = settings.port or ""
    if settings.protocol not in SERIAL_PROTOCOLS or "://" in port or not port:
        return None
    if settings.protocol == "mavlink" and not port.startswith("/"):
        return None  # udpin:..., tcp:...
    return port


def _group_name(gid: int) -> str:
    try:
        return grp.getgrgid(gid).gr_name
    except KeyError:
        return str(gid)


def _user_name(uid: int) -> str:
    try:
        return pwd.getpwuid(uid).pw_name
    except KeyError:
        return str(uid)


def may_read_write(st: os.stat_result, uid: int, gids: set[int]) -> bool:
    """Read and write permission from the mode bits, as the kernel decides (root may always)."""
    if uid == 0:
        return True
    if st.st_uid == uid:
        bits = stat.S_IRUSR | stat.S_IWUSR
    elif st.st_gid in gids:
        bits = stat.S_IRGRP | stat.S_IWGRP
    else:
        bits = stat.S_IROTH | stat.S_IWOTH
    return st.st_mode & bits == bits


def check_port(
    kind: str,
    settings: DeviceSettings,
    *,
    uid: int | None = None,
    gids: set[int] | None = None,
) -> Check:
    """The port of the ``[kind]`` table, for this user (or ``uid``/``gids``)."""
    name = f"port:{kind}"
    path = port_path(settings)
    if path is None:
        return Check(
            name,
            SKIP,
            f"[{kind}] port {settings.port!r} is a network link (checked when the device answers)",
            needed=False,
        )
    if not os.path.exists(path):
        return Check(
            name,
            FAIL,
            f"[{kind}] port {path} does not exist",
            f"plug in the {kind} (its USB serial adapter) and look for its port with "
            f"`snrmon devices` (or ls /dev/serial/by-id/); then set [{kind}] port",
            data={"path": path},
        )
    st = os.stat(path)
    if not stat.S_ISCHR(st.st_mode):
        return Check(
            name,
            FAIL,
            f"[{kind}] port {path} is not a character device",
            f"[{kind}] port must name a serial device (/dev/ttyUSB0, /dev/serial/by-id/...)",
            data={"path": path},
        )
    me = os.getuid() if uid is None else uid
    groups = set(os.getgroups()) | {os.getgid()} if gids is None else set(gids)
    ok = may_read_write(st, me, groups) if uid is not None else os.access(path, os.R_OK | os.W_OK)
    owner, group = _user_name(st.st_uid), _group_name(st.st_gid)
    mode = stat.filemode(st.st_mode)
    data = {"path": path, "mode": mode, "owner": owner, "group": group}
    if ok:
        return Check(
            name,
            PASS,
            f"[{kind}] port {path} ({mode} {owner}:{group}) is readable and writable by this user",
            data=data,
        )
    user = _user_name(me)
    members = set(grp.getgrgid(st.st_gid).gr_mem) if group != str(st.st_gid) else set()
    if user in members:
        fix = (
            f"{user} is in group {group} but this login is not yet: log out and back in "
            f"(or run `newgrp {group}`)"
        )
    else:
        fix = (
            f"sudo usermod -aG {group} {user}, then log out and back in (the port is "
            f"{mode} {owner}:{group})"
        )
    return Check(
        name, FAIL, f"[{kind}] port {path} is not readable and writable by {user}", fix, data=data
    )
