"""GeoJSON (RFC 7946) of the picture: for QGIS, geojson.io, Leaflet/OpenLayers, GDAL.

Each crowd is up to three Features sharing ``properties.uid`` and told apart by ``properties.kind``:
``"crowd"`` (Point at the estimate), ``"crowd_footprint"`` (Polygon: the convex hull of the image box's
corners mapped to the ground; left out when they span no area) and ``"crowd_r95"`` (Polygon: the 95 %
circle, 36 vertices). Each vehicle is one ``"vehicle"`` Point. Coordinates are [lon, lat] in WGS84
degrees, 7 decimals (1 cm); polygon rings are closed and their exterior is counter-clockwise (RFC 7946
3.1.6). Heights are left out (crowds are on the ground; a vehicle's AMSL altitude is a property, as RFC
7946 positions take height above the ellipsoid). A snapshot is one FeatureCollection with the foreign
member ``"uvteam": {"team", "stamp_s"}``; a live stream is the same Features one per line
(newline-delimited GeoJSON, GDAL's GeoJSONSeq).

Feature ids are strings, unique in a collection: ``<uid>`` for the crowd point, ``<uid>/footprint``,
``<uid>/r95``, and the vehicle uid.
"""

from __future__ import annotations

import json
from typing import Any, Iterable

from ._geometry import circle_ring, course_speed, hull_ring, iso8601, mgrs_or_empty
from .picture import CrowdSeen, Snapshot, VehicleSeen

__all__ = ["crowd_features", "vehicle_feature", "feature_collection", "dumps", "feature_lines"]

_DIGITS = 7


def _pos(lon_deg: float, lat_deg: float) -> list[float]:
    return [round(lon_deg, _DIGITS), round(lat_deg, _DIGITS)]


def _ring(ring: list[tuple[float, float]]) -> list[list[float]]:
    out = [_pos(x, y) for x, y in ring]
    out[-1] = out[0]                  # closed exactly, also after rounding
    return out


def crowd_features(c: CrowdSeen, circle_vertices: int = 36) -> list[dict[str, Any]]:
    """A crowd as its Point, footprint Polygon (if it spans an area) and 95 % circle Polygon (if r95 > 0)."""
    cr = c.crowd
    course, speed = course_speed(cr.v_east_m_s, cr.v_north_m_s)
    props = {"kind": "crowd", "uid": c.uid, "id": cr.crowd_id, "source": c.source, "stamp_s": c.stamp_s,
             "time": iso8601(c.stamp_s), "radius95_m": cr.radius95_m, "quality": cr.quality,
             "v_east_m_s": cr.v_east_m_s, "v_north_m_s": cr.v_north_m_s, "speed_m_s": round(speed, 3),
             "course_deg": None if course is None else round(course, 1), "mgrs": mgrs_or_empty(cr.lat_deg, cr.lon_deg),
             "n_outliers": cr.n_outliers, "unseen_s": cr.unseen_s}
    out = [{"type": "Feature", "id": c.uid, "geometry": {"type": "Point", "coordinates": _pos(cr.lon_deg, cr.lat_deg)},
            "properties": props}]
    hull = hull_ring(cr.footprint_lat_deg, cr.footprint_lon_deg)
    if hull:
        out.append({"type": "Feature", "id": f"{c.uid}/footprint",
                    "geometry": {"type": "Polygon", "coordinates": [_ring(hull)]},
                    "properties": {**props, "kind": "crowd_footprint"}})
    circle = circle_ring(cr.lat_deg, cr.lon_deg, cr.radius95_m, circle_vertices)
    if circle:
        out.append({"type": "Feature", "id": f"{c.uid}/r95",
                    "geometry": {"type": "Polygon", "coordinates": [_ring(circle)]},
                    "properties": {**props, "kind": "crowd_r95"}})
    return out


def vehicle_feature(v: VehicleSeen) -> dict[str, Any]:
    f = v.fix
    heading = getattr(f, "heading_deg", None)         # None = the autopilot does not know
    _, speed = course_speed(f.v_east_m_s, f.v_north_m_s)
    return {"type": "Feature", "id": v.uid, "geometry": {"type": "Point", "coordinates": _pos(f.lon_deg, f.lat_deg)},
            "properties": {"kind": "vehicle", "uid": v.uid, "vehicle": f.vehicle, "role": v.role, "stamp_s": f.stamp_s,
                           "time": iso8601(f.stamp_s), "alt_amsl_m": f.alt_amsl_m,
                           "heading_deg": None if heading is None else float(heading), "h_acc_m": f.h_acc_m,
                           "v_east_m_s": f.v_east_m_s, "v_north_m_s": f.v_north_m_s,
                           "speed_m_s": None if speed is None else round(speed, 3),
                           "mgrs": mgrs_or_empty(f.lat_deg, f.lon_deg)}}


def feature_collection(snap: Snapshot) -> dict[str, Any]:
    feats = [f for c in snap.crowds for f in crowd_features(c)] + [vehicle_feature(v) for v in snap.vehicles]
    return {"type": "FeatureCollection", "uvteam": {"team": snap.team, "stamp_s": snap.stamp_s}, "features": feats}


def dumps(obj: Any) -> str:
    """JSON text; refuses NaN and infinities (not JSON)."""
    return json.dumps(obj, separators=(",", ":"), allow_nan=False)


def feature_lines(features: Iterable[dict[str, Any]]) -> str:
    """Newline-delimited GeoJSON: one Feature per line, each line ending in "\\n"."""
    return "".join(dumps(f) + "\n" for f in features)
