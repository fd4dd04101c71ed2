"""`uvteam map` as an operator runs it: a real process on a router-less zenoh peer pair on loopback,
its HTTP server, and the page in headless Chromium drawing what the bus carries where it belongs."""

import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path

import cv2
import numpy as np
import pytest

from conftest import free_port
from uvteam import keys
from uvteam.blobs import Blobs, Landmarks
from uvteam.bus import BusConfig
from uvteam.geo import LocalFrame
from uvteam.io.zenoh_bus import ZenohBus
from uvteam.messages import Crowd, Crowds, Detections, Fix, Frame, Status

pytestmark = pytest.mark.integration
TEAM = "mapt"
LAT0, LON0 = 31.4850, -111.5440
CROWD = (31.48512, -111.54389)              # where crowd 7 stands
CHROMIUM = os.environ.get("UVTEAM_CHROMIUM", "/usr/bin/chromium")
ARTIFACTS = Path(__file__).resolve().parents[1] / "artifacts"
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def _en(east_m, north_m):
    lat, lon = LocalFrame(LAT0, LON0).ground_to_wgs84(east_m, north_m)
    return float(lat), float(lon)


@pytest.fixture
def team_bus():
    """One peer publishing a small team at 10 Hz: a UAV (fix + detections), two UGVs (ugv1 driving a
    circle, ugv2 parked, its liveliness token its own so the test can drop it), a localizer's crowd, and
    camera frames that the map must never pull."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    bus = ZenohBus.open(BusConfig(mode="peer", listen=(endpoint,)))
    stop = threading.Event()
    for v in ("uav1", "ugv1", "loc1"):
        bus.declare_alive(keys.alive(TEAM, v))
    ugv2_token = bus.session.liveliness().declare_token(keys.alive(TEAM, "ugv2"))
    lat_c, lon_c = CROWD
    fp_lat = (lat_c + 2e-5, lat_c + 2e-5, lat_c - 2e-5, lat_c - 2e-5)
    fp_lon = (lon_c - 2e-5, lon_c + 2e-5, lon_c + 2e-5, lon_c - 2e-5)
    crowd = Crowd(7, lat_c, lon_c, fp_lat, fp_lon, 1.5, 1.0, 3.0, "least_squares", 0)
    unseen = Crowd(9, lat_c + 1e-4, lon_c, (), (), 1.0, 0.0, 4.5, "least_squares", 0, 2.0)   # predicted for 2 s

    def pump():
        k = 0
        while not stop.is_set():
            now = time.time()
            a = 0.1 * k
            lat1, lon1 = _en(-15 + 6 * math.cos(a), 6 * math.sin(a))
            bus.publish(keys.key(TEAM, "ugv1", "fix"), Fix("ugv1", now, lat1, lon1, 1300.0, 45.0, 0.3))
            bus.publish(keys.key(TEAM, "ugv2", "fix"), Fix("ugv2", now, *_en(20, -10), 1300.0, 200.0, 0.3))
            bus.publish(keys.key(TEAM, "uav1", "fix"), Fix("uav1", now, *_en(0, 5), 1350.0, 0.0, 0.5))
            bus.publish(keys.key(TEAM, "uav1", "detections"), Detections("uav1", now, k, 1280, 720, 50.0, 800.0, Landmarks(), Blobs.empty(), 0.5, 1.0, 1.5))
            bus.publish(keys.key(TEAM, "loc1", "crowds"), Crowds("loc1", "uav1", now, "least_squares", ("ugv1", "ugv2"), (), (crowd, unseen)))
            bus.publish(keys.key(TEAM, "loc1", "status"), Status("loc1", "localizer", now, "none", 0, k, k, {"step_us_p50": 600.0}))
            bus.publish(keys.key(TEAM, "uav1", "frame"), Frame("uav1", now, k, 2, 1, "bgr8", b"\x00" * 6))
            k += 1
            stop.wait(0.1)

    th = threading.Thread(target=pump, daemon=True)
    th.start()
    yield {"endpoint": endpoint, "ugv2_token": ugv2_token}
    stop.set()
    th.join(timeout=2)
    try:
        ugv2_token.undeclare()
    except Exception:       # already undeclared by the test
        pass
    bus.close()


@pytest.fixture
def basemap(tmp_path):
    """An XYZ folder with one tile under the team (z 17), to check that tiles are served."""
    z = 17
    n = 2 ** z
    x = int((LON0 + 180) / 360 * n)
    y = int((1 - math.asinh(math.tan(math.radians(LAT0))) / math.pi) / 2 * n)
    d = tmp_path / "tiles" / str(z) / str(x)
    d.mkdir(parents=True)
    img = np.full((256, 256, 3), (200, 225, 235), np.uint8)
    cv2.putText(img, "basemap", (40, 130), cv2.FONT_HERSHEY_SIMPLEX, 1.0, (90, 90, 90), 2)
    (d / f"{y}.png").write_bytes(cv2.imencode(".png", img)[1].tobytes())
    return {"dir": tmp_path / "tiles", "z": z, "x": x, "y": y}


@pytest.fixture
def map_url(team_bus, basemap, tmp_path):
    port = free_port()
    log = open(tmp_path / "map.log", "w+")
    proc = subprocess.Popen([sys.executable, "-m", "uvteam", "map", "--team", TEAM, "--mode", "peer",
                             "--connect", team_bus["endpoint"], "--http", f"127.0.0.1:{port}",
                             "--basemap", str(basemap["dir"]), "--stale-s", "2"],
                            stdout=subprocess.PIPE, stderr=log, text=True, start_new_session=True)
    try:
        line = proc.stdout.readline()                          # "uvteam map: team mapt on http://..."
        if "http://" not in line:
            log.seek(0)
            pytest.fail(f"uvteam map did not start: {line!r}\n{log.read()}")
        yield line.split(" on ")[-1].strip()
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(timeout=5)
        proc.stdout.close()
        log.close()
    assert proc.returncode == 0, (tmp_path / "map.log").read_text()


def _get(url, host=None, timeout=5.0):
    req = urllib.request.Request(url, headers={"Host": host} if host else {})
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r:
            return r.status, r.headers.get("Content-Type", ""), r.read()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.headers.get("Content-Type", ""), exc.read()


def _wait_state(url, ok, timeout_s=15.0):
    end = time.monotonic() + timeout_s
    st = None
    while time.monotonic() < end:
        st = json.loads(_get(url + "state.json")[2])
        if ok(st):
            return st
        time.sleep(0.2)
    pytest.fail(f"the map's state never got there: {json.dumps(st)[:2000]}")


def test_server_serves_page_state_events_and_tiles(map_url, basemap):
    status, ctype, body = _get(map_url)
    assert status == 200 and ctype.startswith("text/html") and b"leaflet.js" in body
    status, _, body = _get(map_url + "static/vendor/leaflet/leaflet.js")
    assert status == 200 and b"Leaflet 1.9.4" in body                 # vendored: no internet needed
    assert _get(map_url + "static/../server.py")[0] == 404             # nothing outside static/
    assert _get(map_url + "static/%2e%2e/state.py")[0] == 404
    assert _get(map_url, host="evil.example:8770")[0] == 403           # DNS rebinding: loopback names only
    cfg = json.loads(_get(map_url + "config.json")[2])
    assert cfg["team"] == TEAM and cfg["basemaps"][0]["max_zoom"] == 17
    status, ctype, body = _get(map_url + cfg["basemaps"][0]["url"].format(z=basemap["z"], x=basemap["x"], y=basemap["y"]))
    assert status == 200 and ctype == "image/png" and body.startswith(b"\x89PNG")
    assert _get(map_url + "tiles/0/17/1/1.png")[0] == 404              # a tile the folder does not have

    # everything in: the crowd, four live vehicles and the UAV's footprint (its fix and a detections message)
    st = _wait_state(map_url, lambda s: s["crowds"] and len([v for v in s["vehicles"] if v.get("alive")]) >= 4
                     and any(v["id"] == "uav1" and v.get("footprint_source") for v in s["vehicles"]))
    c, predicted = st["crowds"]
    assert (c["id"], c["source"], c["quality"], c["unseen_s"]) == (7, "loc1", "least_squares", 0.0)
    assert (predicted["id"], predicted["unseen_s"]) == (9, 2.0)
    assert (c["lat"], c["lon"]) == pytest.approx(CROWD) and c["mgrs"].startswith("12RVV")
    v = {x["id"]: x for x in st["vehicles"]}
    assert (v["uav1"]["role"], v["ugv1"]["role"], v["loc1"]["role"]) == ("uav", "ugv", "service")
    assert v["uav1"]["footprint_source"] == "detections"
    assert v["loc1"]["status"]["metrics"] == {"step_us_p50": 600.0}
    assert st["bus"]["rejected"] == 0

    # server-sent events: the first event is the whole state
    with urllib.request.urlopen(map_url + "events", timeout=5) as r:
        assert r.headers["Content-Type"] == "text/event-stream"
        lines = []
        while not (lines and lines[-1] == b"\n" and any(x.startswith(b"data: ") for x in lines)):
            lines.append(r.readline())
    data = json.loads(next(x for x in lines if x.startswith(b"data: "))[6:])
    assert data["team"] == TEAM and data["crowds"][0]["id"] == 7


def _mercator_px(lat_deg, lon_deg, zoom):
    """Web Mercator pixel at a zoom (256 px tiles): written here, not asked of Leaflet."""
    s = 256.0 * 2.0 ** zoom
    siny = math.sin(math.radians(lat_deg))
    return (lon_deg + 180.0) / 360.0 * s, (0.5 - math.log((1 + siny) / (1 - siny)) / (4 * math.pi)) * s


def _expected_container_px(lat_deg, lon_deg, view):
    cx, cy = _mercator_px(view["center"][0], view["center"][1], view["zoom"])
    px, py = _mercator_px(lat_deg, lon_deg, view["zoom"])
    return px - cx + view["size"][0] / 2, py - cy + view["size"][1] / 2


_MEASURE = """() => {
  const m = uvmap.map, box = m.getContainer().getBoundingClientRect();
  const rect = (sel) => { const e = document.querySelector(sel); if (!e) return null;
    const r = e.getBoundingClientRect(); return {x: r.left - box.left + r.width / 2, y: r.top - box.top + r.height / 2, w: r.width, h: r.height}; };
  const c = m.getCenter(), s = m.getSize();
  const veh = Object.fromEntries(uvmap.last.vehicles.filter(v => v.lat != null).map(v => [v.id, {lat: v.lat, lon: v.lon}]));
  const crowd = uvmap.last.crowds[0];
  const leaflet = m.latLngToContainerPoint([crowd.lat, crowd.lon]);
  return {center: [c.lat, c.lng], zoom: m.getZoom(), size: [s.x, s.y], veh,
          crowd_centre: rect("path.crowd-centre.crowd-7"), crowd_r95: rect("path.crowd-r95.crowd-7"),
          leaflet_crowd: [leaflet.x, leaflet.y],
          ugv1: rect(".veh-ugv1"), ugv2: rect(".veh-ugv2"), uav1: rect(".veh-uav1"),
          ugv1_heading: (document.querySelector(".veh-ugv1 g.heading") || {getAttribute: () => null}).getAttribute("transform"),
          ugv2_class: (document.querySelector(".veh-ugv2") || {className: ""}).className,
          footprint: !!document.querySelector("path.uav-footprint"),
          velocity: !!document.querySelector("path.crowd-velocity.crowd-7"),
          list: document.getElementById("crowds").innerText, tiles: document.querySelectorAll(".leaflet-tile-loaded").length};
}"""


def _check_drawn_at_their_places(view):
    # the crowd's centre dot is where Web Mercator puts the published lat/lon (and where Leaflet says)
    ex, ey = _expected_container_px(*CROWD, view)
    assert view["crowd_centre"] is not None, "the crowd is not drawn"
    assert abs(view["crowd_centre"]["x"] - ex) <= 1.5 and abs(view["crowd_centre"]["y"] - ey) <= 1.5, (view, ex, ey)
    assert view["leaflet_crowd"] == pytest.approx([ex, ey], abs=1.0)
    # the 95 % circle around it, 3 m in radius at this zoom and latitude
    m_per_px = 2 * math.pi * 6378137.0 * math.cos(math.radians(CROWD[0])) / (256 * 2 ** view["zoom"])
    r95 = view["crowd_r95"]
    assert abs(r95["x"] - ex) <= 1.5 and abs(r95["y"] - ey) <= 1.5
    assert r95["w"] / 2 == pytest.approx(3.0 / m_per_px, abs=2.0)
    # each vehicle's icon is centred on its last fix as drawn
    for vid in ("ugv1", "ugv2", "uav1"):
        vx, vy = _expected_container_px(view["veh"][vid]["lat"], view["veh"][vid]["lon"], view)
        assert abs(view[vid]["x"] - vx) <= 1.5 and abs(view[vid]["y"] - vy) <= 1.5, (vid, view[vid], vx, vy)


def _wait_page(page, errors, js, timeout):
    try:
        page.wait_for_function(js, timeout=timeout)
    except Exception:
        ARTIFACTS.mkdir(exist_ok=True)
        page.screenshot(path=str(ARTIFACTS / "map-browser-failed.png"))
        seen = page.evaluate("() => JSON.stringify(window.uvmap && uvmap.last)")
        pytest.fail(f"the page never showed {js!r}; page errors {errors}; its last state {str(seen)[:3000]}")


def test_browser_draws_the_team_where_it_is(map_url, team_bus):
    if not Path(CHROMIUM).exists():
        pytest.skip(f"no Chromium at {CHROMIUM}: `apt-get install chromium` (make test does it when run as root) "
                    "or set UVTEAM_CHROMIUM to run the map's browser test")
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (in the test extras) drives Chromium")
    ARTIFACTS.mkdir(exist_ok=True)
    errors = []
    with sync_api.sync_playwright() as p:
        # a fresh temporary profile per launch (Playwright's own --user-data-dir); no browser download
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_FLAGS)
        try:
            page = browser.new_page(viewport={"width": 1200, "height": 800})
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(map_url)
            _wait_page(page, errors, "() => window.uvmap && uvmap.last && uvmap.last.crowds.length > 0 && "
                                   "uvmap.last.vehicles.filter(v => v.lat != null).length >= 3 && "
                                   "document.querySelector('path.crowd-centre.crowd-7')", 20_000)
            page.wait_for_timeout(600)                       # a few more updates: trails, auto-fit settled
            view = page.evaluate(_MEASURE)
            _check_drawn_at_their_places(view)
            assert view["ugv1_heading"] == "rotate(45 14 14)"     # heading arrow, 45 deg clockwise from north
            assert view["footprint"] and view["velocity"]
            assert "#7" in view["list"] and "12R VV" in view["list"] and "31.48512" in view["list"]  # side list
            assert "#9 (unseen 2.0 s)" in view["list"] and "#7 (unseen" not in view["list"]
            shot = ARTIFACTS / "map-browser.png"
            page.screenshot(path=str(shot))
            print(f"screenshot: {shot}")

            # somewhere else at another zoom, by hand: still where the projection says
            page.evaluate("() => { uvmap.userMoved = true; uvmap.map.setView([31.48505, -111.54395], 21); }")
            page.wait_for_timeout(400)
            view = page.evaluate(_MEASURE)
            assert view["zoom"] == 21
            _check_drawn_at_their_places(view)

            # ugv2's liveliness token goes away: drawn as lost (stale, name struck through)
            page.evaluate("() => uvmap.map.setView([31.48505, -111.54395], 19)")
            team_bus["ugv2_token"].undeclare()
            _wait_page(page, errors, "() => document.querySelector('.veh-ugv2.dead.stale')", 10_000)
            page.wait_for_timeout(300)
            page.screenshot(path=str(ARTIFACTS / "map-browser-ugv2-lost.png"))
            tiles = page.evaluate(_MEASURE)["tiles"]
        finally:
            browser.close()
    assert not errors, errors
    assert tiles >= 1                                        # the offline basemap tile is drawn
