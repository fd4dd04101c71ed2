"""`uvteam router`: a zenoh router in Python (no zenohd binary is packaged for this platform).

    uvteam router --listen tcp/0.0.0.0:7447
"""

from __future__ import annotations

import argparse
import logging
import sys

from uvteam.bus import BusConfig
from uvteam.io.zenoh_bus import add_bus_args, zenoh_config
from uvteam.service import StopFlag, setup_logging

log = logging.getLogger("uvteam.router")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="uvteam router", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    add_bus_args(ap)
    args = ap.parse_args(argv)
    setup_logging("router")
    import zenoh  # noqa: PLC0415

    cfg = BusConfig(config_file=args.zenoh_config, mode="router", connect=tuple(args.connect),
                    listen=tuple(args.listen) or ("tcp/0.0.0.0:7447",))
    stop = StopFlag()
    try:
        session = zenoh.open(zenoh_config(cfg))
    except Exception as exc:  # ZError
        print(f"uvteam router: cannot start: {exc}", file=sys.stderr)
        return 3
    try:
        log.info("router %s listening on %s", session.info.zid(), ", ".join(cfg.listen))
        while not stop.wait(1.0):
            pass
    finally:
        session.close()
    return 0
