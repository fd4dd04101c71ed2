"""`uvteam bridge` as a real process against zenoh on loopback: the test publishes Status, Fix and Crowds
messages, and reads back every output with a parser that is not the bridge's own: the CoT datagram on
a loopback UDP socket (xml.etree), the MAVLink datagrams on another (pymavlink), and the GeoJSON
(geojson package), NDJSON, KML (xml.etree), KMZ (zipfile) and CSV (csv + mgrs) files."""

import csv
import io
import json
import math
import signal
import socket
import subprocess
import sys
import threading
import time
import zipfile
from xml.etree import ElementTree as ET

import pytest

from uvteam import keys
from uvteam.bus import BusConfig
from uvteam.io.zenoh_bus import ZenohBus
from uvteam.messages import Crowd, Crowds, Fix, Status

geojson_pkg = pytest.importorskip("geojson")
mgrs_pkg = pytest.importorskip("mgrs")
from pymavlink.dialects.v20 import common as mavlink2  # noqa: E402

pytestmark = pytest.mark.integration
TEAM = "brt"
LAT, LON = 31.4851, -111.5441
KML = "{http://www.opengis.net/kml/2.2}"
GX = "{http://www.google.com/kml/ext/2.2}"


def _udp_socket():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    s.settimeout(0.2)
    return s


def _crowd(k: int) -> Crowd:
    lat = LAT + 1e-6 * k                       # walking north at about 0.55 m/s (5 frames a second)
    d = 2e-5
    return Crowd(3, lat, LON, (lat + d, lat + d, lat - d, lat - d), (LON - d, LON + d, LON + d, LON - d),
                 0.0, 0.55, 2.45, "least_squares", 0)


@pytest.fixture
def team_bus(tcp_port):
    endpoint = f"tcp/127.0.0.1:{tcp_port}"
    bus = ZenohBus.open(BusConfig(mode="peer", listen=(endpoint,)))
    stop = threading.Event()

    def pump():
        k = 0
        while not stop.is_set():
            now = time.time()
            bus.publish(keys.key(TEAM, "ugv1", "status"), Status("ugv1", "ugv", now, "up", 0, k))
            bus.publish(keys.key(TEAM, "ugv1", "fix"), Fix("ugv1", now - 0.1, LAT - 1e-3, LON, 1300.0, 45.0, 0.4,
                                                           0.5, 0.5))
            bus.publish(keys.key(TEAM, "loc1", "crowds"), Crowds("loc1", "uav1", now - 0.2, "least_squares", ("ugv1",), (),
                                                                 (_crowd(k),)))
            k += 1
            stop.wait(0.2)

    th = threading.Thread(target=pump, daemon=True)
    th.start()
    yield endpoint
    stop.set()
    th.join(timeout=2)
    bus.close()


def _wait_for(pred, sock, timeout_s=20.0):
    """Datagrams from ``sock`` until ``pred(datagram)`` says it has seen enough."""
    t_end = time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        try:
            data, _ = sock.recvfrom(65535)
        except socket.timeout:
            continue
        if pred(data):
            return True
    return False


def test_bridge_end_to_end(team_bus, tmp_path):
    cot_sock, mav_sock = _udp_socket(), _udp_socket()
    out = {name: tmp_path / name for name in ("crowds.geojson", "stream.ndjson", "crowds.kml", "crowds.kmz",
                                              "crowds.csv")}
    cmd = [sys.executable, "-m", "uvteam", "bridge", "--team", TEAM, "--connect", team_bus,
           "--geojson", str(out["crowds.geojson"]), "--geojson-stream", str(out["stream.ndjson"]),
           "--kml", str(out["crowds.kml"]), "--kmz", str(out["crowds.kmz"]), "--csv", str(out["crowds.csv"]),
           "--cot", f"udp://127.0.0.1:{cot_sock.getsockname()[1]}", "--cot-period-s", "0",
           "--mavlink", f"udpout:127.0.0.1:{mav_sock.getsockname()[1]}", "--mavlink-sysid", "42",
           "--mavlink-rate-hz", "5", "--kml-period-s", "1", "--track-period-s", "0.1"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        events = {}

        def cot_seen(data):
            # the bridge may join between a Status and a Fix: a fix can come before the vehicle's role,
            # so wait for the event that carries the role (a bridge that never took the Status times out)
            ev = ET.fromstring(data)
            events[ev.get("uid")] = ev
            ugv = events.get("uvteam.brt.ugv1")
            return "uvteam.brt.loc1.crowd.3" in events and ugv is not None and ugv.get("type") != "a-f-G"

        assert _wait_for(cot_seen, cot_sock), f"no CoT events; stderr:\n{proc.stderr.read() if proc.poll() else ''}"
        crowd_ev = events["uvteam.brt.loc1.crowd.3"]
        assert (crowd_ev.get("type"), crowd_ev.get("how")) == ("a-u-G", "m-f")
        pt = crowd_ev.find("point")
        assert abs(float(pt.get("lat")) - LAT) < 1e-3 and float(pt.get("lon")) == pytest.approx(LON, abs=1e-7)
        assert float(pt.get("ce")) == pytest.approx(1.0, abs=0.05)         # 2.45 m at 95 % -> 1.0 m 1-sigma
        assert float(pt.get("le")) == 9999999.0
        assert events["uvteam.brt.ugv1"].get("type") == "a-f-G-E-V"        # the role came from its Status

        parser = mavlink2.MAVLink(None)
        mav = {}

        def mav_seen(data):
            for m in parser.parse_buffer(data) or []:
                mav.setdefault(m.get_type(), m)
                assert m.get_srcSystem() == 42
            return {"HEARTBEAT", "ADSB_VEHICLE"} <= set(mav)

        assert _wait_for(mav_seen, mav_sock), "no MAVLink ADSB_VEHICLE"
        a = mav["ADSB_VEHICLE"]
        assert a.callsign == "CR3" and abs(a.lat * 1e-7 - LAT) < 1e-3 and a.lon == round(LON * 1e7)
        assert a.flags & mavlink2.ADSB_FLAGS_VALID_COORDS and a.heading == 0 and a.hor_velocity == 55   # north

        time.sleep(2.0)                     # a few more frames, and a periodic KML write while running
        assert out["crowds.kml"].exists()
        proc.send_signal(signal.SIGTERM)
        _, stderr = proc.communicate(timeout=20)
        assert proc.returncode == 0, stderr
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate(timeout=10)
        cot_sock.close()
        mav_sock.close()

    fc = geojson_pkg.loads(out["crowds.geojson"].read_text())
    assert fc.is_valid and fc["uvteam"]["team"] == TEAM
    kinds = sorted(f["properties"]["kind"] for f in fc["features"])
    assert kinds == ["crowd", "crowd_footprint", "crowd_r95", "vehicle"]
    crowd = next(f for f in fc["features"] if f["properties"]["kind"] == "crowd")
    assert crowd["properties"]["mgrs"] == _ref_mgrs(crowd["geometry"]["coordinates"][1],
                                                    crowd["geometry"]["coordinates"][0])
    lines = out["stream.ndjson"].read_text().splitlines()
    assert len(lines) >= 10 and all(geojson_pkg.loads(x).is_valid for x in lines)
    assert {json.loads(x)["properties"]["kind"] for x in lines} == {"crowd", "crowd_footprint", "crowd_r95", "vehicle"}

    root = ET.fromstring(out["crowds.kml"].read_bytes())
    folders = root.find(KML + "Document").findall(KML + "Folder")
    track = folders[0].find(KML + "Placemark/" + GX + "Track")
    coords = track.findall(GX + "coord")
    assert len(coords) == len(track.findall(KML + "when")) >= 5
    lats = [float(c.text.split()[1]) for c in coords]
    assert lats == sorted(lats) and lats[-1] > lats[0]                  # the crowd's walk north, in order
    assert folders[1].find(KML + "Placemark").findtext(KML + "name") == "ugv1"
    with zipfile.ZipFile(out["crowds.kmz"]) as z:
        assert z.namelist() == ["doc.kml"]
        ET.fromstring(z.read("doc.kml"))

    rows = list(csv.DictReader(io.StringIO(out["crowds.csv"].read_text())))
    assert len(rows) >= 5 and all(r["crowd_id"] == "3" for r in rows)
    for r in rows[:5]:
        assert r["mgrs"] == _ref_mgrs(float(r["lat_deg"]), float(r["lon_deg"]))
        assert math.isclose(float(r["radius95_m"]), 2.45)


def _ref_mgrs(lat, lon):
    s = mgrs_pkg.MGRS().toMGRS(lat, lon, MGRSPrecision=5)
    return s.decode() if isinstance(s, bytes) else s


def test_bridge_refuses_a_bad_output_url():
    r = subprocess.run([sys.executable, "-m", "uvteam", "bridge", "--team", TEAM, "--cot", "http://x:1"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "udp://HOST:PORT" in r.stderr


def test_bridge_refuses_to_append_to_a_csv_of_other_columns(tmp_path):
    old = tmp_path / "crowds.csv"
    old.write_text("stamp_s,crowd_id,lat_deg,lon_deg,mgrs,radius95_m,quality,v_east_m_s,v_north_m_s\r\n1.0,3,31,-111,,1,exact,0,0\r\n")
    r = subprocess.run([sys.executable, "-m", "uvteam", "bridge", "--team", TEAM, "--csv", str(old)],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "give a new file" in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert old.read_text().count("\n") == 2         # untouched


def test_bridge_cot_to_a_tak_server_over_tcp(team_bus):
    """--cot tcp://HOST:PORT: a stream of <event> documents on one connection, as a TAK server's plain
    streaming input takes them; the test's listener stands in for the server."""
    srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    srv.bind(("127.0.0.1", 0))
    srv.listen(1)
    srv.settimeout(30)
    proc = subprocess.Popen([sys.executable, "-m", "uvteam", "bridge", "--team", TEAM, "--connect", team_bus,
                             "--cot", f"tcp://127.0.0.1:{srv.getsockname()[1]}", "--cot-no-vehicles"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        conn, _ = srv.accept()
        conn.settimeout(1.0)
        buf = b""
        t_end = time.monotonic() + 20
        while buf.count(b"</event>") < 2 and time.monotonic() < t_end:
            try:
                buf += conn.recv(65536)
            except socket.timeout:
                pass
        conn.close()
        docs = [d + b"</event>" for d in buf.split(b"</event>")[:-1]]
        assert len(docs) >= 2                       # one a second (--cot-period-s 1), one document each
        for d in docs:
            ev = ET.fromstring(d.strip())
            assert ev.get("uid") == "uvteam.brt.loc1.crowd.3" and ev.get("type") == "a-u-G"
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate(timeout=10)
        srv.close()
    assert proc.returncode == 0


def test_cot_multicast_stays_on_this_host():
    """The TAK multicast group with TTL 0 from the loopback interface: delivered to a member on this host
    (IP_MULTICAST_LOOP), never onto a network. Skipped where loopback takes no multicast."""
    from uvteam_ground.bridge import CotSender

    group = "239.2.3.1"
    r = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    r.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    r.bind((group, 0))
    r.settimeout(2.0)
    try:
        membership = socket.inet_aton(group) + socket.inet_aton("127.0.0.1")
        r.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, membership)
    except OSError as exc:
        r.close()
        pytest.skip(f"no multicast on loopback here: {exc}")
    sender = CotSender(f"udp://{group}:{r.getsockname()[1]}", ttl=0, iface="127.0.0.1")
    try:
        sender.send('<?xml version="1.0"?><event version="2.0" uid="t" type="a-u-G" how="m-f"/>')
        data, src = r.recvfrom(65535)
        assert ET.fromstring(data).get("uid") == "t" and src[0] == "127.0.0.1"
        assert sender.sent == 1
    finally:
        sender.close()
        r.close()
