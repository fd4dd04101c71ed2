"""systemd's service notification (sd_notify), without libsystemd: READY=1 when a service is up,
WATCHDOG=1 while it lives, STOPPING=1 on the way out. A no-op when not run by systemd (no NOTIFY_SOCKET)."""

from __future__ import annotations

import os
import socket

__all__ = ["notify"]


def notify(state: str) -> bool:
    """Send ``state`` (e.g. "READY=1") to systemd; False when there is no one to tell or it failed."""
    addr = os.environ.get("NOTIFY_SOCKET")
    if not addr:
        return False
    if addr.startswith("@"):          # an abstract socket
        addr = "\0" + addr[1:]
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as s:
            s.connect(addr)
            s.sendall(state.encode())
        return True
    except OSError:
        return False
