"""The one console script: `uvteam <command> [args]`.

Commands are registered by the service packages under the entry-point group ``uvteam.commands``
(pyproject.toml), so this core module never imports a service.
"""

from __future__ import annotations

import sys
from importlib import metadata
from importlib.metadata import entry_points

__all__ = ["main", "commands"]

_HELP = {
    "demo": "run the whole team on loopback with the simulator and a live view",
    "sim": "the simulator: plays each vehicle's autopilot and the UAV camera",
    "uav": "the UAV service: camera -> detections, autopilot -> fix",
    "ugv": "a UGV service: autopilot -> fix + plan, crowds -> planner -> waypoints",
    "localizer": "the localizer service: detections + fixes + plans -> geolocated crowds",
    "tap": "print any uvteam key as JSON lines, or a live summary table",
    "bridge": "crowds and vehicles to GeoJSON, KML/KMZ, CoT (ATAK), MAVLink (QGC/MP) and CSV",
    "map": "the team on a live map in the browser (local web app, works offline)",
    "protocol": "write the protocol's JSON Schemas and reference, generated from the message definitions",
    "record": "record every key of a team to an MCAP file (Foxglove opens it)",
    "replay": "play a recording back onto a bus, or through a fresh localizer to compare its crowds",
    "router": "a zenoh router for ground stations and multi-host setups",
    "certs": "the team CA, certificates and secure zenoh configs (TLS, mTLS, access control)",
    "bench": "benchmarks: localize, vision, latency",
    "experiment": "run scenario files over their seeds; write tables and plots",
    "process": "the UAV pipeline and the localizer offline on a recorded flight (video + fixes CSV)",
}


def commands() -> dict:
    return {ep.name: ep for ep in entry_points(group="uvteam.commands")}


def version() -> str:
    try:
        return metadata.version("uvteam")
    except metadata.PackageNotFoundError:   # a source tree that was never installed
        return "unknown (not installed)"


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    cmds = commands()
    if argv and argv[0] in ("-V", "--version", "version"):
        print(f"uvteam {version()} (Python {sys.version.split()[0]})")
        return 0
    if not argv or argv[0] in ("-h", "--help", "help"):
        print("usage: uvteam <command> [--help] [args]\n       uvteam --version\n\ncommands:")
        for name in sorted(cmds):
            print(f"  {name:<11} {_HELP.get(name, '')}")
        from .io.zenoh_bus import BUS_FLAGS_HELP  # noqa: PLC0415

        print("\n" + BUS_FLAGS_HELP)
        return 0 if argv else 2
    name, rest = argv[0], argv[1:]
    if name not in cmds:
        print(f"uvteam: unknown command {name!r}; try `uvteam --help`", file=sys.stderr)
        return 2
    return int(cmds[name].load()(rest) or 0)
