"""Every zenoh key uvteam uses, built here and nowhere else.

    uvteam/<team>/<vehicle>/<topic>          data: fix, plan, detections, people, crowds, status, truth, sensor, frame
    uvteam/<team>/<vehicle>/alive            liveliness token of the vehicle's service

Team and vehicle ids are 1-32 characters of [A-Za-z0-9_-], so no id can inject key-expression syntax.
"""

from __future__ import annotations

from .errors import ConfigError
from .vocab import is_id

__all__ = ["TOPICS", "ROOT", "check_id", "key", "all_vehicles", "alive", "alive_all", "vehicle_of", "topic_of"]

TOPICS = ("fix", "plan", "detections", "people", "crowds", "status", "truth", "sensor", "frame")
ROOT = "uvteam"


def check_id(kind: str, value: str) -> str:
    if not is_id(value):
        raise ConfigError("<ids>", kind, f"must be 1-32 characters of A-Z a-z 0-9 _ -, got {value!r}")
    return value


def key(team: str, vehicle: str, topic: str) -> str:
    if topic not in TOPICS:
        raise ValueError(f"unknown topic {topic!r}; known: {', '.join(TOPICS)}")
    return f"{ROOT}/{check_id('team', team)}/{check_id('vehicle', vehicle)}/{topic}"


def all_vehicles(team: str, topic: str) -> str:
    """Key expression for one topic of every vehicle in the team."""
    if topic not in TOPICS:
        raise ValueError(f"unknown topic {topic!r}")
    return f"{ROOT}/{check_id('team', team)}/*/{topic}"


def alive(team: str, vehicle: str) -> str:
    return f"{ROOT}/{check_id('team', team)}/{check_id('vehicle', vehicle)}/alive"


def alive_all(team: str) -> str:
    return f"{ROOT}/{check_id('team', team)}/*/alive"


def everything(team: str | None = None) -> str:
    return f"{ROOT}/**" if team is None else f"{ROOT}/{check_id('team', team)}/**"


def vehicle_of(k: str) -> str | None:
    parts = str(k).split("/")
    return parts[2] if len(parts) == 4 and parts[0] == ROOT else None


def topic_of(k: str) -> str | None:
    parts = str(k).split("/")
    return parts[3] if len(parts) == 4 and parts[0] == ROOT else None


__all__ += ["everything"]
