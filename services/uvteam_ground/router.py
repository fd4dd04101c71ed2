"""`uvteam router`: a zenoh router in Python (no zenohd binary is packaged for this platform).

    uvteam router --listen tcp/0.0.0.0:7447
    uvteam router --zenoh-config deploy/zenoh/router.json5        listens where the file says
    uvteam router --zenoh-config deploy/secrets/border1/router.json5    TLS, mTLS, access control (uvteam certs)

Listen endpoints: --listen if given, else the config file's, else tcp/0.0.0.0:7447.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys

from uvteam.bus import BusConfig
from uvteam.errors import ConfigError
from uvteam.io.zenoh_bus import add_bus_args, parse_cfg, zenoh_config
from uvteam.service import StopFlag, setup_logging

log = logging.getLogger("uvteam.router")
DEFAULT_LISTEN = ("tcp/0.0.0.0:7447",)


def file_listen_endpoints(config_file: str | None) -> tuple[str, ...]:
    """The router listen endpoints a zenoh config file sets; () when it sets none (zenoh's default then
    stands in, which is not ours). Raises ConfigError for a missing or invalid file."""
    if not config_file:
        return ()
    import zenoh  # noqa: PLC0415

    eps = json.loads(zenoh_config(BusConfig(config_file=config_file)).get_json("listen/endpoints"))
    if eps == json.loads(zenoh.Config().get_json("listen/endpoints")):
        return ()                        # the file has no listen endpoints: zenoh's per-mode default
    if isinstance(eps, dict):            # {router: [...], peer: [...]}
        eps = eps.get("router", [])
    return tuple(eps)


def router_bus_config(config_file: str | None, connect: tuple[str, ...],
                      listen: tuple[str, ...], cfg: tuple[tuple[str, str], ...] = ()) -> tuple[BusConfig, tuple[str, ...]]:
    """The router's BusConfig and the endpoints it will listen on: flags over the file over the default
    (a --cfg of listen/endpoints is applied last, over all of them)."""
    from_file = file_listen_endpoints(config_file)
    cfg = BusConfig(config_file=config_file, mode="router", connect=connect,
                    listen=listen or (() if from_file else DEFAULT_LISTEN), cfg=cfg)
    return cfg, listen or from_file or DEFAULT_LISTEN


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="uvteam router", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    add_bus_args(ap)
    args = ap.parse_args(argv)
    setup_logging("router")
    import zenoh  # noqa: PLC0415

    try:
        if args.mode not in (None, "router"):
            raise ConfigError("--mode", "mode", f"uvteam router runs in mode router, not {args.mode}")
        cfg, endpoints = router_bus_config(args.zenoh_config, tuple(args.connect), tuple(args.listen),
                                           parse_cfg(args.cfg))
        conf = zenoh_config(cfg)
    except ConfigError as exc:
        print(f"uvteam router: configuration error: {exc}", file=sys.stderr)
        return 2
    stop = StopFlag()
    try:
        session = zenoh.open(conf)
    except Exception as exc:  # ZError
        print(f"uvteam router: cannot start: {exc}", file=sys.stderr)
        return 3
    try:
        log.info("router %s listening on %s", session.info.zid(), ", ".join(endpoints))
        while not stop.wait(1.0):
            pass
    finally:
        session.close()
    return 0
