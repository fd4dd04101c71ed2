"""The message bus: typed publish/subscribe over zenoh, with an in-memory twin for tests.

    bus = ZenohBus.open(BusConfig(config_file="deploy/zenoh/peer.json5", connect=["tcp/10.0.0.1:7447"]))
    with bus:
        bus.declare_alive(keys.alive(team, vehicle))
        bus.subscribe(keys.all_vehicles(team, "fix"), Fix, on_fix)      # decoded and validated
        bus.publish(keys.key(team, vehicle, "fix"), Fix(...))

A payload that does not decode is logged with its key (rate-limited), counted in ``bus.rejected``
and dropped; the handler never sees it. Handlers run on zenoh's threads: keep them short (push to a
queue). Sessions are always closed (an unclosed session with a callback subscriber hangs the
interpreter at exit), so use the bus as a context manager.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Protocol

from . import messages
from .errors import ConfigError, LinkError, MessageError

__all__ = ["BusConfig", "Bus", "ZenohBus", "InMemoryBus", "keyexpr_matches", "add_bus_args", "bus_config_from_args"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BusConfig:
    config_file: str | None = None     # zenoh JSON5; None = built-in peer config, multicast scouting off
    mode: str | None = None            # "peer" | "client" | "router"
    connect: tuple[str, ...] = ()
    listen: tuple[str, ...] = ()
    shared_memory: bool | None = None

    def to_zenoh(self):
        import zenoh  # noqa: PLC0415

        if self.config_file:
            path = Path(self.config_file)
            if not path.is_file():
                raise ConfigError(str(path), "zenoh config", "file not found")
            try:
                conf = zenoh.Config.from_file(str(path))
            except Exception as exc:  # zenoh raises ZError for any parse/validation problem
                raise ConfigError(str(path), "zenoh config", str(exc)) from None
        else:
            conf = zenoh.Config()
            conf.insert_json5("scouting/multicast/enabled", "false")
        try:
            if self.mode:
                if self.mode not in ("peer", "client", "router"):
                    raise ConfigError("--mode", "mode", f"must be peer, client or router, got {self.mode!r}")
                conf.insert_json5("mode", json.dumps(self.mode))
            if self.connect:
                conf.insert_json5("connect/endpoints", json.dumps(list(self.connect)))
            if self.listen:
                conf.insert_json5("listen/endpoints", json.dumps(list(self.listen)))
            if self.shared_memory is not None:
                conf.insert_json5("transport/shared_memory/enabled", json.dumps(self.shared_memory))
        except ConfigError:
            raise
        except Exception as exc:
            raise ConfigError(self.config_file or "<zenoh>", "endpoints", str(exc)) from None
        return conf


def add_bus_args(ap) -> None:
    """The same zenoh flags on every command, as zenoh's own examples have them."""
    g = ap.add_argument_group("zenoh")
    g.add_argument("--zenoh-config", metavar="FILE", help="zenoh JSON5 config (see deploy/zenoh/)")
    g.add_argument("--mode", choices=["peer", "client", "router"], help="zenoh session mode")
    g.add_argument("--connect", "-e", action="append", default=[], metavar="ENDPOINT",
                   help="endpoint to connect to, e.g. tcp/192.168.1.10:7447 (repeatable)")
    g.add_argument("--listen", "-l", action="append", default=[], metavar="ENDPOINT",
                   help="endpoint to listen on, e.g. tcp/0.0.0.0:7447 (repeatable)")


def bus_config_from_args(args, base: BusConfig | None = None) -> BusConfig:
    base = base or BusConfig()
    return BusConfig(config_file=args.zenoh_config or base.config_file, mode=args.mode or base.mode,
                     connect=tuple(args.connect) or base.connect, listen=tuple(args.listen) or base.listen,
                     shared_memory=base.shared_memory)


class Bus(Protocol):
    rejected: Counter
    published: int

    def publish(self, key: str, msg: Any) -> None: ...
    def subscribe(self, keyexpr: str, cls: type, handler: Callable[[str, Any], None]) -> None: ...
    def declare_alive(self, key: str) -> None: ...
    def watch_alive(self, keyexpr: str, handler: Callable[[str, bool], None]) -> None: ...
    def close(self) -> None: ...


class _RateLimitedLog:
    def __init__(self, period_s: float = 5.0) -> None:
        self.period_s, self._last = period_s, {}
        self._lock = threading.Lock()

    def warn(self, key: str, fmt: str, *args) -> None:
        now = time.monotonic()
        with self._lock:
            if now - self._last.get(key, -1e9) < self.period_s:
                return
            self._last[key] = now
        log.warning(fmt, *args)


class _Decoding:
    """Decode-validate-count, shared by the zenoh bus and the in-memory one."""

    def __init__(self) -> None:
        self.rejected: Counter = Counter()
        self.published = 0
        self.received = 0
        self._warn = _RateLimitedLog()
        self._lock = threading.Lock()

    def _deliver(self, key: str, raw: bytes, cls: type, handler: Callable[[str, Any], None]) -> None:
        try:
            msg = messages.decode(cls, raw)
        except MessageError as exc:
            with self._lock:
                self.rejected[key] += 1
            self._warn.warn(key, "dropped a bad message on %s: %s", key, exc)
            return
        with self._lock:
            self.received += 1
        try:
            handler(key, msg)
        except Exception:  # a handler bug must not kill zenoh's thread; it is logged in full
            log.exception("handler for %s failed", key)

    @property
    def rejected_total(self) -> int:
        with self._lock:
            return sum(self.rejected.values())


class ZenohBus(_Decoding):
    def __init__(self, session) -> None:
        super().__init__()
        import zenoh  # noqa: PLC0415

        self._zenoh = zenoh
        self.session = session
        self._encoding = zenoh.Encoding(messages.ENCODING)
        self._pubs: dict[str, Any] = {}
        self._subs: list[Any] = []
        self._tokens: list[Any] = []
        self._closed = False

    @classmethod
    def open(cls, cfg: BusConfig) -> "ZenohBus":
        import zenoh  # noqa: PLC0415

        try:
            return cls(zenoh.open(cfg.to_zenoh()))
        except ConfigError:
            raise
        except Exception as exc:  # ZError: unable to connect, bad endpoint
            raise LinkError("zenoh", str(exc)) from None

    def __enter__(self) -> "ZenohBus":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def publish(self, key: str, msg: Any, *, express: bool = True) -> None:
        raw = messages.encode(msg)
        pub = self._pubs.get(key)
        if pub is None:
            pub = self.session.declare_publisher(
                key, encoding=self._encoding, express=express,
                congestion_control=self._zenoh.CongestionControl.BLOCK)
            self._pubs[key] = pub
        pub.put(raw)
        self.published += 1

    def put_raw(self, key: str, raw: bytes) -> None:
        """Send arbitrary bytes (tests and fault injection only)."""
        self.session.put(key, raw, encoding=self._encoding)

    def subscribe(self, keyexpr: str, cls: type, handler: Callable[[str, Any], None]) -> None:
        def on_sample(sample) -> None:
            self._deliver(str(sample.key_expr), sample.payload.to_bytes(), cls, handler)

        self._subs.append(self.session.declare_subscriber(keyexpr, on_sample))

    def declare_alive(self, key: str) -> None:
        self._tokens.append(self.session.liveliness().declare_token(key))

    def watch_alive(self, keyexpr: str, handler: Callable[[str, bool], None]) -> None:
        put = self._zenoh.SampleKind.PUT

        def on_sample(sample) -> None:
            try:
                handler(str(sample.key_expr), sample.kind == put)
            except Exception:
                log.exception("liveliness handler for %s failed", sample.key_expr)

        self._subs.append(self.session.liveliness().declare_subscriber(keyexpr, on_sample, history=True))

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        for s in self._subs:
            try:
                s.undeclare()
            except Exception:  # already gone with the session
                pass
        for t in self._tokens:
            try:
                t.undeclare()
            except Exception:
                pass
        self.session.close()


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


class InMemoryBus(_Decoding):
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

    def put_raw(self, key: str, raw: bytes) -> None:
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
