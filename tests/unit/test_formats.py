"""uvteam.formats: each output read back by a parser that is not ours (geojson, xml.etree, zipfile,
pymavlink, csv, mgrs), with the geometry and the numbers checked against independent arithmetic."""

import csv
import io
import json
import math
import re
import zipfile
from datetime import datetime
from xml.etree import ElementTree as ET

import pytest
from scipy import stats

from uvteam.formats import Picture, adsb, cot, crowd_csv, geojson, kml
from uvteam.formats.picture import crowd_uid
from uvteam.messages import Crowd, Crowds, Fix, Status

geojson_pkg = pytest.importorskip("geojson")
mgrs_pkg = pytest.importorskip("mgrs")
from pymavlink.dialects.v20 import common as mavlink2  # noqa: E402

T0 = 1_790_000_000.0          # 2026-09-21
LAT, LON = 31.4851, -111.5441
KML = "{http://www.opengis.net/kml/2.2}"
GX = "{http://www.google.com/kml/ext/2.2}"


def _crowd(crowd_id, lat=LAT, lon=LON, r95=2.5, ve=1.2, vn=-0.4, half_deg=2e-5, quality="least_squares", unseen_s=0.0):
    # box corners in image order (x0y0, x1y0, x1y1, x0y1) with the image's y down: clockwise on the ground
    lats = (lat + half_deg, lat + half_deg, lat - half_deg, lat - half_deg)
    lons = (lon - half_deg, lon + half_deg, lon + half_deg, lon - half_deg)
    return Crowd(crowd_id, lat, lon, lats, lons, ve, vn, r95, quality, 0, unseen_s)


def _picture():
    p = Picture("demo", max_age_s=5.0)
    p.add_status(Status("ugv1", "ugv", T0, "up", 0, 1))
    still = _crowd(7, LAT + 1e-3, r95=0.0, ve=0.0, vn=0.0, half_deg=0.0, unseen_s=2.5)  # no area, no circle; unseen
    p.add_crowds(Crowds("loc1", "uav1", T0, "least_squares", ("ugv1",), (), (_crowd(3), still)))
    p.add_crowds(Crowds("loc1", "uav1", T0 + 1.0, "least_squares", ("ugv1",), (), (_crowd(3, LAT + 1e-5), still)))
    p.add_fix(Fix("ugv1", T0 + 0.5, LAT - 1e-3, LON, 1300.0, 90.0, 0.5, 1.0, 0.0))
    p.add_fix(Fix("uav1", T0 + 0.6, LAT, LON + 1e-3, 1350.0, None, 1.5))     # heading unknown (None)
    return p


def _signed_area(ring):
    return 0.5 * sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(ring, ring[1:]))


# ---------------------------------------------------------------- the picture

def test_picture_replaces_a_sources_crowds_and_keeps_tracks():
    p = _picture()
    snap = p.snapshot(T0 + 1.0)
    assert [c.uid for c in snap.crowds] == [crowd_uid("demo", "loc1", 3), crowd_uid("demo", "loc1", 7)]
    assert snap.crowds[0].crowd.lat_deg == LAT + 1e-5                     # the newer frame's
    assert len(p.crowd_tracks()[crowd_uid("demo", "loc1", 3)]) == 2
    assert [v.role for v in snap.vehicles] == ["", "ugv"]                 # uav1 sent no Status
    p.add_crowds(Crowds("loc1", "uav1", T0 + 2.0, "held", (), (), ()))            # a frame with no crowds: all gone
    assert p.snapshot(T0 + 2.0).crowds == ()
    assert len(p.crowd_tracks()) == 2                                     # the tracks stay


@pytest.mark.parametrize("stamp_s, now_s, n_crowds", [
    (T0 + 1.0, T0 + 1.0, 2),      # fresh
    (T0 + 1.0, T0 + 6.0, 2),      # exactly max_age_s old: kept
    (T0 + 1.0, T0 + 6.5, 0),      # older: the source went quiet, its crowds leave
])
def test_picture_ages_out_a_quiet_source(stamp_s, now_s, n_crowds):
    assert len(_picture().snapshot(now_s).crowds) == n_crowds


@pytest.mark.parametrize("period_s, steps_s, want_points", [
    (1.0, [0.0, 0.1, 0.5, 1.0, 1.9, 2.0], 3),    # one point a second: 0, 1.0, 2.0
    (0.0, [0.0, 0.1, 0.5, 1.0, 1.9, 2.0], 6),    # every frame
    (0.0, [0.0, 0.0, -1.0], 1),                  # the same frame twice, then an older one: kept once
])
def test_picture_track_period(period_s, steps_s, want_points):
    p = Picture("demo", track_period_s=period_s)
    for dt in steps_s:
        p.add_fix(Fix("ugv1", T0 + dt, LAT, LON, 0.0, 0.0, 1.0))
    assert len(p.vehicle_tracks()["ugv1"]) == want_points


def test_picture_ignores_out_of_order_messages():
    p = _picture()
    assert p.add_crowds(Crowds("loc1", "uav1", T0 - 5.0, "exact", (), (), (_crowd(99),))) == ()
    assert p.add_fix(Fix("ugv1", T0 - 5.0, 0.0, 0.0, 0.0, 0.0, 1.0)) is None
    assert {c.crowd.crowd_id for c in p.snapshot(T0 + 1.0).crowds} == {3, 7}


@pytest.mark.parametrize("kwargs", [
    {"max_age_s": 0.0},           # a picture that forgets at once
    {"max_track_points": 0},      # tracks with no room
    {"track_period_s": -1.0},     # a negative period
])
def test_picture_rejects_bad_settings(kwargs):
    with pytest.raises(ValueError, match=next(iter(kwargs))):
        Picture("demo", **kwargs)


# ---------------------------------------------------------------- GeoJSON

def test_geojson_snapshot_is_valid_rfc7946():
    fc = geojson.feature_collection(_picture().snapshot(T0 + 1.0))
    text = geojson.dumps(fc)
    obj = geojson_pkg.loads(text)                                  # the independent parser and validator
    assert obj.is_valid, obj.errors()
    kinds = [f["properties"]["kind"] for f in fc["features"]]
    # crowd 3: point, footprint, 95 % circle; crowd 7: point only (no area, r95 = 0); two vehicles
    assert kinds == ["crowd", "crowd_footprint", "crowd_r95", "crowd", "vehicle", "vehicle"]
    ids = [f["id"] for f in fc["features"]]
    assert len(set(ids)) == len(ids)
    for f in obj["features"]:
        assert geojson_pkg.GeoJSON.to_instance(f).is_valid
        if f["geometry"]["type"] == "Polygon":
            ring = f["geometry"]["coordinates"][0]
            assert ring[0] == ring[-1] and len(ring) >= 4           # closed linear ring
            assert _signed_area(ring) > 0.0                         # exterior counter-clockwise (RFC 7946 3.1.6)
            for lon, lat in ring:                                   # [lon, lat] order, near the crowd
                assert abs(lon - LON) < 1e-3 and abs(lat - LAT) < 1e-3
    point = fc["features"][0]
    assert point["geometry"]["coordinates"] == [round(LON, 7), round(LAT + 1e-5, 7)]
    props = point["properties"]
    assert props["mgrs"] == _ref_mgrs(LAT + 1e-5, LON)
    assert (props["id"], props["radius95_m"], props["quality"]) == (3, 2.5, "least_squares")
    assert (props["v_east_m_s"], props["v_north_m_s"]) == (1.2, -0.4)
    assert props["course_deg"] == pytest.approx(math.degrees(math.atan2(1.2, -0.4)), abs=0.05)   # 108.4
    assert props["unseen_s"] == 0.0
    assert [f["properties"]["unseen_s"] for f in fc["features"] if f["properties"].get("id") == 7] == [2.5]
    uav = fc["features"][4]["properties"]
    assert uav["vehicle"] == "uav1" and uav["heading_deg"] is None          # unknown heading -> null
    assert fc["features"][5]["properties"]["heading_deg"] == 90.0


def test_geojson_r95_circle_has_the_radius():
    c = _picture().snapshot(T0 + 1.0).crowds[0]
    ring = geojson.crowd_features(c)[2]["geometry"]["coordinates"][0]
    lat0 = math.radians(c.crowd.lat_deg)
    for lon, lat in ring:       # an independent small-distance formula (equirectangular, WGS84 radii)
        m_per_deg_lat = 111132.954 - 559.822 * math.cos(2 * lat0)
        m_per_deg_lon = 111412.84 * math.cos(lat0)
        d = math.hypot((lat - c.crowd.lat_deg) * m_per_deg_lat, (lon - c.crowd.lon_deg) * m_per_deg_lon)
        assert d == pytest.approx(2.5, abs=0.01)


def test_geojson_stream_lines_are_features():
    snap = _picture().snapshot(T0 + 1.0)
    text = geojson.feature_lines(f for c in snap.crowds for f in geojson.crowd_features(c))
    lines = text.splitlines()
    assert text.endswith("\n") and len(lines) == 4
    for line in lines:
        f = geojson_pkg.loads(line)
        assert f["type"] == "Feature" and f.is_valid


def test_geojson_refuses_nan():
    with pytest.raises(ValueError):
        geojson.dumps({"x": float("nan")})


# ---------------------------------------------------------------- KML / KMZ

def _kml_tree(text):
    assert text.startswith('<?xml version="1.0" encoding="UTF-8"?>')
    return ET.fromstring(text.encode("utf-8"))


def test_kml_document_structure():
    p = _picture()
    text = kml.document(p.snapshot(T0 + 1.0), p.crowd_tracks(), p.vehicle_tracks())
    root = _kml_tree(text)
    assert root.tag == KML + "kml"
    doc = root.find(KML + "Document")
    folders = doc.findall(KML + "Folder")
    assert [f.findtext(KML + "name") for f in folders] == ["Crowds", "Vehicles"]
    for st in doc.findall(KML + "Style"):
        assert re.fullmatch(r"[0-9a-f]{8}", st.find(KML + "LineStyle/" + KML + "color").text)   # aabbggrr
    crowd_tracks = [pm for pm in folders[0].findall(KML + "Placemark") if pm.find(GX + "Track") is not None]
    circles = [pm for pm in folders[0].findall(KML + "Placemark") if pm.find(KML + "Polygon") is not None]
    assert len(crowd_tracks) == 2 and len(circles) == 1               # crowd 7 has r95 = 0: no circle
    for pm in crowd_tracks + folders[1].findall(KML + "Placemark"):
        children = [c.tag for c in pm]
        assert children.index(KML + "name") < children.index(KML + "styleUrl") < children.index(GX + "Track")
        tr = pm.find(GX + "Track")
        tags = [c.tag for c in tr]
        whens, coords = tr.findall(KML + "when"), tr.findall(GX + "coord")
        assert tags == [KML + "altitudeMode"] + [KML + "when"] * len(whens) + [GX + "coord"] * len(coords)
        assert len(whens) == len(coords) >= 1
        stamps = [datetime.fromisoformat(w.text.replace("Z", "+00:00")).timestamp() for w in whens]
        assert stamps == sorted(stamps) and stamps[0] >= T0
        for c in coords:
            lon, lat, alt = map(float, c.text.split(" "))               # gx:coord is "lon lat alt"
            assert abs(lon - LON) < 2e-3 and abs(lat - LAT) < 2e-3
    track3 = crowd_tracks[0].find(GX + "Track")
    assert track3.findtext(KML + "altitudeMode") == "clampToGround" and len(track3.findall(GX + "coord")) == 2
    uav = folders[1].find(KML + "Placemark")
    assert uav.findtext(KML + "name") == "uav1"
    assert uav.find(GX + "Track").findtext(KML + "altitudeMode") == "absolute"
    assert uav.find(GX + "Track").findtext(GX + "coord").endswith(" 1350.00")
    ring_text = circles[0].find(".//" + KML + "LinearRing/" + KML + "coordinates").text.split()
    ring = [tuple(map(float, t.split(",")[:2])) for t in ring_text]      # KML coordinates are "lon,lat,alt"
    assert ring[0] == ring[-1] and _signed_area(ring) > 0.0


def test_kml_empty_picture_is_still_a_document():
    p = Picture("demo")
    root = _kml_tree(kml.document(p.snapshot(T0), {}, {}))
    folders = root.find(KML + "Document").findall(KML + "Folder")
    assert [f.findtext(KML + "name") for f in folders] == ["Crowds", "Vehicles"]


def test_kmz_holds_doc_kml():
    p = _picture()
    text = kml.document(p.snapshot(T0 + 1.0), p.crowd_tracks(), p.vehicle_tracks())
    data = kml.kmz(text)
    with zipfile.ZipFile(io.BytesIO(data)) as z:
        assert z.testzip() is None
        assert z.namelist() == ["doc.kml"]
        assert z.read("doc.kml").decode("utf-8") == text
    assert kml.kmz(text) == data                                          # deterministic


# ---------------------------------------------------------------- Cursor-on-Target

_ISO = re.compile(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(\.\d+)?Z")


def _check_event(text):
    """The required attributes and their ranges per MITRE's CoT Event.xsd (version 2.0)."""
    assert text.startswith("<?xml")
    ev = ET.fromstring(text.encode("utf-8"))
    assert ev.tag == "event"
    for a in ("version", "uid", "type", "time", "start", "stale", "how"):
        assert ev.get(a), a
    assert float(ev.get("version")) >= 2
    assert re.fullmatch(r"\w+(-\w+)*(;[^;]*)?", ev.get("type"))
    assert re.fullmatch(r"\w(-\w+)*", ev.get("how"))
    t = {}
    for a in ("time", "start", "stale"):
        assert _ISO.fullmatch(ev.get(a)), ev.get(a)
        t[a] = datetime.fromisoformat(ev.get(a).replace("Z", "+00:00")).timestamp()
    assert t["time"] <= t["start"] < t["stale"]
    pt = ev.find("point")
    vals = {a: float(pt.get(a)) for a in ("lat", "lon", "hae", "ce", "le")}
    assert -90 <= vals["lat"] <= 90 and -180 <= vals["lon"] <= 180 and vals["ce"] >= 0 and vals["le"] >= 0
    assert ev.find("detail") is not None
    return ev, t, vals


def test_cot_crowd_event():
    c = _picture().snapshot(T0 + 1.0).crowds[0]
    ev, t, pt = _check_event(cot.crowd_event(c, stale_s=5.0))
    assert (ev.get("type"), ev.get("how"), ev.get("uid")) == ("a-u-G", "m-f", "uvteam.demo.loc1.crowd.3")
    assert t["time"] == pytest.approx(T0 + 1.0, abs=1e-3) and t["stale"] - t["start"] == pytest.approx(5.0, abs=1e-3)
    # ce is the 1-sigma of the 2-D Gaussian whose 95 % circle is radius95_m: radius95 = Rayleigh.ppf(0.95) * sigma
    assert pt["ce"] == pytest.approx(2.5 / stats.rayleigh.ppf(0.95), abs=0.05)     # 1.02 m
    assert pt["le"] == 9999999.0 and pt["hae"] == 9999999.0
    assert (pt["lat"], pt["lon"]) == (pytest.approx(LAT + 1e-5, abs=1e-7), pytest.approx(LON, abs=1e-7))
    tr = ev.find("detail/track")
    assert float(tr.get("course")) == pytest.approx(108.4, abs=0.1)
    assert float(tr.get("speed")) == pytest.approx(math.hypot(1.2, 0.4), abs=0.01)
    assert ev.find("detail/contact").get("callsign") == "crowd 3"
    assert _ref_mgrs(LAT + 1e-5, LON) in ev.findtext("detail/remarks") and "unseen" not in ev.findtext("detail/remarks")
    assert len(cot.crowd_event(c, 5.0).encode()) < 1400                   # one unfragmented UDP datagram
    predicted = ET.fromstring(cot.crowd_event(_picture().snapshot(T0 + 1.0).crowds[1], 5.0))   # crowd 7, unseen 2.5 s
    assert predicted.findtext("detail/remarks").endswith("unseen 2.5 s: predicted")


@pytest.mark.parametrize("vehicle, want_type, want_course", [
    ("ugv1", "a-f-G-E-V", 90.0),    # a UGV (its Status said so), moving east
    ("uav1", "a-f-G", 0.0),         # role not known yet; heading None and not moving: course 0
])
def test_cot_vehicle_event(vehicle, want_type, want_course):
    v = next(v for v in _picture().snapshot(T0 + 1.0).vehicles if v.fix.vehicle == vehicle)
    ev, _, pt = _check_event(cot.vehicle_event(v, stale_s=10.0))
    assert (ev.get("type"), ev.get("how")) == (want_type, "m-g")
    assert pt["ce"] == v.fix.h_acc_m
    assert float(ev.find("detail/track").get("course")) == want_course


def test_cot_vehicle_ce_keeps_an_rtk_fix_above_zero():
    # A 2 cm RTK fix once went out as ce="0.0": a perfect position, which no receiver has.
    p = Picture("demo", max_age_s=5.0)
    p.add_fix(Fix("ugv1", T0, LAT, LON, 1300.0, 90.0, 0.02, 0.0, 0.0))
    _, _, pt = _check_event(cot.vehicle_event(p.snapshot(T0).vehicles[0], stale_s=10.0))
    assert pt["ce"] == 0.02


def test_cot_rejects_a_stale_time_not_after_start():
    with pytest.raises(ValueError, match="stale_s"):
        cot.crowd_event(_picture().snapshot(T0 + 1.0).crowds[0], stale_s=0.0)


# ---------------------------------------------------------------- MAVLink ADSB_VEHICLE

def _decode(frames):
    parser = mavlink2.MAVLink(None)
    out = []
    for f in frames:
        out += parser.parse_buffer(f) or []
    return out


def test_adsb_frames_decode_with_pymavlink():
    snap = _picture().snapshot(T0 + 1.0)
    enc = adsb.AdsbEncoder(sysid=42, compid=191)
    frames = [enc.heartbeat()] + enc.crowds(snap, now_s=T0 + 3.0)
    msgs = _decode(frames)
    assert [m.get_type() for m in msgs] == ["HEARTBEAT", "ADSB_VEHICLE", "ADSB_VEHICLE"]
    assert all(m.get_srcSystem() == 42 and m.get_srcComponent() == 191 for m in msgs)
    assert [m.get_seq() for m in msgs] == [0, 1, 2]
    assert all(f[0] == 0xFD for f in frames)                              # MAVLink 2
    hb, a3, a7 = msgs
    assert hb.type == mavlink2.MAV_TYPE_ONBOARD_CONTROLLER and hb.autopilot == mavlink2.MAV_AUTOPILOT_INVALID
    assert a3.lat == round((LAT + 1e-5) * 1e7) and a3.lon == round(LON * 1e7)
    assert a3.callsign == "CR3" and a3.tslc == 2
    assert a3.flags & mavlink2.ADSB_FLAGS_VALID_COORDS and a3.flags & mavlink2.ADSB_FLAGS_VALID_HEADING
    assert not a3.flags & mavlink2.ADSB_FLAGS_VALID_ALTITUDE
    assert a3.heading == 10843 and a3.hor_velocity == 126                 # 108.43 deg, 1.26 m/s
    assert not a7.flags & mavlink2.ADSB_FLAGS_VALID_HEADING               # crowd 7 stands still
    assert a3.ICAO_address != a7.ICAO_address and a3.ICAO_address >> 20 == 0xF
    again = _decode(adsb.AdsbEncoder(sysid=42).crowds(snap, now_s=T0 + 3.0))
    assert [m.ICAO_address for m in again] == [a3.ICAO_address, a7.ICAO_address]   # stable per crowd track


def test_adsb_heartbeat_as_autopilot_component_is_a_vehicle():
    hb = _decode([adsb.AdsbEncoder(sysid=42, compid=1).heartbeat()])[0]
    assert hb.type == mavlink2.MAV_TYPE_GENERIC                          # QGC makes a vehicle of compid 1 only


@pytest.mark.parametrize("kwargs", [
    {"sysid": 0},              # 0 is broadcast, not a sender
    {"compid": 256},           # beyond 8 bits
    {"icao_base": 1 << 24},    # beyond 24 bits
])
def test_adsb_rejects_bad_ids(kwargs):
    with pytest.raises(ValueError, match=next(iter(kwargs))):
        adsb.AdsbEncoder(**kwargs)


# ---------------------------------------------------------------- CSV

def _ref_mgrs(lat, lon):
    out = mgrs_pkg.MGRS().toMGRS(lat, lon, MGRSPrecision=5)
    return out.decode() if isinstance(out, bytes) else out


def test_csv_reads_back_with_mgrs():
    snap = _picture().snapshot(T0 + 1.0)
    text = crowd_csv.HEADER + crowd_csv.rows(snap.crowds)
    rows = list(csv.DictReader(io.StringIO(text)))
    assert list(rows[0]) == ["stamp_s", "crowd_id", "lat_deg", "lon_deg", "mgrs", "radius95_m", "quality",
                             "v_east_m_s", "v_north_m_s", "unseen_s"]
    assert len(rows) == 2 and [r["unseen_s"] for r in rows] == ["0.00", "2.50"]   # seen; predicted
    for r, c in zip(rows, snap.crowds):
        assert int(r["crowd_id"]) == c.crowd.crowd_id and float(r["stamp_s"]) == pytest.approx(c.stamp_s)
        assert float(r["lat_deg"]) == pytest.approx(c.crowd.lat_deg, abs=1e-7)
        assert r["mgrs"] == _ref_mgrs(float(r["lat_deg"]), float(r["lon_deg"]))
        assert float(r["radius95_m"]) == c.crowd.radius95_m and r["quality"] == c.crowd.quality
    assert crowd_csv.rows([]) == ""


def test_json_of_a_snapshot_with_no_crowds():
    fc = geojson.feature_collection(Picture("demo").snapshot(T0))
    assert json.loads(geojson.dumps(fc)) == {"type": "FeatureCollection", "uvteam": {"team": "demo", "stamp_s": 0.0},
                                             "features": []}
    assert geojson_pkg.loads(geojson.dumps(fc)).is_valid
