"""What `uvteam map` draws, from bus messages: footprints, roles, alive/stale, crowds and their tracks."""

import json
import math
import sqlite3
from uvteam.io.files import tomllib  # tomli before Python 3.11
from dataclasses import replace
from fnmatch import fnmatch
from pathlib import Path

import cv2
import numpy as np
import pytest

from uvteam import keys
from uvteam.blobs import Blobs, Landmarks
from uvteam.bus import keyexpr_matches
from uvteam.errors import ConfigError
from uvteam.geo import LocalFrame
from uvteam.messages import Crowd, Crowds, Detections, Fix, Plan, Status, Waypoint
from uvteam_ground.map.server import STATIC_DIR, parse_hostport, subscriptions
from uvteam_ground.map.state import MapConfig, TeamView, camera_footprint_latlon, offset_latlon
from uvteam_ground.map.tiles import open_basemap

LAT0, LON0 = 31.4850, -111.5440
T0 = 1_800_000_000.0
REPO = Path(__file__).resolve().parents[2]


def _fix(vehicle, stamp_s, east_m=0.0, north_m=0.0, heading_deg=90.0, alt_amsl_m=1300.0):
    lat, lon = LocalFrame(LAT0, LON0).ground_to_wgs84(east_m, north_m)
    return Fix(vehicle, stamp_s, float(lat), float(lon), alt_amsl_m, heading_deg, 0.5, 1.0, 0.0)


def _crowd(cid, east_m=0.0, north_m=0.0, v=(1.0, 2.0), quality="exact"):
    lat, lon = (float(x) for x in LocalFrame(LAT0, LON0).ground_to_wgs84(east_m, north_m))
    return Crowd(cid, lat, lon, (lat + 1e-5, lat + 1e-5, lat - 1e-5, lat - 1e-5),
                 (lon - 1e-5, lon + 1e-5, lon + 1e-5, lon - 1e-5), v[0], v[1], 1.5, quality, 0)


def _local(lat, lon):
    e, n = LocalFrame(LAT0, LON0).wgs84_to_ground(lat, lon)
    return float(e), float(n)


K = lambda v, topic: keys.key("t", v, topic)   # noqa: E731


# -- the camera footprint ----------------------------------------------------------------------------
@pytest.mark.parametrize("yaw_deg, top_left_en", [
    (0.0, (-40.487, 22.774)),     # north-up: the image's top-left corner is north-west
    (90.0, (22.774, 40.487)),     # camera turned east: the image top points east, top-left is north-east
    (180.0, (40.487, -22.774)),   # facing south
    (-90.0, (-22.774, -40.487)),  # facing west
])
def test_footprint_corners(yaw_deg, top_left_en):
    # 50 m up, 78 deg across 1280 px: 80.97 m x 45.55 m on the ground
    corners = camera_footprint_latlon(LAT0, LON0, 50.0, 78.0, 1280, 720, yaw_deg)
    en = [_local(*c) for c in corners]
    assert en[0] == pytest.approx(top_left_en, abs=0.01)
    assert math.dist(en[0], en[1]) == pytest.approx(2 * 50 * math.tan(math.radians(39)), abs=0.01)  # image width
    assert math.dist(en[1], en[2]) == pytest.approx(2 * 50 * math.tan(math.radians(39)) * 720 / 1280, abs=0.01)
    assert np.mean(en, axis=0) == pytest.approx((0, 0), abs=1e-6)            # centred under the camera


@pytest.mark.parametrize("alt_agl_m", [0.0, -5.0, float("nan")])   # on the ground, below it, unknown
def test_footprint_needs_a_height(alt_agl_m):
    with pytest.raises(ValueError, match="alt_agl_m"):
        camera_footprint_latlon(LAT0, LON0, alt_agl_m, 78.0, 1280, 720)


def test_offset_latlon_is_metric():
    lat, lon = offset_latlon(LAT0, LON0, 30.0, -40.0)
    assert _local(lat, lon) == pytest.approx((30.0, -40.0), abs=0.005)


# -- vehicles ----------------------------------------------------------------------------------------
def _snap(view, now_s):
    snap = view.snapshot(now_s)
    json.dumps(snap)                                  # plain data only
    return snap, {v["id"]: v for v in snap["vehicles"]}


def test_roles_footprint_from_detections_and_from_fix():
    view = TeamView(MapConfig(team="t", ground_amsl_m=1250.0))
    view.on_fix(K("uav1", "fix"), _fix("uav1", T0, alt_amsl_m=1300.0, heading_deg=0.0), T0)
    view.on_fix(K("ugv1", "fix"), _fix("ugv1", T0, 10.0), T0)
    view.on_status(K("loc1", "status"), Status("loc1", "localizer", T0, "none", 0, 5), T0)
    _, v = _snap(view, T0 + 0.1)
    assert (v["uav1"]["role"], v["ugv1"]["role"], v["loc1"]["role"]) == ("uav", "ugv", "service")  # uav by its id
    assert v["uav1"]["footprint_source"] == "fix"          # 1300 - 1250 = 50 m over ground, 1280x720 by default
    width = math.dist(_local(*v["uav1"]["footprint"][0]), _local(*v["uav1"]["footprint"][1]))
    assert width == pytest.approx(80.97, abs=0.02)
    # the detector's own height above ground and image size win while they are fresh
    view.on_detections(K("uav1", "detections"), Detections("uav1", T0, 1, 640, 640, 25.0, 800.0, Landmarks(), Blobs.empty(), 0.5, 1.0, 1.5), T0)
    _, v = _snap(view, T0 + 0.1)
    fp = [_local(*c) for c in v["uav1"]["footprint"]]
    assert v["uav1"]["footprint_source"] == "detections"
    assert math.dist(fp[0], fp[1]) == pytest.approx(40.49, abs=0.02) and math.dist(fp[1], fp[2]) == pytest.approx(40.49, abs=0.02)
    # stale detections: back to the fix
    _, v = _snap(view, T0 + 10.0)
    assert v["uav1"]["footprint_source"] == "fix"


def test_no_footprint_without_a_height_and_the_publisher_of_detections_is_the_uav():
    view = TeamView(MapConfig(team="t"))                  # no ground height configured
    view.on_fix(K("hexa", "fix"), _fix("hexa", T0), T0)
    view.on_fix(K("rover", "fix"), _fix("rover", T0), T0)
    _, v = _snap(view, T0)
    assert v["hexa"]["role"] == "ugv" and "footprint" not in v["hexa"]   # nothing says it flies yet
    view.on_detections(K("hexa", "detections"), Detections("hexa", T0, 1, 1280, 720, 50.0, 800.0, Landmarks(), Blobs.empty(), 0.5, 1.0, 1.5), T0)
    _, v = _snap(view, T0)
    assert v["hexa"]["role"] == "uav" and v["rover"]["role"] == "ugv"
    assert v["hexa"]["footprint_source"] == "detections"
    _, v = _snap(view, T0 + 5.0)                          # detections stale, no ground height: no footprint
    assert v["hexa"]["footprint"] is None and v["hexa"]["footprint_source"] is None


def test_unknown_heading_draws_no_arrow():
    # Fix.heading_deg may become optional (None = unknown); the view must carry None, not 0
    view = TeamView(MapConfig(team="t", ground_amsl_m=1250.0))
    view.on_fix(K("ugv1", "fix"), _fix("ugv1", T0, heading_deg=None), T0)
    view.on_fix(K("uav1", "fix"), _fix("uav1", T0, heading_deg=None), T0)
    _, v = _snap(view, T0)
    assert v["ugv1"]["heading_deg"] is None and v["uav1"]["heading_deg"] is None
    assert v["uav1"]["footprint_yaw_known"] is False       # drawn north-up, dashed
    js = (STATIC_DIR / "map.js").read_text()
    assert "v.heading_deg == null" in js                  # the page draws a dot, no arrow, for None


@pytest.mark.parametrize("alive, age_s, stale", [
    (None, 0.5, False),   # the liveliness watcher has said nothing yet, fresh fix: not stale
    (True, 0.5, False),   # alive and fresh
    (True, 3.5, True),    # alive but the fix is older than stale_s = 3
    (False, 0.1, True),   # its token is gone: stale whatever the fix age
])
def test_stale_from_liveliness_and_fix_age(alive, age_s, stale):
    view = TeamView(MapConfig(team="t"))
    view.on_fix(K("ugv1", "fix"), _fix("ugv1", T0), T0)
    if alive is not None:
        view.on_alive(keys.alive("t", "ugv1"), alive, T0)
    _, v = _snap(view, T0 + age_s)
    assert v["ugv1"]["alive"] is alive and v["ugv1"]["stale"] is stale
    assert v["ugv1"]["age_s"] == pytest.approx(age_s, abs=0.01)


def test_trail_keeps_points_a_step_apart_and_plan_starts_at_the_vehicle():
    view = TeamView(MapConfig(team="t", trail_step_m=1.0, trail_points=5))
    for i in range(40):                                   # 0.3 m a fix: a trail point every 4th fix (1.2 m)
        view.on_fix(K("ugv1", "fix"), _fix("ugv1", T0 + i * 0.1, east_m=0.3 * i), T0 + i * 0.1)
    view.on_plan(K("ugv1", "plan"), Plan("ugv1", T0, (Waypoint(T0 + 5, LAT0 + 1e-4, LON0),)), T0 + 4)
    _, v = _snap(view, T0 + 4)
    trail = [_local(*p) for p in v["ugv1"]["trail"]]
    assert len(trail) == 5                                # the newest five
    assert [round(e, 2) for e, _ in trail] == [6.0, 7.2, 8.4, 9.6, 10.8]
    assert v["ugv1"]["plan"][0] == [v["ugv1"]["lat"], v["ugv1"]["lon"]] and len(v["ugv1"]["plan"]) == 2


# -- crowds ------------------------------------------------------------------------------------------
def test_crowds_track_mgrs_arrow_lost_and_dropped():
    view = TeamView(MapConfig(team="t", crowd_keep_s=10.0, arrow_s=5.0))
    k = K("loc1", "crowds")
    for i in range(5):
        view.on_crowds(k, Crowds("loc1", "uav1", T0 + i, "exact", ("ugv1",), (), (_crowd(3, i * 1.0, 0.0), _crowd(4, 50, 50))), T0 + i)
    snap, _ = _snap(view, T0 + 4.2)
    c3 = next(c for c in snap["crowds"] if c["id"] == 3)
    assert c3["source"] == "loc1" and not c3["lost"] and not c3["stale"]
    assert len(c3["track"]) == 5 and _local(*c3["track"][-1]) == pytest.approx((4.0, 0.0), abs=0.01)
    assert _local(*c3["arrow_tip"]) == pytest.approx((4.0 + 5.0, 10.0), abs=0.01)   # 5 s at (1, 2) m/s
    assert c3["mgrs"].startswith("12RVV") and len(c3["mgrs"]) == 15
    assert len(c3["footprint"]) == 4 and c3["quality"] == "exact" and c3["radius95_m"] == 1.5 and c3["unseen_s"] == 0.0
    assert snap["frames"]["loc1"]["quality"] == "exact"
    # crowd 4 is no longer reported: lost (drawn faded) for crowd_keep_s, then dropped
    view.on_crowds(k, Crowds("loc1", "uav1", T0 + 5, "exact", ("ugv1",), (), (_crowd(3, 5.0, 0.0),)), T0 + 5)
    snap, _ = _snap(view, T0 + 6)
    assert {c["id"]: c["lost"] for c in snap["crowds"]} == {3: False, 4: True}
    snap, _ = _snap(view, T0 + 16)
    assert [c["id"] for c in snap["crowds"]] == [3]
    assert snap["crowds"][0]["stale"]                     # 11 s without a crowds message


def test_standing_crowd_has_no_arrow():
    view = TeamView(MapConfig(team="t"))
    view.on_crowds(K("loc1", "crowds"), Crowds("loc1", "uav1", T0, "held", (), (), (_crowd(1, v=(0.0, 0.01)),)), T0)
    assert view.snapshot(T0)["crowds"][0]["arrow_tip"] is None


def test_changed_is_notified_and_version_counts():
    view = TeamView(MapConfig(team="t"))
    v0 = view.version
    view.on_alive(keys.alive("t", "ugv1"), True, T0)
    view.on_fix(K("ugv1", "fix"), _fix("ugv1", T0), T0)
    assert view.version == v0 + 2


@pytest.mark.parametrize("change, field", [
    ({"hfov_deg": 0.0}, "hfov_deg"),              # no field of view
    ({"hfov_deg": 180.0}, "hfov_deg"),            # a pinhole cannot see 180 deg
    ({"stale_s": 0.0}, "stale_s"),                # everything would be stale
    ({"footprint_yaw": "east"}, "footprint_yaw"), # not a mode
    ({"team": "a/b"}, "team"),                    # key-expression syntax in an id
    ({"origin": (95.0, 0.0)}, "origin"),          # beyond the pole
    ({"ground_amsl_m": float("nan")}, "ground_amsl_m"),
])
def test_config_errors_name_the_field(change, field):
    with pytest.raises(ConfigError, match=field):
        replace(MapConfig(team="t"), **change) if "team" not in change else MapConfig(**{"team": "t", **change})


# -- what the map subscribes to and serves --------------------------------------------------------------
def test_subscriptions_never_match_frames():
    exprs = [e for e, _ in subscriptions("demo")]
    for topic in ("fix", "crowds", "status", "plan", "detections"):
        assert any(keyexpr_matches(e, keys.key("demo", "uav1", topic)) for e in exprs), topic
    for topic in ("frame", "truth", "sensor", "people"):
        assert not any(keyexpr_matches(e, keys.key("demo", "uav1", topic)) for e in exprs), topic
    assert not any(keyexpr_matches(e, keys.key("other", "uav1", "fix")) for e in exprs)   # other teams


@pytest.mark.parametrize("text, hostport", [
    ("127.0.0.1:8770", ("127.0.0.1", 8770)),   # the default
    ("0.0.0.0:0", ("0.0.0.0", 0)),             # any address, any free port
    ("[::1]:9000", ("::1", 9000)),             # IPv6 in brackets
    ("localhost:80", ("localhost", 80)),       # a name
])
def test_parse_hostport(text, hostport):
    assert parse_hostport(text) == hostport


@pytest.mark.parametrize("text", ["8770", "127.0.0.1", ":8770", "127.0.0.1:99999"])  # no host, no port, too big
def test_parse_hostport_rejects(text):
    with pytest.raises(ConfigError, match="--http"):
        parse_hostport(text)


def test_static_files_are_package_data():
    """Every file the page needs matches pyproject's package-data globs, so `pip install .` ships it."""
    globs = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["uvteam_ground"]
    files = [p.relative_to(STATIC_DIR.parents[1]).as_posix() for p in STATIC_DIR.rglob("*") if p.is_file()]
    assert {"map/static/index.html", "map/static/map.js", "map/static/vendor/leaflet/leaflet.js",
            "map/static/vendor/leaflet/LICENSE"} <= set(files)
    missing = [f for f in files if not any(fnmatch(f, g) and f.count("/") == g.count("/") for g in globs)]
    assert not missing


# -- offline basemaps ---------------------------------------------------------------------------------
def _png(value: int) -> bytes:
    return cv2.imencode(".png", np.full((256, 256, 3), value, np.uint8))[1].tobytes()


def test_xyz_folder(tmp_path):
    for z, x, y in [(16, 12000, 26000), (17, 24001, 52001)]:
        (tmp_path / str(z) / str(x)).mkdir(parents=True)
        (tmp_path / str(z) / str(x) / f"{y}.png").write_bytes(_png(z))
    src = open_basemap(tmp_path)
    assert (src.info.fmt, src.info.min_zoom, src.info.max_zoom) == ("png", 16, 17)
    w, s, e, n = src.info.bounds                          # of the z 16 tile: 0.0055 deg across
    assert w < -111.0 and e - w == pytest.approx(360 / 2**16) and s < n
    assert src.tile(17, 24001, 52001) == _png(17)
    assert src.tile(17, 24001, 52002) is None             # missing tile


def test_mbtiles_flips_rows(tmp_path):
    f = tmp_path / "area.mbtiles"
    db = sqlite3.connect(f)
    db.executescript("CREATE TABLE metadata (name TEXT, value TEXT);"
                     "CREATE TABLE tiles (zoom_level INTEGER, tile_column INTEGER, tile_row INTEGER, tile_data BLOB);")
    db.executemany("INSERT INTO metadata VALUES (?, ?)", [("name", "sasabe"), ("format", "png"), ("minzoom", "2"),
                                                          ("maxzoom", "3"), ("bounds", "-111.6,31.4,-111.5,31.5")])
    db.execute("INSERT INTO tiles VALUES (3, 1, 6, ?)", (_png(9),))       # TMS row 6 at z 3 is XYZ row 1
    db.commit()
    db.close()
    src = open_basemap(f)
    assert (src.info.name, src.info.min_zoom, src.info.max_zoom) == ("sasabe", 2, 3)
    assert src.info.bounds == (-111.6, 31.4, -111.5, 31.5)
    assert src.tile(3, 1, 1) == _png(9) and src.tile(3, 1, 6) is None
    src.close()


@pytest.mark.parametrize("make, reason", [
    (lambda p: p / "missing", "no such file"),                                        # a typo
    (lambda p: (p / "empty").mkdir() or p / "empty", "no zoom folders"),              # an empty folder
    (lambda p: (p / "m.tif").write_bytes(b"II*\x00") and p / "m.tif", "GeoTIFF"),     # a GeoTIFF: says how to convert
    (lambda p: (p / "m.mbtiles").write_text("hello") and p / "m.mbtiles", "MBTiles"),  # not SQLite
])
def test_basemap_errors(tmp_path, make, reason):
    with pytest.raises(ConfigError, match=reason):
        open_basemap(make(tmp_path))
