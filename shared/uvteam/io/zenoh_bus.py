"""The zenoh bus: :class:`uvteam.bus.Bus` over an eclipse-zenoh session, and zenoh's command-line flags.

    with ZenohBus.open(BusConfig(config_file="deploy/zenoh/peer.json5", connect=("tcp/10.0.0.1:7447",))) as bus:
        ...

Handlers run on zenoh's threads: keep them short (push to a queue). Sessions are always closed (an
unclosed session with a callback subscriber hangs the interpreter at exit), so use the bus as a
context manager. After :meth:`ZenohBus.close` a publish is dropped and counted (``dropped_closed``)
without calling zenoh: a thread still inside a zenoh call while the interpreter finalises is
cancelled through zenoh's native frames, and the process aborts ("FATAL: exception not rethrown").
A publish that passed that check while another thread closed the bus gets zenoh's "session closed"
error: counted and dropped the same way.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any, Callable

from .. import messages
from ..bus import BusConfig, Decoding
from ..errors import ConfigError, LinkError

__all__ = ["ZenohBus", "zenoh_config", "add_bus_args", "bus_config_from_args", "parse_cfg", "BUS_FLAGS_HELP"]

log = logging.getLogger(__name__)

# Without a config file, what deploy/zenoh/client.json5 and peer.json5 ship: no multicast scouting, a
# silent link declared dead after 3 s (liveliness follows), and reconnection tried every 0.25-1 s, so a
# restarted router or peer is found again within a second of coming back.
BUILT_IN = {"scouting/multicast/enabled": "false", "transport/link/tx/lease": "3000",
            "connect/retry": "{period_init_ms: 250, period_max_ms: 1000, period_increase_factor: 2}"}


def zenoh_config(cfg: BusConfig):
    """A :class:`BusConfig` as a ``zenoh.Config`` (file first, or :data:`BUILT_IN`; then the explicit
    fields over it; then each ``--cfg KEY:VALUE``)."""
    import zenoh  # noqa: PLC0415

    if cfg.config_file:
        path = Path(cfg.config_file)
        if not path.is_file():
            raise ConfigError(str(path), "zenoh config", "file not found")
        try:
            conf = zenoh.Config.from_file(str(path))
        except Exception as exc:  # zenoh raises ZError for any parse/validation problem
            raise ConfigError(str(path), "zenoh config", str(exc)) from None
    else:
        conf = zenoh.Config()
        for k, v in BUILT_IN.items():
            conf.insert_json5(k, v)
    try:
        if cfg.mode:
            if cfg.mode not in ("peer", "client", "router"):
                raise ConfigError("--mode", "mode", f"must be peer, client or router, got {cfg.mode!r}")
            conf.insert_json5("mode", json.dumps(cfg.mode))
        if cfg.connect:
            conf.insert_json5("connect/endpoints", json.dumps(list(cfg.connect)))
        if cfg.listen:
            conf.insert_json5("listen/endpoints", json.dumps(list(cfg.listen)))
        if cfg.shared_memory is not None:
            conf.insert_json5("transport/shared_memory/enabled", json.dumps(cfg.shared_memory))
        if cfg.connect_timeout_ms is not None:
            conf.insert_json5("connect/timeout_ms", json.dumps(cfg.connect_timeout_ms))
    except ConfigError:
        raise
    except Exception as exc:
        raise ConfigError(cfg.config_file or "<zenoh>", "endpoints", str(exc)) from None
    for key, value in cfg.cfg:
        try:
            conf.insert_json5(key, value)
        except Exception as exc:  # ZError: an unknown key, or a value of the wrong type or not JSON5
            raise ConfigError("--cfg", key, f"zenoh refuses {value!r}: {exc}") from None
    return conf


def parse_cfg(items) -> tuple[tuple[str, str], ...]:
    """``--cfg KEY:VALUE`` items (zenoh's examples' syntax: VALUE is JSON5, inserted at the config path
    KEY) -> pairs; ConfigError for one without a colon."""
    out = []
    for item in items or ():
        key, sep, value = item.partition(":")
        if not sep or not key.strip() or not value.strip():
            raise ConfigError("--cfg", item, "expected KEY:VALUE, e.g. 'transport/link/tx/lease:3000' or "
                                             "'scouting/multicast/enabled:false'")
        out.append((key.strip(), value.strip()))
    return tuple(out)


BUS_FLAGS_HELP = """zenoh flags (the same on every command that opens a session, as in zenoh's own examples):
  -m, --mode peer|client|router   session mode (default: the config's, else peer; tap, map, record and replay:
                                  client when --connect is given; uvteam router: router)
  -e, --connect ENDPOINT          connect to ENDPOINT, e.g. tcp/10.0.0.1:7447 (repeatable)
  -l, --listen ENDPOINT           listen on ENDPOINT, e.g. tcp/0.0.0.0:7447 (repeatable)
  --zenoh-config FILE             a zenoh JSON5 config file (deploy/zenoh/); the flags above go over it
  --cfg KEY:VALUE                 insert the JSON5 VALUE at config path KEY, last, e.g.
                                  --cfg transport/link/tx/lease:3000 --cfg 'connect/endpoints:["tcp/10.0.0.1:7447"]'
Without --zenoh-config, multicast scouting is off: say where to connect or listen."""


def add_bus_args(ap) -> None:
    """The same zenoh flags on every command, as zenoh's own examples have them (:data:`BUS_FLAGS_HELP`)."""
    g = ap.add_argument_group("zenoh", "the same on every command that opens a zenoh session (docs: README, "
                                       "'zenoh flags')")
    g.add_argument("--zenoh-config", metavar="FILE", help="zenoh JSON5 config (see deploy/zenoh/); the flags go over it")
    g.add_argument("--mode", "-m", choices=["peer", "client", "router"], help="zenoh session mode")
    g.add_argument("--connect", "-e", action="append", default=[], metavar="ENDPOINT",
                   help="endpoint to connect to, e.g. tcp/192.168.1.10:7447 (repeatable)")
    g.add_argument("--listen", "-l", action="append", default=[], metavar="ENDPOINT",
                   help="endpoint to listen on, e.g. tcp/0.0.0.0:7447 (repeatable)")
    g.add_argument("--cfg", action="append", default=[], metavar="KEY:VALUE",
                   help="insert a JSON5 VALUE at zenoh config path KEY, last (zenoh's examples' syntax), e.g. "
                        "--cfg transport/link/tx/lease:3000 (repeatable)")


def bus_config_from_args(args, base: BusConfig | None = None) -> BusConfig:
    """The flags over ``base``; ConfigError for a malformed ``--cfg``."""
    base = base or BusConfig()
    return BusConfig(config_file=args.zenoh_config or base.config_file, mode=args.mode or base.mode,
                     connect=tuple(args.connect) or base.connect, listen=tuple(args.listen) or base.listen,
                     shared_memory=base.shared_memory, connect_timeout_ms=base.connect_timeout_ms,
                     cfg=base.cfg + parse_cfg(getattr(args, "cfg", ())))


class ZenohBus(Decoding):
    def __init__(self, session) -> None:
        super().__init__()
        import zenoh  # noqa: PLC0415

        self._zenoh = zenoh
        self.session = session
        self._encoding = zenoh.Encoding(messages.ENCODING)
        self._pubs: dict[tuple[str, type], Any] = {}
        self._subs: list[Any] = []
        self._tokens: list[Any] = []
        self._closed = False
        self.dropped_closed = 0      # publishes that came after close(): never handed to zenoh

    @classmethod
    def open(cls, cfg: BusConfig) -> "ZenohBus":
        import zenoh  # noqa: PLC0415

        try:
            return cls(zenoh.open(zenoh_config(cfg)))
        except ConfigError:
            raise
        except Exception as exc:  # ZError: unable to connect, bad endpoint
            raise LinkError("zenoh", str(exc)) from None

    def __enter__(self) -> "ZenohBus":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def publish(self, key: str, msg: Any, *, express: bool = True) -> None:
        """Encode, validate and put ``msg`` on ``key``; zenoh's encoding names its schema
        (``application/msgpack;crowds/3``), so a receiver can tell what came without decoding it."""
        raw = messages.encode(msg)
        if self._send(key, lambda: self._publisher(key, type(msg), express).put(raw)):
            self.published += 1

    def _publisher(self, key: str, cls: type, express: bool):
        """The publisher of ``cls`` on ``key``, declared on first use."""
        pub = self._pubs.get((key, cls))
        if pub is None:
            pub = self.session.declare_publisher(
                key, encoding=self._zenoh.Encoding(messages.encoding_of(cls)), express=express,
                congestion_control=self._zenoh.CongestionControl.BLOCK)
            self._pubs[(key, cls)] = pub
        return pub

    def put_raw(self, key: str, raw: bytes, encoding: str | None = None) -> None:
        """Send bytes as they are: a recording played back (``encoding`` as recorded, e.g.
        ``application/msgpack;fix/2``), or garbage in fault-injection tests (plain ``application/msgpack``).
        Blocking under congestion as :meth:`publish` does: zenoh's default drops, and a replay as fast as
        it goes on a loaded machine lost a payload."""
        self._send(key, lambda: self.session.put(
            key, raw, encoding=self._zenoh.Encoding(encoding) if encoding else self._encoding,
            congestion_control=self._zenoh.CongestionControl.BLOCK))

    def _send(self, key: str, put: Callable[[], Any]) -> bool:
        """``put()`` unless the bus is closed; True when it ran. A put that meets a close (another thread's,
        after the check: zenoh says "session closed") is dropped and counted as one after it is."""
        if self._closed:
            self._drop_closed(key)
            return False
        try:
            put()
        except Exception:
            if not self._closed:
                raise
            self._drop_closed(key)
            return False
        return True

    def _drop_closed(self, key: str) -> None:
        self.dropped_closed += 1
        if self.dropped_closed == 1:
            log.info("bus closed: dropped a message for %s (and any after it)", key)

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


