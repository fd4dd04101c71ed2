"""Files the services read at start-up: TOML configs and scenarios, signing keys. Each failure is a
:class:`uvteam.errors.ConfigError` naming the file."""

from __future__ import annotations

import glob
import os
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

__all__ = ["read_toml", "load_vehicle_config", "load_scenario", "read_signing_key", "ground_imagery_files",
           "IMAGE_SUFFIXES", "ImageryMissing"]

IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png")


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


class ImageryMissing(ConfigError):
    """A scenario's real ground imagery is not on this machine (it lives in ../shared/data, never in the
    repository): tests and experiments skip such a scenario and say so."""


def load_vehicle_config(path: str | Path, *, bus_override: BusConfig | None = None) -> VehicleConfig:
    p = Path(path)
    return vehicle_config_from_dict(read_toml(p), str(p), base_dir=p.parent, bus_override=bus_override)


def load_scenario(path: str | Path) -> Scenario:
    """A scenario file, checked: keys, ranges, and that every file it names is there."""
    p = Path(path)
    sc = scenario_from_dict(read_toml(p), str(p))
    ground_imagery_files(sc)
    return sc


def ground_imagery_files(sc: Scenario) -> tuple[tuple[Path, ...], ...]:
    """The image files of each ``[[ground.imagery]]`` source, sorted: its ``path`` (a file, a folder of
    .jpg/.jpeg/.png, or a glob pattern) relative to the scenario file's folder. :class:`ImageryMissing`
    (a ConfigError) naming the scenario and ``ground.imagery[i].path`` when a source names no image file
    (e.g. ../shared/data is not on this machine: the real imagery is never in the repository)."""
    base = Path(sc.path).parent if sc.path else Path(".")
    out = []
    for i, src in enumerate(sc.ground.imagery):
        raw = Path(src.path).expanduser()
        p = raw if raw.is_absolute() else base / raw
        if any(ch in src.path for ch in "*?["):
            files = sorted(Path(f) for f in glob.glob(str(p)) if Path(f).is_file())
        elif p.is_dir():
            files = sorted(f for f in p.iterdir() if f.is_file() and f.suffix.lower() in IMAGE_SUFFIXES)
        else:
            files = [p] if p.is_file() else []
        if not files:
            raise ImageryMissing(sc.path, f"ground.imagery[{i}].path",
                                 f"no image file at {src.path!r} (looked in {os.path.normpath(p)}); real imagery is "
                                 "not in the repository: it is read from ../shared/data, see scenarios/README.md")
        bad = [f.name for f in files if f.suffix.lower() not in IMAGE_SUFFIXES]
        if bad:
            raise ConfigError(sc.path, f"ground.imagery[{i}].path", f"not images ({', '.join(IMAGE_SUFFIXES)}): {bad[:3]}")
        out.append(tuple(files))
    return tuple(out)


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
