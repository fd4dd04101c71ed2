"""Loopback ports chosen now for a process started later to bind (the demo's router and MAVLink links,
the benchmarks, the tests).

Binding port 0 and closing the socket names a port that is free now, but the kernel takes it from its
ephemeral range, from which it also hands a port to every socket that connects or sends without binding
first (a zenoh client's connection, the simulator's autopilot sockets). Between the choice and the bind,
such a socket can be given the very port: a UGV service once failed to open its ``udpin`` link with
EADDRINUSE in a loaded test run. :func:`free_port` therefore picks at random below the ephemeral range,
where only an explicit bind takes a port, and checks that nothing holds it. Nothing holds a port it named
until its process starts, so a caller that names several before starting any passes those already named
(``taken``): the demo once gave two UGVs' links the same port, and the second failed to bind.
"""

from __future__ import annotations

import random
import socket
from collections.abc import Collection
from pathlib import Path

__all__ = ["ephemeral_range", "free_port"]

LOWEST_PORT = 20000                 # below: the well-known and registered ports services tend to use
DYNAMIC_RANGE = (49152, 65535)      # IANA's dynamic ports: what BSD, macOS and Windows hand out
LINUX_RANGE_FILE = Path("/proc/sys/net/ipv4/ip_local_port_range")
TRIES = 100


def ephemeral_range(path: Path = LINUX_RANGE_FILE) -> tuple[int, int]:
    """The ports the kernel hands to sockets that do not bind one (inclusive): Linux's setting, else IANA's."""
    try:
        lo, hi = (int(v) for v in path.read_text().split())
    except (OSError, ValueError):
        return DYNAMIC_RANGE
    return lo, hi


def free_port(kind: int = socket.SOCK_STREAM, host: str = "127.0.0.1", *,
              rng: random.Random | None = None, ephemeral: tuple[int, int] | None = None,
              taken: Collection[int] = ()) -> int:
    """A ``kind`` port on ``host`` that nothing holds now and not in ``taken`` (named already for a process
    not started yet), below the ephemeral range (module docstring); the kernel's own choice when there is no
    room below it or every try is taken."""
    lo, _ = ephemeral_range() if ephemeral is None else ephemeral
    top = min(lo, 65536)
    pick = rng or random.SystemRandom()
    if top - LOWEST_PORT >= 1000:
        for _ in range(TRIES):
            port = pick.randrange(LOWEST_PORT, top)
            if port in taken:
                continue
            with socket.socket(socket.AF_INET, kind) as s:
                try:
                    s.bind((host, port))
                except OSError:
                    continue
                return port
    for _ in range(TRIES):
        with socket.socket(socket.AF_INET, kind) as s:
            s.bind((host, 0))
            port = s.getsockname()[1]
        if port not in taken:
            return port
    raise OSError(f"no free port on {host} outside the {len(taken)} already named")
