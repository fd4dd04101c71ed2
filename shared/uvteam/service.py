"""What every service shell shares: argument parsing, logging with the vehicle id, a stop flag set by
SIGINT/SIGTERM, and exit codes (0 ok, 2 configuration error, 3 link error)."""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
from typing import Callable

from .io.files import load_vehicle_config
from .io.zenoh_bus import add_bus_args, bus_config_from_args
from .config import VehicleConfig
from .errors import ConfigError, LinkError

__all__ = ["service_main", "StopFlag", "setup_logging"]


def setup_logging(name: str, level: str = "INFO") -> None:
    logging.basicConfig(level=getattr(logging, level.upper(), logging.INFO), stream=sys.stderr,
                        format=f"%(asctime)s {name} %(levelname)s %(name)s: %(message)s", force=True)


class StopFlag:
    """Set by SIGINT or SIGTERM (or by the caller); services poll it or wait on it."""

    def __init__(self, install: bool = True) -> None:
        self.event = threading.Event()
        if install and threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                signal.signal(sig, lambda *_: self.event.set())

    def is_set(self) -> bool:
        return self.event.is_set()

    def wait(self, timeout: float) -> bool:
        return self.event.wait(timeout)

    def set(self) -> None:
        self.event.set()


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
        return run(cfg, StopFlag())
    except ConfigError as exc:
        logging.getLogger(prog).error("configuration error: %s", exc)
        return 2
    except LinkError as exc:
        logging.getLogger(prog).error("link error: %s", exc)
        return 3
