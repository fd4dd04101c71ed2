"""The skeleton every service shell shares, written once: argument parsing and config loading (exit 2 on
a bad config), logging with the vehicle id, opening the bus and declaring liveliness, the node's
worker threads, status at 1 Hz with typed metrics, a newest-wins slot, and a clean shutdown on
SIGINT/SIGTERM. Exit codes: 0 ok, 2 configuration error, 3 link error.

A service's logic is a *node* (:mod:`uvteam.nodes`): a class handed its bus, autopilot and clock, with
no I/O of its own. The shell (``services/uvteam_*/app.py``) opens the real links and calls
:func:`run_node`; the experiment drives the same node classes over the in-memory bus in simulated time.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import threading
import time
from dataclasses import replace
from typing import Callable, Protocol

from . import keys
from .bus import Bus
from .config import VehicleConfig
from .errors import ConfigError, LinkError
from .io.files import load_vehicle_config
from .io.systemd import notify
from .io.zenoh_bus import ZenohBus, add_bus_args, bus_config_from_args
from .messages import Status
from .sync import LatestSlot, StopFlag

__all__ = ["service_main", "run_node", "Node", "StopFlag", "LatestSlot", "setup_logging", "STATUS_PERIOD_S"]

log = logging.getLogger(__name__)
STATUS_PERIOD_S = 1.0
STEP_TIMEOUT_S = 0.02


def setup_logging(name: str, level: str = "INFO") -> None:
    logging.basicConfig(level=getattr(logging, level.upper(), logging.INFO), stream=sys.stderr,
                        format=f"%(asctime)s {name} %(levelname)s %(name)s: %(message)s", force=True)


class Node(Protocol):
    """What :func:`run_node` needs of a service's logic."""

    service: str                                    # "uav" | "ugv" | "localizer"

    def start(self) -> None: ...                    # subscribe on the bus
    def step(self, timeout_s: float) -> None: ...   # the main loop's work; may wait up to timeout_s for some
    def workers(self) -> list[tuple[str, Callable[[StopFlag], None]]]: ...   # loops for threads of their own
    def metrics(self) -> dict[str, float]: ...      # numbers for the status message
    def link_state(self) -> str: ...                # the autopilot link: "up" | "down" | "none"
    def note(self) -> str: ...                      # one line for people


def status_of(cfg: VehicleConfig, node: Node, bus: Bus, now_s: float) -> Status:
    return Status(cfg.id, node.service, now_s, node.link_state(), bus.rejected_total, bus.published, bus.received,
                  {k: float(v) for k, v in node.metrics().items()}, node.note()[:256])


Worker = tuple[str, Callable[[StopFlag], None]]
JOIN_TIMEOUT_S = 2.0
# The node's threads that outlived their join (names). A thread still inside native code (zenoh,
# OpenCV) when the interpreter finalises is cancelled through frames that catch the unwind, and the
# process aborts ("FATAL: exception not rethrown") after a clean stop; service_main then exits
# without finalising instead.
_stragglers: list[str] = []
OPEN_ATTEMPT_MS = 1000       # each attempt to reach the router waits this long, so a stop is heard within 2 s


def open_bus(cfg: VehicleConfig, stop: StopFlag) -> ZenohBus | None:
    """The zenoh bus, retried until it opens or ``stop`` (None then): a service started before its router
    says it is waiting, once per attempt, and stops promptly when told."""
    attempt = replace(cfg.bus, connect_timeout_ms=OPEN_ATTEMPT_MS) if cfg.bus.connect else cfg.bus
    tries = 0
    while not stop.is_set():
        try:
            return ZenohBus.open(attempt)
        except LinkError as exc:
            tries += 1
            if tries == 1 or tries % 30 == 0:
                log.warning("cannot reach %s yet (%s); retrying until it answers or the service is stopped",
                            ", ".join(cfg.bus.connect) or "the bus", exc.reason)
            stop.wait(0.5)
    return None


def run_node(cfg: VehicleConfig, stop: StopFlag, make_node: Callable[[Bus], Node],
             shell_workers: Callable[[Node], list[Worker]] | None = None) -> int:
    """Open the zenoh bus, declare liveliness, run the node until ``stop``; status once a second.
    ``shell_workers``: loops of the shell's own I/O (a camera) that feed the node, on threads too."""
    bus = open_bus(cfg, stop)
    if bus is None:
        log.info("%s %s stopped before the bus opened", cfg.role, cfg.id)
        return 0
    with bus:
        bus.declare_alive(keys.alive(cfg.team, cfg.id))
        node = make_node(bus)
        node.start()
        loops = node.workers() + (shell_workers(node) if shell_workers else [])
        threads = [threading.Thread(target=fn, args=(stop,), name=name, daemon=True) for name, fn in loops]
        for t in threads:
            t.start()
        status_key = keys.key(cfg.team, cfg.id, "status")
        log.info("%s %s up (%s)", cfg.role, cfg.id, node.note() or "no data yet")
        notify("READY=1")
        next_status = 0.0
        try:
            while not stop.is_set():
                node.step(STEP_TIMEOUT_S)
                now = time.time()
                if now >= next_status:
                    bus.publish(status_key, status_of(cfg, node, bus, now))
                    notify("WATCHDOG=1")
                    next_status = now + STATUS_PERIOD_S
        finally:
            notify("STOPPING=1")
            stop.set()
            deadline = time.monotonic() + JOIN_TIMEOUT_S
            for t in threads:
                t.join(timeout=max(0.0, deadline - time.monotonic()))
            _stragglers.extend(t.name for t in threads if t.is_alive())
            if _stragglers:
                log.warning("still running %.0f s after the stop: %s", JOIN_TIMEOUT_S, ", ".join(_stragglers))
            close = getattr(node, "close", None)
            if close is not None:
                close()
            log.info("%s %s stopping: %s", cfg.role, cfg.id,
                     " ".join(f"{k}={v:g}" for k, v in sorted(node.metrics().items())))
    return 0


def service_main(argv: list[str] | None, prog: str, description: str, role: str,
                 run: Callable[[VehicleConfig, StopFlag], int]) -> int:
    ap = argparse.ArgumentParser(prog=prog, description=description)
    ap.add_argument("--config", "-c", required=True, metavar="FILE", help="vehicle TOML (deploy/vehicles/*.toml)")
    ap.add_argument("--log-level", default="INFO", choices=["DEBUG", "INFO", "WARNING", "ERROR"])
    add_bus_args(ap)
    args = ap.parse_args(argv)
    try:
        cfg = load_vehicle_config(args.config, bus_override=bus_config_from_args(args))
        if cfg.role != role:
            raise ConfigError(cfg.source, "vehicle.role", f"this is the {role} service, the file is for a {cfg.role}")
    except ConfigError as exc:
        print(f"{prog}: configuration error: {exc}", file=sys.stderr)
        return 2
    setup_logging(f"{cfg.team}/{cfg.id}", args.log_level)
    try:
        code = run(cfg, StopFlag())
    except ConfigError as exc:
        logging.getLogger(prog).error("configuration error: %s", exc)
        code = 2
    except LinkError as exc:
        logging.getLogger(prog).error("link error: %s", exc)
        code = 3
    if _stragglers:   # see _stragglers: everything is closed; do not let finalisation cancel them
        logging.shutdown()
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    return code
