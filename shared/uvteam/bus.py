"""The message bus interface: typed publish/subscribe, and an in-memory twin of the zenoh bus.

    with bus:                                                   # a Bus: zenoh (uvteam.io.zenoh_bus) or InMemoryBus
        bus.declare_alive(keys.alive(team, vehicle))
        bus.subscribe(keys.all_vehicles(team, "fix"), Fix, on_fix)      # decoded and validated
        bus.publish(keys.key(team, vehicle, "fix"), Fix(...))

A payload that does not decode is logged with its key (rate-limited), counted in ``bus.rejected``
and dropped; the handler never sees it. Both buses share that decoding (:class:`Decoding`), so what a
unit test on the in-memory bus sees is what a service on zenoh sees. The in-memory bus delivers
synchronously on the publisher's thread: the experiment runs the services' own classes over it in
simulated time, deterministically.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import Counter
from dataclasses import dataclass
from typing import Any, Callable, Protocol

from . import messages
from .errors import MessageError

__all__ = ["BusConfig", "Bus", "Decoding", "InMemoryBus", "RateLimitedLog", "keyexpr_matches"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BusConfig:
    config_file: str | None = None     # zenoh JSON5; None = built-in peer config, multicast scouting off
    mode: str | None = None            # "peer" | "client" | "router"
    connect: tuple[str, ...] = ()
    listen: tuple[str, ...] = ()
    shared_memory: bool | None = None
    connect_timeout_ms: int | None = None   # how long opening waits for a connect endpoint (-1: forever)
    cfg: tuple[tuple[str, str], ...] = ()   # (KEY, JSON5 VALUE) inserted last, as zenoh's --cfg KEY:VALUE


class Bus(Protocol):
    rejected: Counter                 # per key: messages dropped (bad, or refused by a handler)
    published: int
    received: int
    rejected_total: int

    def publish(self, key: str, msg: Any) -> None: ...
    def subscribe(self, keyexpr: str, cls: type, handler: Callable[[str, Any], None]) -> None: ...
    def declare_alive(self, key: str) -> None: ...
    def watch_alive(self, keyexpr: str, handler: Callable[[str, bool], None]) -> None: ...
    def reject(self, key: str, why: str) -> None: ...
    def close(self) -> None: ...


class RateLimitedLog:
    """A warning at most once per ``period_s`` per reason (loops and handlers must not flood the log)."""

    def __init__(self, logger: logging.Logger = log, period_s: float = 5.0) -> None:
        self.log, self.period_s, self._last = logger, period_s, {}
        self._lock = threading.Lock()

    def warn(self, reason: str, fmt: str, *args) -> None:
        now = time.monotonic()
        with self._lock:
            if now - self._last.get(reason, -1e9) < self.period_s:
                return
            self._last[reason] = now
        self.log.warning(fmt, *args)


class Decoding:
    """Decode-validate-count, shared by the zenoh bus and the in-memory one."""

    def __init__(self) -> None:
        self.rejected: Counter = Counter()
        self.published = 0
        self.received = 0
        self._warn = RateLimitedLog()
        self._lock = threading.Lock()

    def _deliver(self, key: str, raw: bytes, cls: type, handler: Callable[[str, Any], None]) -> None:
        try:
            msg = messages.decode(cls, raw)
        except MessageError as exc:
            self.reject(key, str(exc))
            return
        with self._lock:
            self.received += 1
        try:
            handler(key, msg)
        except Exception:  # a handler bug must not kill zenoh's thread; it is logged in full
            log.exception("handler for %s failed", key)

    def reject(self, key: str, why: str) -> None:
        """Count and log (rate-limited) a message dropped on ``key``: undecodable here, or refused by
        its handler (a sender that is not who the key says, an implausible fix, ...)."""
        with self._lock:
            self.rejected[key] += 1
        self._warn.warn(key, "dropped a message on %s: %s", key, why)

    @property
    def rejected_total(self) -> int:
        with self._lock:
            return sum(self.rejected.values())


def keyexpr_matches(expr: str, key: str) -> bool:
    """zenoh key-expression match for the forms uvteam uses: literal chunks, '*' and '**'."""
    e, k = expr.split("/"), key.split("/")

    def m(i: int, j: int) -> bool:
        if i == len(e):
            return j == len(k)
        if e[i] == "**":
            return any(m(i + 1, jj) for jj in range(j, len(k) + 1))
        if j == len(k):
            return False
        return (e[i] == "*" or e[i] == k[j]) and m(i + 1, j + 1)

    return m(0, 0)


class InMemoryBus(Decoding):
    """The same interface in one process, synchronous: for unit tests of service logic."""

    def __init__(self, hub: "InMemoryBus | None" = None) -> None:
        super().__init__()
        self._hub = hub._hub if hub is not None else {"subs": [], "alive": set(), "watch": []}

    def __enter__(self) -> "InMemoryBus":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def publish(self, key: str, msg: Any) -> None:
        self.put_raw(key, messages.encode(msg))
        self.published += 1

    def put_raw(self, key: str, raw: bytes, encoding: str | None = None) -> None:
        """Bytes as they are to every matching subscriber (``encoding`` is zenoh's; unused here)."""
        for expr, cls, handler, owner in list(self._hub["subs"]):
            if keyexpr_matches(expr, key):
                owner._deliver(key, raw, cls, handler)

    def subscribe(self, keyexpr: str, cls: type, handler: Callable[[str, Any], None]) -> None:
        self._hub["subs"].append((keyexpr, cls, handler, self))

    def declare_alive(self, key: str) -> None:
        self._hub["alive"].add(key)
        for expr, h in self._hub["watch"]:
            if keyexpr_matches(expr, key):
                h(key, True)

    def watch_alive(self, keyexpr: str, handler: Callable[[str, bool], None]) -> None:
        self._hub["watch"].append((keyexpr, handler))
        for k in self._hub["alive"]:
            if keyexpr_matches(keyexpr, k):
                handler(k, True)

    def drop_alive(self, key: str) -> None:
        self._hub["alive"].discard(key)
        for expr, h in self._hub["watch"]:
            if keyexpr_matches(expr, key):
                h(key, False)

    def close(self) -> None:
        self._hub["subs"] = [s for s in self._hub["subs"] if s[3] is not self]
