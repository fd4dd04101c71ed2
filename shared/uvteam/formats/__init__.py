"""What operators' tools read: the team's picture as GeoJSON, KML/KMZ, Cursor-on-Target, MAVLink
ADSB_VEHICLE and CSV. Pure converters: messages (or a :class:`Snapshot` of them) in, text or bytes out;
no sockets, files or clocks (``uvteam bridge`` in services/uvteam_ground/bridge.py does the I/O).

    picture = Picture("demo")                       # the bus messages, kept as crowds, vehicles and tracks
    picture.add_crowds(crowds_msg); picture.add_fix(fix_msg)
    snap = picture.snapshot(now_s)
    geojson.dumps(geojson.feature_collection(snap))          # RFC 7946 FeatureCollection
    kml.document(snap, picture.crowd_tracks(), picture.vehicle_tracks())   # KML 2.2 with gx:Track
    cot.crowd_event(snap.crowds[0], stale_s=5.0)               # one CoT <event>
    adsb.AdsbEncoder(sysid=1).crowds(snap, now_s)              # MAVLink 2 ADSB_VEHICLE datagram bytes
    crowd_csv.HEADER + crowd_csv.rows(snap.crowds)             # CSV with MGRS

Mapping of every field, and how each file was checked, in docs/formats.md.
"""

from . import adsb, cot, crowd_csv, geojson, kml
from ..mgrs import latlon_to_mgrs
from .picture import CrowdSeen, Picture, Snapshot, TrackPoint, VehicleSeen

__all__ = ["Picture", "Snapshot", "CrowdSeen", "VehicleSeen", "TrackPoint", "latlon_to_mgrs",
           "geojson", "kml", "cot", "adsb", "crowd_csv"]
