"""KML 2.2 and KMZ of the picture: for Google Earth (desktop, web, mobile) and other KML readers.

A Document with two Folders. "Crowds": per crowd track one Placemark with a ``gx:Track`` (one ``when``
and one ``gx:coord`` per frame it was seen in, clamped to the ground, so Google Earth's time slider
replays it), and for each crowd in the current snapshot one Placemark with its 95 % circle as a Polygon
(36 vertices, closed, counter-clockwise). "Vehicles": per vehicle a Placemark with a ``gx:Track`` at its
AMSL altitude (``altitudeMode`` absolute). KML coordinates are lon,lat[,alt] in WGS84 degrees; times are
ISO 8601 UTC. A KMZ is the same KML zipped as ``doc.kml``, the file a KMZ reader opens first.

Element order follows the OGC KML 2.2 schema and Google's gx extension (Placemark: name, description,
styleUrl, geometry; gx:Track: altitudeMode, when..., gx:coord...).
"""

from __future__ import annotations

import io
import xml.etree.ElementTree as ET
import zipfile
from typing import Mapping

from ._geometry import circle_ring, course_speed, iso8601, mgrs_or_empty
from .picture import CrowdSeen, Snapshot, TrackPoint

__all__ = ["KML_NS", "GX_NS", "document", "kmz"]

KML_NS = "http://www.opengis.net/kml/2.2"
GX_NS = "http://www.google.com/kml/ext/2.2"
_K, _G = f"{{{KML_NS}}}", f"{{{GX_NS}}}"
ET.register_namespace("", KML_NS)
ET.register_namespace("gx", GX_NS)

# KML colours are aabbggrr
_STYLES = {"crowd": ("ff1c1ce3", "501c1ce3", "http://maps.google.com/mapfiles/kml/shapes/target.png"),
           "vehicle": ("ffe39a1c", "50e39a1c", "http://maps.google.com/mapfiles/kml/shapes/cabs.png")}


def _sub(parent: ET.Element, tag: str, text: str | None = None, **attrib) -> ET.Element:
    e = ET.SubElement(parent, tag, attrib)
    if text is not None:
        e.text = text
    return e


def _style(doc: ET.Element, sid: str) -> None:
    line, poly, icon = _STYLES[sid]
    st = _sub(doc, _K + "Style", id=sid)
    ic = _sub(st, _K + "IconStyle")
    _sub(ic, _K + "color", line)
    _sub(_sub(ic, _K + "Icon"), _K + "href", icon)
    ls = _sub(st, _K + "LineStyle")
    _sub(ls, _K + "color", line)
    _sub(ls, _K + "width", "2")
    _sub(_sub(st, _K + "PolyStyle"), _K + "color", poly)


def _track(parent: ET.Element, points: tuple[TrackPoint, ...], absolute: bool) -> None:
    tr = _sub(parent, _G + "Track")
    _sub(tr, _K + "altitudeMode", "absolute" if absolute else "clampToGround")
    for p in points:
        _sub(tr, _K + "when", iso8601(p.stamp_s))
    for p in points:
        alt = p.alt_amsl_m if (absolute and p.alt_amsl_m is not None) else 0.0
        _sub(tr, _G + "coord", f"{p.lon_deg:.7f} {p.lat_deg:.7f} {alt:.2f}")


def _describe(c: CrowdSeen) -> str:
    cr = c.crowd
    course, speed = course_speed(cr.v_east_m_s, cr.v_north_m_s)
    return (f"crowd {cr.crowd_id} from {c.source} at {iso8601(c.stamp_s)}; "
            f"MGRS {mgrs_or_empty(cr.lat_deg, cr.lon_deg)}; "
            f"95 % radius {cr.radius95_m:.1f} m; quality {cr.quality}; speed {speed:.1f} m/s"
            + ("" if course is None else f" toward {course:.0f} deg")
            + (f"; unseen {cr.unseen_s:.1f} s: predicted" if cr.unseen_s > 0 else ""))


def document(snap: Snapshot, crowd_tracks: Mapping[str, tuple[TrackPoint, ...]],
             vehicle_tracks: Mapping[str, tuple[TrackPoint, ...]], name: str | None = None) -> str:
    """The KML text (UTF-8, with its XML declaration)."""
    root = ET.Element(_K + "kml")
    doc = _sub(root, _K + "Document")
    _sub(doc, _K + "name", name or f"uvteam {snap.team}")
    _sub(doc, _K + "description", f"crowds and vehicles of team {snap.team} up to {iso8601(snap.stamp_s)}"
         if snap.stamp_s > 0 else f"crowds and vehicles of team {snap.team}")
    for sid in _STYLES:
        _style(doc, sid)
    current = {c.uid: c for c in snap.crowds}
    crowds = _sub(doc, _K + "Folder")
    _sub(crowds, _K + "name", "Crowds")
    for uid, points in crowd_tracks.items():
        if not points:
            continue
        pm = _sub(crowds, _K + "Placemark", id=uid)
        _sub(pm, _K + "name", f"crowd {uid.rsplit('.', 1)[-1]}")
        if uid in current:
            _sub(pm, _K + "description", _describe(current[uid]))
        _sub(pm, _K + "styleUrl", "#crowd")
        _track(pm, points, absolute=False)
    for c in snap.crowds:
        ring = circle_ring(c.crowd.lat_deg, c.crowd.lon_deg, c.crowd.radius95_m)
        if not ring:
            continue
        pm = _sub(crowds, _K + "Placemark", id=f"{c.uid}.r95")
        _sub(pm, _K + "name", f"crowd {c.crowd.crowd_id} 95 %")
        _sub(pm, _K + "description", _describe(c))
        _sub(pm, _K + "styleUrl", "#crowd")
        poly = _sub(pm, _K + "Polygon")
        _sub(poly, _K + "altitudeMode", "clampToGround")
        lr = _sub(_sub(poly, _K + "outerBoundaryIs"), _K + "LinearRing")
        _sub(lr, _K + "coordinates", " ".join(f"{x:.7f},{y:.7f},0" for x, y in ring))
    vehicles = _sub(doc, _K + "Folder")
    _sub(vehicles, _K + "name", "Vehicles")
    roles = {v.fix.vehicle: v.role for v in snap.vehicles}
    for vehicle, points in vehicle_tracks.items():
        if not points:
            continue
        pm = _sub(vehicles, _K + "Placemark", id=f"uvteam.{snap.team}.{vehicle}")
        _sub(pm, _K + "name", vehicle)
        if roles.get(vehicle):
            _sub(pm, _K + "description", roles[vehicle])
        _sub(pm, _K + "styleUrl", "#vehicle")
        _track(pm, points, absolute=True)
    ET.indent(root, space=" ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def kmz(kml_text: str) -> bytes:
    """A KMZ archive holding ``kml_text`` as doc.kml (deflated; fixed timestamp, so equal input gives equal bytes)."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        info = zipfile.ZipInfo("doc.kml", date_time=(1980, 1, 1, 0, 0, 0))
        info.compress_type = zipfile.ZIP_DEFLATED
        z.writestr(info, kml_text.encode("utf-8"))
    return buf.getvalue()
