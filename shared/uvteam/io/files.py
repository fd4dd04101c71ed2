"""Files the services read at start-up: TOML configs and scenarios, signing keys. Each failure is a
:class:`uvteam.errors.ConfigError` naming the file."""

from __future__ import annotations

import sys

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10
    import tomli as tomllib
from pathlib import Path

from ..bus import BusConfig
from ..config import VehicleConfig, vehicle_config_from_dict
from ..errors import ConfigError
from ..scenario import Scenario, scenario_from_dict

__all__ = ["read_toml", "load_vehicle_config", "load_scenario", "read_signing_key"]


def read_toml(path: str | Path) -> dict:
    """A TOML file as a dict, or ConfigError naming the file."""
    p = Path(path)
    try:
        text = p.read_bytes().decode("utf-8")
        return tomllib.loads(text)
    except (FileNotFoundError, IsADirectoryError):
        raise ConfigError(str(p), "<file>", "not found") from None
    except OSError as exc:
        raise ConfigError(str(p), "<file>", f"cannot be read: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(str(p), "<file>", f"not a text file (byte {exc.start} is not UTF-8)") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(str(p), "<file>", f"not TOML: {exc}") from None


def load_vehicle_config(path: str | Path, *, bus_override: BusConfig | None = None) -> VehicleConfig:
    p = Path(path)
    return vehicle_config_from_dict(read_toml(p), str(p), base_dir=p.parent, bus_override=bus_override)


def load_scenario(path: str | Path) -> Scenario:
    p = Path(path)
    return scenario_from_dict(read_toml(p), str(p))


def read_signing_key(cfg: VehicleConfig) -> bytes | None:
    """The 32-byte MAVLink 2 signing key the config names, or None when it names none."""
    if not cfg.autopilot.signing_key_file:
        return None
    kp = Path(cfg.autopilot.signing_key_file)
    try:
        key = kp.read_bytes()
    except OSError as exc:
        raise ConfigError(cfg.source, "autopilot.signing_key_file", str(exc)) from None
    if len(key) != 32:
        raise ConfigError(cfg.source, "autopilot.signing_key_file", f"a signing key has 32 bytes, got {len(key)}")
    return key
