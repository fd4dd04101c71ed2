"""Cursor-on-Target 2.0 events: for ATAK, WinTAK, iTAK and TAK Server.

One ``<event>`` per crowd and per vehicle, UTF-8 XML with its declaration, small enough for one UDP
datagram (about 700 bytes). Attributes (MITRE CoT Event schema 2.0, Event.xsd):

- ``uid``: stable per crowd track, ``uvteam.<team>.<source>.crowd.<crowd_id>``; per vehicle
  ``uvteam.<team>.<vehicle>``. TAK replaces the marker with the same uid.
- ``type``: a crowd is ``a-u-G`` by default: an atom (a-) of unknown affiliation (u) on the ground (G).
  The team detects moving groups of people; it does not know whether they are friendly, neutral or
  hostile, and calling them hostile (a-h-G) is a human's decision, not a detector's. No MIL-STD-2525
  function code is added: a crowd is not a military unit (G-U-...) or equipment (G-E-...). Configurable.
  Vehicles are friendly: a UGV ``a-f-G-E-V`` (ground equipment, vehicle), the UAV ``a-f-A`` (air), a
  vehicle whose role is not known yet ``a-f-G``.
- ``how``: a crowd is ``m-f``, machine "fused - corroborated from multiple sources": its position comes
  from the UAV's image through a homography fitted to several UGVs' GNSS fixes. Vehicles: ``m-g``
  (derived from a GPS receiver).
- ``time`` = ``start`` = the capture time of the frame (or fix); ``stale`` = start + ``stale_s``, which the
  bridge sets to a multiple of the tracking interval (default 5 x 1 s): a crowd not reported again by
  then fades from TAK maps.
- ``point``: ``lat``/``lon`` WGS84; ``hae`` 9999999.0 for crowds (height unknown; the TAK convention for
  unknown, PyTAK's DEFAULT_COT_VAL) and for vehicles (the fix is AMSL, not height above the ellipsoid);
  ``ce`` the circular 1-sigma error in metres, which Event.xsd defines as "the one sigma point for a
  zero mean normal (Gaussian) distribution": radius95_m / sqrt(2 ln 20) = 0.4085 radius95_m for crowds
  (see _geometry.sigma_from_radius95), h_acc_m (already 1-sigma) for vehicles; ``le`` 9999999.0 (no
  vertical error is known).
- ``detail``: ``contact callsign``, ``track course speed`` (course only when moving faster than
  0.1 m/s; else 0.0 with speed 0), ``remarks`` with the MGRS reference, radius95_m, quality and source.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from ._geometry import course_speed, iso8601, mgrs_or_empty, sigma_from_radius95
from .picture import CrowdSeen, VehicleSeen

__all__ = ["UNKNOWN", "CROWD_TYPE", "CROWD_HOW", "crowd_event", "vehicle_event", "vehicle_type"]

UNKNOWN = 9999999.0
CROWD_TYPE = "a-u-G"
CROWD_HOW = "m-f"
_VEHICLE_TYPES = {"ugv": "a-f-G-E-V", "uav": "a-f-A"}
_DECLARATION = '<?xml version="1.0" encoding="UTF-8" standalone="yes"?>'


def vehicle_type(role: str) -> str:
    return _VEHICLE_TYPES.get(role, "a-f-G")


def _event(uid: str, cot_type: str, how: str, stamp_s: float, stale_s: float, lat_deg: float, lon_deg: float,
           hae_m: float, ce_m: float, le_m: float, callsign: str, course_deg: float, speed_m_s: float,
           remarks: str) -> str:
    if not stale_s > 0.0:
        raise ValueError(f"stale_s must be > 0, got {stale_s!r}")
    t = iso8601(stamp_s)
    ev = ET.Element("event", {"version": "2.0", "uid": uid, "type": cot_type, "how": how, "time": t, "start": t,
                              "stale": iso8601(stamp_s + stale_s)})
    ET.SubElement(ev, "point", {"lat": f"{lat_deg:.7f}", "lon": f"{lon_deg:.7f}", "hae": f"{hae_m:.1f}",
                                "ce": f"{ce_m:.2f}", "le": f"{le_m:.1f}"})   # cm: an RTK fix is not 0.0
    detail = ET.SubElement(ev, "detail")
    ET.SubElement(detail, "contact", {"callsign": callsign})
    ET.SubElement(detail, "track", {"course": f"{course_deg:.1f}", "speed": f"{speed_m_s:.2f}"})
    ET.SubElement(detail, "remarks").text = remarks
    return _DECLARATION + ET.tostring(ev, encoding="unicode")


def crowd_event(c: CrowdSeen, stale_s: float, cot_type: str = CROWD_TYPE, how: str = CROWD_HOW) -> str:
    """One CoT event for a crowd; ``stale_s`` after its capture time it goes stale."""
    cr = c.crowd
    course, speed = course_speed(cr.v_east_m_s, cr.v_north_m_s)
    mgrs = mgrs_or_empty(cr.lat_deg, cr.lon_deg)
    remarks = (f"uvteam crowd {cr.crowd_id} from {c.source}: MGRS {mgrs or '-'}, 95 % radius {cr.radius95_m:.1f} m, "
               f"quality {cr.quality}, v_east {cr.v_east_m_s:+.2f} m/s, v_north {cr.v_north_m_s:+.2f} m/s"
               + (f", unseen {cr.unseen_s:.1f} s: predicted" if cr.unseen_s > 0 else ""))
    return _event(c.uid, cot_type, how, c.stamp_s, stale_s, cr.lat_deg, cr.lon_deg, UNKNOWN,
                  sigma_from_radius95(cr.radius95_m), UNKNOWN, f"crowd {cr.crowd_id}",
                  0.0 if course is None else course, speed if course is not None else 0.0, remarks)


def vehicle_event(v: VehicleSeen, stale_s: float) -> str:
    """One CoT event for a team vehicle (friendly); course from its velocity, else its heading, else 0."""
    f = v.fix
    course, speed = course_speed(f.v_east_m_s, f.v_north_m_s)
    heading = getattr(f, "heading_deg", None)
    if course is None:   # too slow to have a course, or its velocity unknown: the heading, at the speed known
        course, speed = (float(heading) if heading is not None else 0.0), speed or 0.0
    remarks = (f"uvteam {v.role or 'vehicle'} {f.vehicle}: MGRS {mgrs_or_empty(f.lat_deg, f.lon_deg) or '-'}, "
               f"alt {f.alt_amsl_m:.1f} m AMSL, heading {'unknown' if heading is None else f'{heading:.0f} deg'}")
    return _event(v.uid, vehicle_type(v.role), "m-g", f.stamp_s, stale_s, f.lat_deg, f.lon_deg, UNKNOWN,
                  f.h_acc_m, UNKNOWN, f.vehicle, course, speed, remarks)
