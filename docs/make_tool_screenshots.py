"""Open what `uvteam bridge` writes in the real programs it is meant for, and keep the evidence in
docs/tools/ (docs/formats.md, "Opened in the tools", says what each one showed).

One short `uvteam demo` on loopback, with `uvteam bridge` connected to its router, writing GeoJSON, KML,
KMZ and CSV, sending MAVLink to MAVProxy and Cursor-on-Target to a PyTAK receiver (both on 127.0.0.1).
Then:

- QGIS 3 (PyQGIS, headless) loads the GeoJSON (point and polygon sublayers), the KML, the KMZ and the
  CSV (delimited-text layer, X = lon_deg, Y = lat_deg) and renders a print layout to
  docs/tools/qgis-bridge-outputs.png;
- GDAL's `ogrinfo` reads the same files; its summary goes to docs/tools/ogrinfo.txt;
- MAVProxy (a MAVLink ground station) receives the ADSB_VEHICLE traffic; its console (`watch
  ADSB_VEHICLE`, `adsb status`, `status ADSB_VEHICLE`) goes to docs/tools/mavproxy-adsb.txt; its `map`
  module (wxPython, on a virtual X display: Xvfb) draws the same traffic, captured with Pillow's
  ImageGrab to docs/tools/mavproxy-map.png. No internet here, so the map tiles are MAVProxy's
  "Unavailable" placeholders. MAVProxy's adsb module labels a vehicle with its callsign only once it has
  its own vehicle's GLOBAL_POSITION_INT (in the field, the autopilot's); there is no MAVLink autopilot
  on this link in the demo, so this script stands in for it: it relays the UGV positions the bridge
  wrote to the GeoJSON as HEARTBEAT (MAV_TYPE_GROUND_ROVER) + GLOBAL_POSITION_INT, ugv<n> as system
  id n (the bridge's own ADSB_VEHICLE and HEARTBEAT are sent with system id 1, component 191);
- PyTAK (with takproto, which turns CoT XML into TAK Protocol protobuf) receives the CoT datagrams;
  what it parsed goes to docs/tools/pytak-cot.txt.

None of these programs is a dependency of uvteam. Install them on the side (Debian 12, as root):

    apt-get install -y qgis python3-qgis gdal-bin
    apt-get install -y xvfb python3-wxgtk4.0        # X server for MAVProxy's map, and Debian's wxPython
    /usr/bin/python3 -m venv --system-site-packages /tmp/mavproxy-venv   # so it sees Debian's wx
    /tmp/mavproxy-venv/bin/pip install MAVProxy     # MAVProxy 1.8.75, with pymavlink; Pillow for ImageGrab
    python3 -m venv /tmp/pytak-venv && /tmp/pytak-venv/bin/pip install pytak takproto

and run, from the repository root:

    .venv/bin/python docs/make_tool_screenshots.py [--duration 30] [--out docs/tools]

A missing program is reported and its part skipped (no Xvfb, or no wx for the MAVProxy venv's Python:
no map, the console part still runs). The script calls itself with Debian's
/usr/bin/python3 for the QGIS part (python3-qgis is built for it) and with the PyTAK venv's Python for
the CoT receiver, so this file imports only the standard library at the top.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
TEAM = "demo"           # the team id `uvteam demo` uses


def _free_port(kind: int = socket.SOCK_DGRAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# --------------------------------------------------------------------------------------------- run

def run(args: argparse.Namespace) -> int:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="uvteam-tools-"))
    files = {k: work / f"crowds.{k}" for k in ("geojson", "kml", "kmz", "csv")}
    uvteam = [sys.executable, "-m", "uvteam"]
    mav_port, cot_port = _free_port(), _free_port()
    nice = ["nice", "-n", "10"]
    procs: list[subprocess.Popen] = []

    mavproxy = shutil.which("mavproxy.py", path=f"{args.mavproxy_venv}/bin")
    mp_py = str(Path(args.mavproxy_venv) / "bin" / "python")
    mp = mp_log = display = relay = None
    if mavproxy:
        display = _xvfb(mp_py, procs)
        mp_log = open(work / "mavproxy.txt", "w")
        # --target-system 1: MAVProxy hands a module only the packets of its target system, which it
        # otherwise learns from an autopilot's HEARTBEAT (there is none here; in the field the bridge
        # sends with the autopilot's system id, 1 by default, exactly as for QGC)
        mp = subprocess.Popen([*nice, mavproxy, f"--master=udpin:127.0.0.1:{mav_port}", "--nowait",
                               "--target-system", "1", "--state-basedir", str(work),
                               "--default-modules", "adsb,map" if display else "adsb"],
                              stdin=subprocess.PIPE, stdout=mp_log, stderr=subprocess.STDOUT, text=True,
                              cwd=work, start_new_session=True, env=_mp_env(display, work))
        procs.append(mp)
        if display:
            relay = subprocess.Popen([*nice, mp_py, __file__, "--ugv-relay", str(mav_port), "--seconds",
                                      str(args.duration + 2), "--geojson", str(files["geojson"])],
                                     start_new_session=True)
            procs.append(relay)
    else:
        print(f"no MAVProxy in {args.mavproxy_venv}: the MAVLink part is skipped", file=sys.stderr)

    pytak_py = Path(args.pytak_venv) / "bin" / "python"
    cot = None
    if pytak_py.exists():
        cot = subprocess.Popen([*nice, str(pytak_py), __file__, "--cot-receive", str(cot_port),
                                "--seconds", str(args.duration + 5), "--cot-out", str(work / "pytak-cot.txt")],
                               start_new_session=True)
        procs.append(cot)
    else:
        print(f"no PyTAK venv at {args.pytak_venv}: the CoT part is skipped", file=sys.stderr)

    demo = subprocess.Popen([*nice, *uvteam, "demo", "--duration", str(args.duration), "--quiet", "--no-map"],
                            stdout=subprocess.PIPE, text=True, start_new_session=True)
    procs.append(demo)
    try:
        seen = []
        while not (m := re.search(r"router (tcp/\S+)", seen[-1] if seen else "")):
            line = demo.stdout.readline()
            if not line:
                raise RuntimeError("uvteam demo did not start:\n" + "".join(seen))
            seen.append(line)
        endpoint = m.group(1)
        print(f"demo router {endpoint}; outputs in {work}", flush=True)
        bridge = subprocess.Popen(
            [*nice, *uvteam, "bridge", "--team", TEAM, "--mode", "client", "--connect", endpoint,
             "--geojson", str(files["geojson"]), "--kml", str(files["kml"]), "--kmz", str(files["kmz"]),
             "--kml-period-s", "2", "--csv", str(files["csv"]),
             "--cot", f"udp://127.0.0.1:{cot_port}", "--mavlink", f"udpout:127.0.0.1:{mav_port}",
             "--duration", str(args.duration + 2)], start_new_session=True)
        procs.append(bridge)
        if mp is not None:
            _drive_mavproxy(mp, watch_at_s=args.duration * 0.6, display=display, py=mp_py,
                            geojson=files["geojson"], png=out / "mavproxy-map.png")
        demo_out = demo.communicate(timeout=args.duration + 120)[0]
        print(demo_out[-1500:], flush=True)
        bridge.wait(timeout=30)
        if cot is not None:
            cot.wait(timeout=30)
    finally:
        for p in procs:
            if p.poll() is None:
                p.terminate()
                try:
                    p.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    p.kill()
        if mp_log is not None:
            mp_log.close()

    if mp is not None:
        _keep(work / "mavproxy.txt", out / "mavproxy-adsb.txt", "MAVProxy console, receiving `uvteam bridge "
              f"--mavlink udpout:127.0.0.1:{mav_port}` (the MAVProxy side: --master=udpin:127.0.0.1:{mav_port})")
    if cot is not None:
        _keep(work / "pytak-cot.txt", out / "pytak-cot.txt", None)
    _ogrinfo(files, out / "ogrinfo.txt")
    _qgis(files, out / "qgis-bridge-outputs.png")
    print(f"done: {out}")
    return 0


def _xvfb(mp_py: str, procs: list) -> str | None:
    """A virtual X display for MAVProxy's map (wxPython), or None (reported) when there is no Xvfb or no
    wx for the MAVProxy venv's Python."""
    xvfb = shutil.which("Xvfb")
    if not xvfb:
        print("no Xvfb (apt-get install xvfb): MAVProxy's map is skipped", file=sys.stderr)
        return None
    if subprocess.run([mp_py, "-c", "import wx, PIL.ImageGrab"], capture_output=True).returncode != 0:
        print(f"no wxPython/Pillow for {mp_py} (apt-get install python3-wxgtk4.0 and a venv with "
              "--system-site-packages): MAVProxy's map is skipped", file=sys.stderr)
        return None
    r, w = os.pipe()
    x = subprocess.Popen([xvfb, "-displayfd", str(w), "-screen", "0", "1024x768x24", "-nolisten", "tcp", "-noreset"],
                         pass_fds=(w,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    os.close(w)
    procs.append(x)
    with os.fdopen(r) as f:
        number = f.readline().strip()
    if not number:
        print("Xvfb did not start: MAVProxy's map is skipped", file=sys.stderr)
        return None
    return f":{number}"


def _mp_env(display: str | None, work: Path) -> dict:
    env = dict(os.environ, PYTHONUNBUFFERED="1", HOME=str(work))   # HOME: the map's .tilecache
    if display:
        # offline: the tile downloader fails at once on a closed local port instead of waiting on DNS
        env.update(DISPLAY=display, http_proxy="http://127.0.0.1:9", https_proxy="http://127.0.0.1:9",
                   HTTP_PROXY="http://127.0.0.1:9", HTTPS_PROXY="http://127.0.0.1:9", NO_AT_BRIDGE="1")
    return env


def _area(geojson: Path) -> tuple[float, float]:
    """The mean position of the points in the bridge's GeoJSON (the demo's area when not yet written)."""
    import json  # noqa: PLC0415
    try:
        pts = [f["geometry"]["coordinates"] for f in json.loads(geojson.read_text())["features"]
               if f["geometry"]["type"] == "Point"]
    except (OSError, ValueError, KeyError):
        pts = []
    if not pts:
        return 31.4852, -111.5437
    return sum(p[1] for p in pts) / len(pts), sum(p[0] for p in pts) / len(pts)


def _drive_mavproxy(mp: subprocess.Popen, watch_at_s: float, display: str | None = None, py: str = "",
                    geojson: Path | None = None, png: Path | None = None) -> None:
    """Type commands into MAVProxy's console while the crowds are live (and set up, then capture, its map)."""
    def typed(line: str) -> None:
        mp.stdin.write(line + "\n")
        mp.stdin.flush()

    def script() -> None:
        if display:
            time.sleep(max(0.0, watch_at_s - 6))
            lat, lon = _area(geojson)
            typed("map follow 0")                  # it follows our vehicle (the relayed ugv1) otherwise
            typed("map zoom 70")                   # ground width of the window, m
            typed(f"map center {lat:.6f} {lon:.6f}")
            time.sleep(6)
        else:
            time.sleep(watch_at_s)
        typed("watch ADSB_VEHICLE")
        time.sleep(2.5)
        typed("watch")
        typed("adsb status")
        typed("status ADSB_VEHICLE")
        typed("status HEARTBEAT")
        typed("link")
        time.sleep(1.0)
        if display:
            grab = ("import sys; from PIL import ImageGrab; im = ImageGrab.grab(xdisplay=sys.argv[1]); "
                    "im = im.crop(im.convert('L').getbbox() or (0, 0) + im.size); im.save(sys.argv[2]); "
                    "print('wrote', sys.argv[2], im.size)")
            r = subprocess.run([py, "-c", grab, display, str(png)], capture_output=True, text=True)
            print((r.stdout + r.stderr).strip(), flush=True)
        mp.stdin.close()

    threading.Thread(target=script, daemon=True).start()


def _keep(src: Path, dst: Path, header: str | None) -> None:
    text = src.read_text(errors="replace") if src.exists() else "(nothing was written)\n"
    text = re.sub(r"\x1b\[[0-9;]*[A-Za-z]", "", text)      # terminal colours
    lines = text.splitlines()
    if len(lines) > 200:                                   # keep the file small: head and tail
        lines = lines[:120] + [f"... ({len(lines) - 200} lines left out) ..."] + lines[-80:]
    dst.write_text((f"# {header}\n" if header else "") + "\n".join(lines) + "\n")
    print(f"wrote {dst}")


def _ogrinfo(files: dict[str, Path], dst: Path) -> None:
    """`ogrinfo -so -al` per file (the SRS WKT left out), and the geometry types GDAL read, counted with
    GDAL's SQLite SQL dialect."""
    ogrinfo = shutil.which("ogrinfo")
    if not ogrinfo:
        print("no ogrinfo (apt-get install gdal-bin): skipped", file=sys.stderr)
        return
    version = subprocess.run([ogrinfo, "--version"], capture_output=True, text=True).stdout.strip()
    parts = [f"# GDAL's ogrinfo ({version}) on the files `uvteam bridge` wrote in one demo run\n"]
    csv_oo = ["-oo", "X_POSSIBLE_NAMES=lon_deg", "-oo", "Y_POSSIBLE_NAMES=lat_deg", "-oo", "AUTODETECT_TYPE=YES"]
    for kind, path in files.items():
        oo = csv_oo if kind == "csv" else []
        cmd = [ogrinfo, "-ro", "-so", "-al", *oo, str(path)]
        r = subprocess.run(cmd, capture_output=True, text=True)
        text, kept, in_wkt = (r.stdout + r.stderr).splitlines(), [], False
        for ln in text:                                   # drop the multi-line SRS WKT, keep its ID
            if ln.startswith("Layer SRS WKT:"):
                in_wkt = True
                continue
            if in_wkt:
                if ln.startswith("    ID["):
                    kept.append("Layer SRS: " + ln.strip().rstrip("]").replace("ID[", "").replace('"', ""))
                if not ln.startswith((" ", "GEOGCRS")):
                    in_wkt = False
                else:
                    continue
            kept.append(ln)
        parts.append(f"$ ogrinfo {' '.join(cmd[1:-1])} {path.name}\n" + "\n".join(kept) + "\n")
        layers = re.findall(r"^Layer name: (.+)$", r.stdout, re.M)
        for layer in layers:
            group = '"kind", ' if kind == "geojson" else ""
            sql = (f"SELECT {group}GeometryType(geometry) AS geometry_type, COUNT(*) AS n, "
                   "SUM(ST_NumPoints(geometry)) AS line_vertices, "
                   "MIN(MbrMinX(geometry)) AS lon_min, MAX(MbrMaxX(geometry)) AS lon_max, "
                   "MIN(MbrMinY(geometry)) AS lat_min, MAX(MbrMaxY(geometry)) AS lat_max "
                   f'FROM "{layer}" GROUP BY {group}geometry_type')
            q = subprocess.run([ogrinfo, "-ro", "-q", *oo, "-dialect", "SQLite", "-sql", sql, str(path)],
                               capture_output=True, text=True)
            rows = re.findall(r"^  (\w+) \(\w+\) = (.*)$", q.stdout, re.M)
            table, row = [], []
            for name, value in rows:
                if value != "(null)":
                    row.append(f"{name}={value}")
                if name == "lat_max":
                    table.append("  " + ", ".join(row))
                    row = []
            parts.append(f"$ ogrinfo -ro -q -dialect SQLite -sql '{sql}' {path.name}\n" + "\n".join(table)
                         + ("\n" + q.stderr.strip() if q.stderr.strip() else "") + "\n")
    dst.write_text("\n".join(parts))
    print(f"wrote {dst}")


def _qgis(files: dict[str, Path], png: Path) -> None:
    py = "/usr/bin/python3"
    probe = subprocess.run([py, "-c", "import qgis.core"], capture_output=True)
    if probe.returncode != 0:
        print("no PyQGIS for /usr/bin/python3 (apt-get install qgis python3-qgis): skipped", file=sys.stderr)
        return
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen", XDG_RUNTIME_DIR=tempfile.mkdtemp())
    env.pop("PYTHONPATH", None)
    subprocess.run(["nice", "-n", "10", py, __file__, "--qgis-render", str(png),
                    *(f"{k}={v}" for k, v in files.items())], env=env, check=True)


# ------------------------------------------------------------------------------- CoT receiver (PyTAK)

def cot_receive(port: int, seconds: float, out: str) -> int:
    """Receive CoT datagrams with PyTAK's own UDP reader; with TAK_PROTO=1, PyTAK's RXWorker hands each
    one to takproto, which parses the XML into a TAK Protocol v1 TakMessage (protobuf)."""
    import asyncio  # noqa: PLC0415
    from configparser import ConfigParser  # noqa: PLC0415

    import warnings  # noqa: PLC0415

    warnings.filterwarnings("ignore", message=".*package is required")   # TLS/HTTP extras, not used here
    import pytak  # noqa: PLC0415
    from takproto.proto import TakMessage  # noqa: PLC0415

    seen: dict[str, object] = {}
    counts = {"datagrams": 0, "parsed": 0, "failed": 0}

    class Receiver(pytak.RXWorker):
        async def handle_data(self, data):   # not used: run_once puts onto the queue
            pass

    async def main() -> None:
        cp = ConfigParser()
        cp["rx"] = {"COT_URL": f"udp+ro://127.0.0.1:{port}", "TAK_PROTO": "1"}
        cfg = cp["rx"]
        reader, _ = await pytak.protocol_factory(cfg)
        q: asyncio.Queue = asyncio.Queue()
        rx = Receiver(q, cfg, reader)
        task = asyncio.create_task(rx.run())
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            try:
                msg = await asyncio.wait_for(q.get(), timeout=0.5)
            except asyncio.TimeoutError:
                continue
            counts["datagrams"] += 1
            if isinstance(msg, TakMessage) and msg.cotEvent.uid:
                counts["parsed"] += 1
                seen[msg.cotEvent.uid] = msg
            else:
                counts["failed"] += 1
        task.cancel()

    asyncio.run(main())
    from importlib.metadata import version  # noqa: PLC0415

    lines = [f"# PyTAK {version('pytak')} (udp+ro://127.0.0.1:{port}, TAK_PROTO=1) with takproto {version('takproto')}: "
             f"{counts['datagrams']} CoT datagrams from `uvteam bridge --cot udp://127.0.0.1:{port}`, "
             f"{counts['parsed']} parsed into TAK Protocol v1 TakMessage, {counts['failed']} not",
             f"# the last event of each of the {len(seen)} uids, as takproto's protobuf fields:",
             f"{'uid':<34} {'type':<10} {'how':<4} {'callsign':<10} {'lat':>11} {'lon':>12} {'ce':>6} "
             f"{'speed':>5} {'course':>6} {'stale-start s':>13}"]
    for uid, m in sorted(seen.items()):
        e = m.cotEvent
        lines.append(f"{uid:<34} {e.type:<10} {e.how:<4} {e.detail.contact.callsign:<10} {e.lat:11.7f} "
                     f"{e.lon:12.7f} {e.ce:6.2f} {e.detail.track.speed:5.2f} {e.detail.track.course:6.1f} "
                     f"{(e.staleTime - e.startTime) / 1000:13.1f}")
    if seen:
        lines += ["# one of them in full (protobuf text format):", str(next(iter(seen.values()))).rstrip()]
    Path(out).write_text("\n".join(lines) + "\n")
    return 0 if counts["parsed"] else 1


# ---------------------------------------------------------------- UGV telemetry stand-in (pymavlink)

def ugv_relay(port: int, seconds: float, geojson: str) -> int:
    """Stand in for the UGVs' autopilots on MAVProxy's link: twice a second, the UGV positions the bridge
    last wrote to its GeoJSON, sent as HEARTBEAT (MAV_TYPE_GROUND_ROVER) and GLOBAL_POSITION_INT, ugv<n>
    from system id n, component 1 (MAVProxy's adsb module labels traffic only once it has one)."""
    import json  # noqa: PLC0415

    from pymavlink import mavutil  # noqa: PLC0415

    links: dict[int, object] = {}
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        time.sleep(0.5)
        try:
            feats = json.loads(Path(geojson).read_text())["features"]
        except (OSError, ValueError, KeyError):
            continue
        for f in feats:
            p = f.get("properties", {})
            m = re.fullmatch(r"ugv(\d+)", str(p.get("vehicle", "")))
            if p.get("kind") != "vehicle" or not m or f["geometry"]["type"] != "Point":
                continue
            n = int(m.group(1))
            if n not in links:
                links[n] = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=n,
                                                      source_component=1)
            mav = links[n].mav
            lon, lat = f["geometry"]["coordinates"][:2]
            alt_mm = int(p.get("alt_amsl_m", 0) * 1000)
            mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GROUND_ROVER, mavutil.mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                               mavutil.mavlink.MAV_MODE_FLAG_AUTO_ENABLED, 10, mavutil.mavlink.MAV_STATE_ACTIVE)
            mav.global_position_int_send(int(time.monotonic() * 1000) & 0xFFFFFFFF, round(lat * 1e7),
                                         round(lon * 1e7), alt_mm, 0, round(p.get("v_north_m_s", 0) * 100),
                                         round(p.get("v_east_m_s", 0) * 100), 0,
                                         round(p.get("heading_deg", 0) * 100) % 36000)
    return 0


# ------------------------------------------------------------------------------------ QGIS rendering

def qgis_render(png: str, specs: list[str]) -> int:
    """PyQGIS, headless: load the bridge's files as QGIS layers and export a print layout to PNG: on the
    left the GeoJSON and the CSV, on the right the KML and the KMZ (the same tracks, drawn one over the
    other), each map with the legend of its own layers."""
    from qgis.core import (Qgis, QgsApplication, QgsCoordinateReferenceSystem,  # noqa: PLC0415
                           QgsCoordinateTransform, QgsFillSymbol, QgsLayoutExporter, QgsLayoutItemLabel,
                           QgsLayoutItemLegend, QgsLayoutItemMap, QgsLayoutItemScaleBar, QgsLayoutPoint,
                           QgsLayoutSize, QgsLineSymbol, QgsMarkerSymbol, QgsPalLayerSettings, QgsPrintLayout,
                           QgsProject, QgsRectangle, QgsSingleSymbolRenderer, QgsTextFormat, QgsUnitTypes,
                           QgsVectorLayer, QgsVectorLayerSimpleLabeling, QgsWkbTypes)
    from qgis.PyQt.QtGui import QColor, QFont  # noqa: PLC0415

    files = dict(s.split("=", 1) for s in specs)
    app = QgsApplication([], False)
    app.initQgis()
    project = QgsProject.instance()
    project.setCrs(QgsCoordinateReferenceSystem("EPSG:3857"))
    report: list[str] = []

    def add(uri: str, name: str, provider: str, symbol, subset: str | None = None, label: str | None = None):
        layer = QgsVectorLayer(uri, name, provider)
        if not layer.isValid():
            report.append(f"{name}: QGIS could not open {uri}")
            return None
        if subset:
            layer.setSubsetString(subset)
        layer.setRenderer(QgsSingleSymbolRenderer(symbol))    # KML layers come with the embedded-style renderer
        if label:
            pal = QgsPalLayerSettings()
            pal.fieldName = label
            pal.isExpression = True
            fmt = QgsTextFormat()
            fmt.setFont(QFont("DejaVu Sans"))
            fmt.setSize(7)
            pal.setFormat(fmt)
            layer.setLabeling(QgsVectorLayerSimpleLabeling(pal))
            layer.setLabelsEnabled(True)
        project.addMapLayer(layer)
        report.append(f"{name}: {layer.featureCount()} features, {QgsWkbTypes.displayString(layer.wkbType())} "
                      f"(QGIS provider {layer.providerType()}: {layer.dataProvider().storageType()})")
        return layer

    def line(colour: str, width: str, style: str = "solid"):
        return QgsLineSymbol.createSimple({"line_color": colour, "line_width": width, "line_style": style})

    gj, kml, kmz, csv = files["geojson"], files["kml"], files["kmz"], files["csv"]
    vehicle_label = "\"vehicle\" || ' (' || \"role\" || ')'"
    left = [   # top to bottom
        add(f"{gj}|geometrytype=Point", "crowd (kind = crowd)", "ogr",
            QgsMarkerSymbol.createSimple({"name": "star", "size": "3.6", "color": "230,30,30"}),
            "\"kind\" = 'crowd'", label="'crowd ' || \"id\" || '  ' || \"mgrs\""),
        add(f"{gj}|geometrytype=Point", "vehicle (kind = vehicle)", "ogr",
            QgsMarkerSymbol.createSimple({"name": "triangle", "size": "2.6", "color": "40,90,200"}),
            "\"kind\" = 'vehicle'", label=vehicle_label),
        add(f"file://{csv}?delimiter=,&xField=lon_deg&yField=lat_deg&crs=EPSG:4326&detectTypes=yes",
            "crowds.csv rows (lon_deg, lat_deg)", "delimitedtext",
            QgsMarkerSymbol.createSimple({"name": "circle", "size": "0.9", "color": "90,90,255",
                                          "outline_style": "no"})),
        add(f"{gj}|geometrytype=Polygon", "crowd_footprint", "ogr",
            QgsFillSymbol.createSimple({"color": "0,0,0,0", "outline_color": "200,0,200", "outline_width": "0.3",
                                        "outline_style": "dash"}), "\"kind\" = 'crowd_footprint'"),
        add(f"{gj}|geometrytype=Polygon", "crowd_r95 (95 % circle)", "ogr",
            QgsFillSymbol.createSimple({"color": "255,200,0,80", "outline_color": "230,150,0",
                                        "outline_width": "0.4"}), "\"kind\" = 'crowd_r95'"),
    ]
    right = [
        add(f"{kmz}|layername=Crowds|geometrytype=LineString25D", "KMZ Crowds: gx:Track", "ogr",
            line("0,230,230", "0.3", "dash")),
        add(f"{kmz}|layername=Vehicles|geometrytype=LineString25D", "KMZ Vehicles: gx:Track", "ogr",
            line("0,230,230", "0.3", "dash")),
        add(f"{kml}|layername=Crowds|geometrytype=Polygon25D", "KML Crowds: 95 % Polygon", "ogr",
            QgsFillSymbol.createSimple({"color": "255,200,0,80", "outline_color": "230,150,0",
                                        "outline_width": "0.4"})),
        add(f"{kml}|layername=Crowds|geometrytype=LineString25D", "KML Crowds: gx:Track", "ogr",
            line("220,30,30", "0.9")),
        add(f"{kml}|layername=Vehicles|geometrytype=LineString25D", "KML Vehicles: gx:Track", "ogr",
            line("40,90,200", "0.7")),
    ]
    left, right = [x for x in left if x is not None], [x for x in right if x is not None]
    if not left and not right:
        print("\n".join(report), file=sys.stderr)
        return 1

    extent = QgsRectangle()
    for lyr in left + right:
        if lyr.featureCount():
            extent.combineExtentWith(QgsCoordinateTransform(lyr.crs(), project.crs(), project)
                                     .transformBoundingBox(lyr.extent()))
    extent.scale(1.1)

    mm = QgsUnitTypes.LayoutMillimeters
    layout = QgsPrintLayout(project)
    layout.initializeDefaults()
    layout.pageCollection().page(0).setPageSize(QgsLayoutSize(250, 168, mm))

    def label(text: str, x: float, y: float, w: float, size: int) -> None:
        item = QgsLayoutItemLabel(layout)
        item.setText(text)
        item.setFont(QFont("DejaVu Sans", size))
        item.attemptMove(QgsLayoutPoint(x, y, mm))
        item.attemptResize(QgsLayoutSize(w, 6, mm))
        layout.addLayoutItem(item)

    label(f"QGIS {Qgis.QGIS_VERSION}, headless: the files `uvteam bridge` wrote in one `uvteam demo` run "
          "(no basemap: offline)", 4, 2, 242, 10)
    for x, layers, title in ((4, left, "crowds.geojson (GDAL GeoJSON) + crowds.csv (delimited text)"),
                             (127, right, "crowds.kml and crowds.kmz (GDAL LIBKML)")):
        label(title, x, 9, 119, 8)
        m = QgsLayoutItemMap(layout)
        m.attemptMove(QgsLayoutPoint(x, 15, mm))
        m.attemptResize(QgsLayoutSize(119, 105, mm))
        m.setCrs(project.crs())
        m.setLayers(layers)
        m.setExtent(extent)
        m.setFrameEnabled(True)
        m.setBackgroundColor(QColor(248, 248, 240) if x < 100 else QColor(70, 70, 70))
        layout.addLayoutItem(m)
        m.attemptResize(QgsLayoutSize(119, 105, mm))    # setExtent fitted the item to the extent's shape
        m.zoomToExtent(extent)
        legend = QgsLayoutItemLegend(layout)
        legend.setTitle("")
        legend.setAutoUpdateModel(False)
        root = legend.model().rootGroup()
        root.removeAllChildren()
        for lyr in layers:
            root.addLayer(lyr)
        legend.setLinkedMap(m)
        legend.attemptMove(QgsLayoutPoint(x, 121, mm))
        layout.addLayoutItem(legend)
        bar = QgsLayoutItemScaleBar(layout)
        bar.setStyle("Single Box")
        bar.setLinkedMap(m)
        bar.applyDefaultSize()
        bar.setUnits(QgsUnitTypes.DistanceMeters)
        bar.setNumberOfSegments(2)
        bar.setNumberOfSegmentsLeft(0)
        bar.setUnitsPerSegment(10)
        bar.setUnitLabel("m")
        if x > 100:
            fmt = bar.textFormat()
            fmt.setColor(QColor(255, 255, 255))
            bar.setTextFormat(fmt)
        bar.attemptMove(QgsLayoutPoint(x + 3, 108, mm))
        layout.addLayoutItem(bar)

    settings = QgsLayoutExporter.ImageExportSettings()
    settings.dpi = 100
    settings.exportMetadata = False
    settings.generateWorldFile = False
    result = QgsLayoutExporter(layout).exportToImage(png, settings)
    print("\n".join(report))
    print(f"QGIS layout export: {'ok' if result == QgsLayoutExporter.Success else result} -> {png}")
    app.exitQgis()
    return 0 if result == QgsLayoutExporter.Success else 1


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--duration", type=float, default=30.0, help="seconds of demo (default 30)")
    ap.add_argument("--out", default=str(HERE / "tools"))
    ap.add_argument("--mavproxy-venv", default="/tmp/mavproxy-venv")
    ap.add_argument("--pytak-venv", default="/tmp/pytak-venv")
    ap.add_argument("--cot-receive", type=int, metavar="PORT", help=argparse.SUPPRESS)
    ap.add_argument("--seconds", type=float, default=30.0, help=argparse.SUPPRESS)
    ap.add_argument("--cot-out", help=argparse.SUPPRESS)
    ap.add_argument("--qgis-render", metavar="PNG", help=argparse.SUPPRESS)
    ap.add_argument("--ugv-relay", type=int, metavar="PORT", help=argparse.SUPPRESS)
    ap.add_argument("--geojson", help=argparse.SUPPRESS)
    ap.add_argument("specs", nargs="*", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.cot_receive:
        return cot_receive(args.cot_receive, args.seconds, args.cot_out)
    if args.qgis_render:
        return qgis_render(args.qgis_render, args.specs)
    if args.ugv_relay:
        return ugv_relay(args.ugv_relay, args.seconds, args.geojson)
    return run(args)


if __name__ == "__main__":
    sys.exit(main())
