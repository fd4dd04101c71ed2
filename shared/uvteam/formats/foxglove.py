"""Foxglove's map messages, as JSON: a vehicle's fix as ``foxglove.LocationFix`` and a localizer's crowds
as ``foxglove.GeoJSON``. Pure: messages in, JSON-ready dicts out. ``uvteam record`` writes them on
channels of their own beside the raw payloads, so Foxglove's Map panel draws a recording as it is.

The schemas are the subset of Foxglove's own (``@foxglove/schemas``, jsonschema) that these messages
use; the tests validate the messages against Foxglove's published schemas.

- LocationFix: ``timestamp`` = the fix's capture time; ``frame_id`` = the vehicle; ``altitude`` = its
  AMSL altitude (LocationFix asks for metres; no geoid is applied); ``position_covariance`` = the
  horizontal 1-sigma accuracy squared on east and north, 0 up, typed APPROXIMATED; ``heading`` in
  radians clockwise from north and ``velocity`` (east, north, 0) only when the vehicle knows them;
  ``color`` one per vehicle (the UAV black).
- GeoJSON: ``{"geojson": <FeatureCollection text>}`` with each crowd's point, footprint and 95 % circle
  (:func:`uvteam.formats.geojson.crowd_features`, the same features ``uvteam bridge`` writes).
"""

from __future__ import annotations

import math
from typing import Any

from ..messages import Crowds, Fix
from .geojson import crowd_features, dumps
from .picture import CrowdSeen, crowd_uid

__all__ = ["LOCATION_FIX", "GEOJSON", "location_fix", "crowds_geojson", "timestamp", "SCHEMAS"]

LOCATION_FIX = "foxglove.LocationFix"
GEOJSON = "foxglove.GeoJSON"
_PALETTE = ((0.89, 0.10, 0.11), (0.18, 0.62, 0.25), (0.22, 0.49, 0.72), (0.79, 0.64, 0.0), (0.77, 0.11, 0.54),
            (0.0, 0.65, 0.72), (1.0, 0.5, 0.0), (0.42, 0.24, 0.60))
_TIME = {"type": "object", "title": "time", "properties": {"sec": {"type": "integer", "minimum": 0},
                                                           "nsec": {"type": "integer", "minimum": 0,
                                                                    "maximum": 999999999}}}
_VECTOR3 = {"title": "foxglove.Vector3", "type": "object", "required": ["x", "y", "z"],
            "properties": {"x": {"type": "number"}, "y": {"type": "number"}, "z": {"type": "number"}}}
_COLOR = {"title": "foxglove.Color", "type": "object", "required": ["r", "g", "b", "a"],
          "properties": {k: {"type": "number"} for k in "rgba"}}
SCHEMAS: dict[str, dict[str, Any]] = {
    LOCATION_FIX: {
        "title": LOCATION_FIX, "description": "A navigation satellite fix for any Global Navigation Satellite System",
        "type": "object",
        "properties": {
            "timestamp": _TIME, "frame_id": {"type": "string"}, "latitude": {"type": "number"},
            "longitude": {"type": "number"}, "altitude": {"type": "number"},
            "position_covariance": {"type": "array", "items": {"type": "number"}, "minItems": 9, "maxItems": 9},
            "position_covariance_type": {"title": "foxglove.PositionCovarianceType",
                                         "oneOf": [{"title": t, "const": i} for i, t in
                                                   enumerate(("UNKNOWN", "APPROXIMATED", "DIAGONAL_KNOWN", "KNOWN"))]},
            "heading": {"type": "number"}, "velocity": _VECTOR3, "color": _COLOR,
        },
    },
    GEOJSON: {"title": GEOJSON, "description": "GeoJSON data for annotating maps", "type": "object",
              "properties": {"geojson": {"type": "string"}}},
}


def timestamp(stamp_s: float) -> dict[str, int]:
    sec = math.floor(stamp_s)
    nsec = min(int(round((stamp_s - sec) * 1e9)), 999_999_999)
    return {"sec": int(sec), "nsec": nsec}


def _color(vehicle: str, role: str) -> dict[str, float]:
    if role == "uav":
        return {"r": 0.1, "g": 0.1, "b": 0.1, "a": 1.0}
    r, g, b = _PALETTE[sum(vehicle.encode()) % len(_PALETTE)]
    return {"r": r, "g": g, "b": b, "a": 1.0}


def location_fix(fix: Fix, role: str = "") -> dict[str, Any]:
    """A fix as a foxglove.LocationFix."""
    var = fix.h_acc_m ** 2
    out: dict[str, Any] = {
        "timestamp": timestamp(fix.stamp_s), "frame_id": fix.vehicle, "latitude": fix.lat_deg,
        "longitude": fix.lon_deg, "altitude": fix.alt_amsl_m,
        "position_covariance": [var, 0.0, 0.0, 0.0, var, 0.0, 0.0, 0.0, 0.0], "position_covariance_type": 1,
        "color": _color(fix.vehicle, role)}
    if fix.heading_deg is not None:
        out["heading"] = math.radians(fix.heading_deg)
    if fix.v_east_m_s is not None and fix.v_north_m_s is not None:
        out["velocity"] = {"x": fix.v_east_m_s, "y": fix.v_north_m_s, "z": 0.0}
    return out


def crowds_geojson(team: str, msg: Crowds) -> dict[str, Any]:
    """One frame's crowds as a foxglove.GeoJSON (a FeatureCollection, empty when there are none)."""
    feats = [f for c in msg.crowds
             for f in crowd_features(CrowdSeen(crowd_uid(team, msg.vehicle, c.crowd_id), team, msg.vehicle,
                                               msg.stamp_s, c))]
    return {"geojson": dumps({"type": "FeatureCollection", "features": feats})}
