"""The project's vocabulary, defined once: every enumerated word a config, a scenario or a message may
carry. Configs and messages are checked against these at load or decode; code compares with them.

- ids (team, vehicle, UGV): 1-32 characters of [A-Za-z0-9_-], so no id can inject key-expression syntax;
- ``ROLES``: what a vehicle's service is; ``SERVICES``: what a status message may come from;
- ``DETECTORS``: how the UAV service finds what it reports ("pixels": its camera through the vision
  pipeline; "sim-sensor": the simulator's sensor model, for runs without pixels);
- ``IMAGE_COORDINATES``: which centre a landmark uses in the fit (the motion blob's or the roof label's);
- ``GIMBALS``: how the UAV camera is mounted ("stabilised": it looks down whatever the body does, and
  turns with the heading; "fixed": it tilts with the body);
- ``SOLVERS``: the landmark-to-blob assignment (optimal, or the paper's greedy heuristic);
- ``COLORS``: the roof-label colors the vision pipeline can find (:mod:`uvteam.vision.landmarks` holds
  their HSV ranges, keyed by these names);
- :class:`FitQuality`: how a crowd's transform was obtained; every estimate carries one.
"""

from __future__ import annotations

import enum
import re
from typing import Literal

__all__ = ["ID_PATTERN", "is_id", "ROLES", "Role", "SERVICES", "DETECTORS", "Detector", "IMAGE_COORDINATES",
           "ImageCoordinates", "SOLVERS", "Solver", "COLORS", "Color", "FitQuality", "check_choice", "GIMBALS", "Gimbal"]

ID_PATTERN = re.compile(r"^[A-Za-z0-9_-]{1,32}$")


def is_id(value: object) -> bool:
    return isinstance(value, str) and ID_PATTERN.fullmatch(value) is not None   # fullmatch: "$" would let "id\n" pass


Role = Literal["uav", "ugv", "localizer"]
ROLES: tuple[Role, ...] = ("uav", "ugv", "localizer")
SERVICES = ROLES + ("sim", "router", "ground")
Detector = Literal["pixels", "sim-sensor"]
DETECTORS: tuple[Detector, ...] = ("pixels", "sim-sensor")
ImageCoordinates = Literal["motion", "color"]
IMAGE_COORDINATES: tuple[ImageCoordinates, ...] = ("motion", "color")
Gimbal = Literal["stabilised", "fixed"]
GIMBALS: tuple[Gimbal, ...] = ("stabilised", "fixed")
Solver = Literal["optimal", "greedy"]
SOLVERS: tuple[Solver, ...] = ("optimal", "greedy")
Color = Literal["red", "yellow", "green", "cyan", "blue", "magenta"]
COLORS: tuple[Color, ...] = ("red", "yellow", "green", "cyan", "blue", "magenta")


class FitQuality(str, enum.Enum):
    EXACT = "exact"                  # n = 4, the system is square
    LEAST_SQUARES = "least_squares"  # n > 4, all landmarks used
    ROBUST = "robust"                # n >= 5, outlier landmarks named and left out
    SUSPECT = "suspect"              # n = 4 and the transform disagrees with what was known before (radius says so)
    HELD = "held"                    # too few landmarks this frame: an earlier transform reused
    POSE = "pose"                    # too few landmarks: placed by the camera's pose (attitude, height) alone
    FAILED = "failed"                # no usable transform


QUALITIES = tuple(q.value for q in FitQuality)
__all__ += ["QUALITIES"]


def check_choice(what: str, value: object, choices: tuple) -> str | None:
    """None when ``value`` is one of ``choices``, else the reason, naming them."""
    if value in choices:
        return None
    return f"{what} must be one of {', '.join(map(str, choices))}; got {value!r}"
