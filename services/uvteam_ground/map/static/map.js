// uvteam map: draws the snapshots the server pushes (server-sent events on /events) with Leaflet.
// No tiles are needed: a metric grid (metres east/north of the grid origin), a scale bar and a
// north arrow; offline basemaps from the server's /tiles/ when it was given --basemap.
"use strict";
(function () {
  const QUALITY = {
    exact: "#1a7f37", least_squares: "#1f6feb", robust: "#9a6700", held: "#d4700a", failed: "#b42318",
  };
  const QUALITY_TEXT = {
    exact: "exact (4 landmarks)", least_squares: "least squares", robust: "robust (outliers left out)",
    held: "held (earlier fit)", failed: "failed",
  };
  const PALETTE = ["#e41a1c", "#2e9e3f", "#377eb8", "#c9a400", "#c51b8a", "#00a6b8", "#ff7f00", "#6a3d9a"];
  const UAV_COLOR = "#222";
  const qcolor = (q) => QUALITY[q] || "#666";

  // everything the page knows, for the console and the browser test
  const S = { cfg: null, map: null, last: null, origin: null, vehicles: {}, crowds: {}, colors: {},
              rendered: 0, userMoved: false, knownIds: "" };
  window.uvmap = S;

  const esc = (s) => String(s).replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" }[c]));
  const fmtLatLon = (lat, lon) => `${lat.toFixed(6)}, ${lon.toFixed(6)}`;
  const spacedMgrs = (m) => {
    const r = /^(\d{0,2}[A-Z])([A-Z]{2})(\d*)$/.exec(m || "");
    if (!r) return m || "";
    const h = r[3].length / 2;
    return [r[1], r[2], r[3].slice(0, h), r[3].slice(h)].filter(Boolean).join(" ");
  };
  const age = (s) => (s == null ? "-" : s < 10 ? `${s.toFixed(1)} s` : `${Math.round(s)} s`);

  function colorOf(id) {
    if (!(id in S.colors)) S.colors[id] = PALETTE[Object.keys(S.colors).length % PALETTE.length];
    return S.colors[id];
  }

  // WGS84 metres per degree of latitude and longitude at a latitude
  function metresPerDegree(latDeg) {
    const a = 6378137.0, e2 = 6.69437999014e-3, phi = (latDeg * Math.PI) / 180;
    const w = Math.sqrt(1 - e2 * Math.sin(phi) ** 2);
    return [((a * (1 - e2)) / w ** 3) * (Math.PI / 180), (a / w) * Math.cos(phi) * (Math.PI / 180)];
  }

  function niceStep(m) {
    const p = Math.pow(10, Math.floor(Math.log10(m)));
    for (const k of [1, 2, 5, 10]) if (k * p >= m) return k * p;
    return 10 * p;
  }

  // -- the metric grid: lines of constant east and north, which Web Mercator draws straight --------
  const MetricGrid = L.Layer.extend({
    onAdd(map) {
      this._canvas = L.DomUtil.create("canvas", "grid-canvas");
      map.getPane("grid").appendChild(this._canvas);
      map.on("move zoom resize viewreset", this._draw, this);
      this._draw();
    },
    onRemove(map) {
      map.off("move zoom resize viewreset", this._draw, this);
      L.DomUtil.remove(this._canvas);
      S.gridStep = null;
    },
    _draw() {
      const map = this._map, size = map.getSize(), c = this._canvas, dpr = window.devicePixelRatio || 1;
      L.DomUtil.setPosition(c, map.containerPointToLayerPoint([0, 0]));
      c.width = size.x * dpr; c.height = size.y * dpr;
      c.style.width = size.x + "px"; c.style.height = size.y + "px";
      const g = c.getContext("2d");
      g.setTransform(dpr, 0, 0, dpr, 0, 0);
      g.clearRect(0, 0, size.x, size.y);
      const o = S.origin || [map.getCenter().lat, map.getCenter().lng];
      const [mLat, mLon] = metresPerDegree(o[0]);
      const b = map.getBounds();
      const mpp = map.distance(map.containerPointToLatLng([0, size.y / 2]), map.containerPointToLatLng([size.x, size.y / 2])) / size.x;
      const step = niceStep(mpp * 90);
      S.gridStep = step;
      const lines = [];
      const e0 = Math.ceil(((b.getWest() - o[1]) * mLon) / step), e1 = Math.floor(((b.getEast() - o[1]) * mLon) / step);
      const n0 = Math.ceil(((b.getSouth() - o[0]) * mLat) / step), n1 = Math.floor(((b.getNorth() - o[0]) * mLat) / step);
      if (e1 - e0 > 400 || n1 - n0 > 400) return;
      g.font = "11px 'DejaVu Sans', Arial, sans-serif";
      g.textBaseline = "top";
      for (let i = e0; i <= e1; i++) {
        const x = Math.round(map.latLngToContainerPoint([o[0], o[1] + (i * step) / mLon]).x) + 0.5;
        lines.push(["v", x, i]);
      }
      for (let i = n0; i <= n1; i++) {
        const y = Math.round(map.latLngToContainerPoint([o[0] + (i * step) / mLat, o[1]]).y) + 0.5;
        lines.push(["h", y, i]);
      }
      const label = (i, axis) => (i === 0 ? `0 ${axis}` : `${i > 0 ? "+" : "\u2212"}${fmtM(Math.abs(i * step))} ${axis}`);
      for (const [kind, p, i] of lines) {
        g.strokeStyle = i === 0 ? "rgba(60,60,60,0.75)" : "rgba(90,90,90,0.28)";
        g.lineWidth = i === 0 ? 1.5 : 1;
        g.beginPath();
        if (kind === "v") { g.moveTo(p, 0); g.lineTo(p, size.y); } else { g.moveTo(0, p); g.lineTo(size.x, p); }
        g.stroke();
      }
      g.fillStyle = "rgba(40,40,40,0.8)";
      for (const [kind, p, i] of lines) {
        if (kind === "v") g.fillText(label(i, "E"), p + 3, 3);
        else g.fillText(label(i, "N"), 52, p + 2);   // clear of the zoom buttons
      }
      if (S.legend) S.legend.update();
    },
  });
  const fmtM = (m) => (m >= 1000 ? `${+(m / 1000).toFixed(3)} km` : `${+m.toFixed(2)} m`);

  function northArrow() {
    const c = L.control({ position: "topright" });
    c.onAdd = () => {
      const d = L.DomUtil.create("div", "north-arrow");
      d.title = "north (the map is north-up)";
      d.innerHTML = '<svg width="22" height="34" viewBox="0 0 22 34"><path d="M11 2 L19 28 L11 22 L3 28 Z" fill="#222"/>' +
        '<path d="M11 2 L11 22 L3 28 Z" fill="#fff" stroke="#222" stroke-width="1"/></svg><div>N</div>';
      return d;
    };
    return c;
  }

  function legend() {
    const c = L.control({ position: "bottomright" });
    c.onAdd = () => { c._div = L.DomUtil.create("div", "legend"); c.update(); return c._div; };
    c.update = () => {
      if (!c._div) return;
      const q = Object.entries(QUALITY).map(([k, v]) => `<i style="background:${v}"></i>${esc(QUALITY_TEXT[k])}`).join("<br>");
      const o = S.origin ? `origin ${fmtLatLon(S.origin[0], S.origin[1])}` : "origin: first fix";
      const grid = S.gridStep ? `grid ${fmtM(S.gridStep)} (ENU, ${o})` : "grid off";
      c._div.innerHTML = `<b>crowd fit</b><br>${q}<br><span class="muted">${esc(grid)}<br>circle: 95 %; arrow: ${S.cfg ? S.cfg.arrow_s : 5} s ahead</span>`;
    };
    S.legend = c;
    return c;
  }

  function fitButton() {
    const c = L.control({ position: "topleft" });
    c.onAdd = () => {
      const d = L.DomUtil.create("div", "leaflet-bar fit-button");
      d.textContent = "fit";
      d.title = "zoom to the team";
      L.DomEvent.on(d, "click", (e) => { L.DomEvent.stop(e); S.userMoved = false; fit(true); });
      return d;
    };
    return c;
  }

  // -- vehicles ---------------------------------------------------------------------------------
  function vehicleIcon(v) {
    const color = v.role === "uav" ? UAV_COLOR : colorOf(v.id);
    let shape;
    if (v.role === "uav") {
      shape = '<g stroke="#222" stroke-width="2" fill="#fff"><line x1="6" y1="6" x2="22" y2="22"/><line x1="22" y1="6" x2="6" y2="22"/>' +
        '<circle cx="6" cy="6" r="3.5"/><circle cx="22" cy="6" r="3.5"/><circle cx="6" cy="22" r="3.5"/><circle cx="22" cy="22" r="3.5"/>' +
        '<circle cx="14" cy="14" r="3" fill="#222"/></g>';
      if (v.heading_deg != null) shape += `<g class="heading" transform="rotate(${v.heading_deg} 14 14)"><path d="M14 1 L17 7 L11 7 Z" fill="#222"/></g>`;
    } else if (v.heading_deg == null) {
      shape = `<circle cx="14" cy="14" r="7" fill="${color}" stroke="#000" stroke-width="1.5"/>`;
    } else {
      shape = `<g class="heading" transform="rotate(${v.heading_deg} 14 14)"><path d="M14 1 L23 25 L14 19 L5 25 Z" fill="${color}" stroke="#000" stroke-width="1.5"/></g>`;
    }
    const cls = `veh-icon veh-${v.id} role-${v.role}` + (v.stale ? " stale" : "") + (v.alive === false ? " dead" : "");
    const html = `<svg class="arrow" width="28" height="28" viewBox="0 0 28 28">${shape}</svg><span class="label">${esc(v.id)}</span>`;
    return { key: cls + html, icon: L.divIcon({ className: cls, html, iconSize: [28, 28], iconAnchor: [14, 14] }) };
  }

  function vehicleTip(v) {
    const alive = v.alive == null ? "unknown" : v.alive ? "yes" : "NO";
    let s = `<b>${esc(v.id)}</b> (${v.role})<br>${fmtLatLon(v.lat, v.lon)}<br>MGRS ${esc(spacedMgrs(v.mgrs))}` +
      `<br>alt ${v.alt_amsl_m.toFixed(1)} m AMSL, heading ${v.heading_deg == null ? "unknown" : v.heading_deg.toFixed(0) + "\u00b0"}` +
      `<br>${v.speed_m_s == null ? "speed unknown" : v.speed_m_s.toFixed(1) + " m/s"}, \u00b1${v.h_acc_m.toFixed(1)} m, fix ${age(v.age_s)} old, alive ${alive}`;
    if (v.role === "uav") s += `<br>footprint: ${v.footprint ? "from " + v.footprint_source : "unknown altitude"}`;
    return s;
  }

  function drawVehicle(v) {
    let e = S.vehicles[v.id];
    if (!e) e = S.vehicles[v.id] = {};
    if (v.lat == null) return;   // a service: the list only
    const ll = [v.lat, v.lon];
    const color = v.role === "uav" ? UAV_COLOR : colorOf(v.id);
    const ic = vehicleIcon(v);
    if (!e.marker) {
      e.marker = L.marker(ll, { icon: ic.icon, pane: "vehicles", keyboard: false }).bindTooltip("", { direction: "top", offset: [0, -12] }).addTo(S.map);
      e.iconKey = ic.key;
    } else {
      e.marker.setLatLng(ll);
      if (e.iconKey !== ic.key) { e.marker.setIcon(ic.icon); e.iconKey = ic.key; }
    }
    e.marker.setTooltipContent(vehicleTip(v));
    const trailStyle = { pane: "tracks", color, weight: 2, opacity: v.stale ? 0.35 : 0.7, className: `trail trail-${v.id}`, interactive: false };
    if (!e.trail) e.trail = L.polyline(v.trail, trailStyle).addTo(S.map); else { e.trail.setLatLngs(v.trail); e.trail.setStyle(trailStyle); }
    const planStyle = { pane: "tracks", color, weight: 1.5, opacity: 0.8, dashArray: "4 5", className: `plan plan-${v.id}`, interactive: false };
    if (!e.plan) e.plan = L.polyline(v.plan || [], planStyle).addTo(S.map); else e.plan.setLatLngs(v.plan || []);
    if (v.role === "uav") {
      const fpStyle = { pane: "footprints", color: "#333", weight: 1.5, fillColor: "#888", fillOpacity: 0.08,
                        dashArray: v.footprint_yaw_known ? null : "6 6", className: "uav-footprint", interactive: false };
      if (v.footprint) {
        if (!e.footprint) e.footprint = L.polygon(v.footprint, fpStyle).addTo(S.map);
        else { e.footprint.setLatLngs(v.footprint); e.footprint.setStyle(fpStyle); }
      } else if (e.footprint) { e.footprint.remove(); e.footprint = null; }
    }
  }

  // -- crowds -----------------------------------------------------------------------------------
  function crowdTip(c) {
    return `<b>crowd ${c.id}</b>${c.lost ? " (lost)" : ""}${c.unseen_s > 0 ? `, unseen ${c.unseen_s.toFixed(1)} s: predicted` : ""}<br>${fmtLatLon(c.lat, c.lon)}<br>MGRS ${esc(spacedMgrs(c.mgrs))}` +
      `<br>95 % radius ${c.radius95_m.toFixed(1)} m, fit ${esc(c.quality)}${c.n_outliers ? `, ${c.n_outliers} outliers` : ""}` +
      `<br>${c.speed_m_s.toFixed(1)} m/s (E ${c.v_east_m_s.toFixed(1)}, N ${c.v_north_m_s.toFixed(1)}), ${age(c.age_s)} ago`;
  }

  function drawCrowd(c) {
    const k = `${c.source}:${c.id}`;
    let e = S.crowds[k];
    const color = qcolor(c.quality), fade = c.stale ? 0.4 : c.unseen_s > 0 ? 0.6 : 1.0;
    const ll = [c.lat, c.lon], cls = `crowd-${c.id}`;
    if (!e) {
      e = S.crowds[k] = {};
      e.footprint = L.polygon(c.footprint, { pane: "footprints", className: `crowd-footprint ${cls}`, interactive: false }).addTo(S.map);
      e.track = L.polyline(c.track, { pane: "tracks", weight: 2, dashArray: "1 4", className: `crowd-track ${cls}`, interactive: false }).addTo(S.map);
      e.r95 = L.circle(ll, { pane: "circles", radius: c.radius95_m, weight: 1.5, dashArray: "5 4", fillOpacity: 0.1, className: `crowd-r95 ${cls}` })
        .bindTooltip("", { sticky: true }).addTo(S.map);
      e.shaft = L.polyline([ll, ll], { pane: "arrows", weight: 2.5, className: `crowd-velocity ${cls}`, interactive: false }).addTo(S.map);
      e.head = L.marker(ll, { pane: "arrows", interactive: false, keyboard: false,
                              icon: L.divIcon({ className: "arrowhead", html: "", iconSize: [16, 16], iconAnchor: [8, 8] }) });
      e.centre = L.circleMarker(ll, { pane: "centres", radius: 5, weight: 1.5, color: "#000", fillOpacity: 1, className: `crowd-centre ${cls}` })
        .bindTooltip("", { direction: "top", offset: [0, -6] }).addTo(S.map);
      e.label = L.marker(ll, { pane: "vehicles", interactive: false, keyboard: false,
                               icon: L.divIcon({ className: "crowd-label", html: `#${c.id}`, iconSize: null, iconAnchor: [-8, 20] }) }).addTo(S.map);
    }
    e.footprint.setLatLngs(c.footprint);
    e.footprint.setStyle({ color, weight: 1, opacity: fade, fillColor: color, fillOpacity: 0.25 * fade });
    e.track.setLatLngs(c.track);
    e.track.setStyle({ color, opacity: 0.8 * fade });
    e.r95.setLatLng(ll); e.r95.setRadius(c.radius95_m);
    e.r95.setStyle({ color, opacity: fade, fillColor: color, fillOpacity: 0.08 * fade });
    e.centre.setLatLng(ll); e.centre.setStyle({ fillColor: color, opacity: fade, fillOpacity: fade });
    e.label.setLatLng(ll);
    L.DomUtil[c.lost ? "addClass" : "removeClass"](e.label.getElement(), "lost");
    const tip = crowdTip(c);
    e.centre.setTooltipContent(tip); e.r95.setTooltipContent(tip);
    if (c.arrow_tip) {
      e.shaft.setLatLngs([ll, c.arrow_tip]); e.shaft.setStyle({ color, opacity: fade });
      const bearing = (Math.atan2(c.v_east_m_s, c.v_north_m_s) * 180) / Math.PI;
      const html = `<svg width="16" height="16" viewBox="0 0 16 16"><g transform="rotate(${bearing.toFixed(1)} 8 8)">` +
        `<path d="M8 0 L14 14 L8 10 L2 14 Z" fill="${color}" fill-opacity="${fade}"/></g></svg>`;
      e.head.setLatLng(c.arrow_tip);
      if (e.headHtml !== html) { e.head.setIcon(L.divIcon({ className: "arrowhead", html, iconSize: [16, 16], iconAnchor: [8, 8] })); e.headHtml = html; }
      if (!S.map.hasLayer(e.head)) e.head.addTo(S.map);
    } else {
      e.shaft.setLatLngs([ll, ll]);
      if (S.map.hasLayer(e.head)) e.head.remove();
    }
  }

  function removeCrowd(k) {
    const e = S.crowds[k];
    for (const l of Object.values(e)) if (l && l.remove) l.remove();
    delete S.crowds[k];
  }

  // -- the side list ----------------------------------------------------------------------------
  function renderSide(st) {
    const conn = document.getElementById("conn");
    const bus = st.bus || {};
    document.getElementById("footer").textContent =
      `received ${bus.received ?? "-"} messages, rejected here ${bus.rejected ?? "-"}; updated ${new Date(st.now_s * 1000).toLocaleTimeString()}`;
    conn.className = "ok";
    conn.textContent = "live";
    const frames = Object.entries(st.frames).map(([src, f]) =>
      `${esc(src)}: fit ${esc(f.quality)}, landmarks ${f.landmarks_used.length}` +
      (f.outlier_landmarks.length ? ` (outliers ${esc(f.outlier_landmarks.join(" "))})` : "") + `, ${age(f.age_s)} ago`);
    document.getElementById("frame").innerHTML = frames.join("<br>") || '<span class="muted">no crowds message yet</span>';
    const rows = st.vehicles.map((v) => {
      const alive = v.alive == null ? '<span class="unknown">?</span>' : v.alive ? '<span class="yes">yes</span>' : '<span class="no">NO</span>';
      const link = v.status ? esc(v.status.link) : "-";
      const metrics = v.status ? Object.entries(v.status.metrics || {}).map(([k, x]) => `${k}=${x}`).join(" ") : "";
      const note = v.status ? esc([v.status.note, metrics].filter(Boolean).join("; ")) : "";
      const sw = v.lat == null ? "" : `<span style="color:${v.role === "uav" ? UAV_COLOR : colorOf(v.id)}">\u25a0</span> `;
      const row = `<tr class="${v.stale ? "stale" : ""}" data-vehicle="${esc(v.id)}"><td>${sw}${esc(v.id)}</td><td>${alive}</td>` +
        `<td>${v.lat == null ? "-" : age(v.age_s)}</td><td>${link}</td></tr>`;
      return note ? row + `<tr class="note-row${v.stale ? " stale" : ""}"><td colspan="4" class="note">${note}</td></tr>` : row;
    });
    document.querySelector("#vehicles tbody").innerHTML = rows.join("");
    const crowds = st.crowds.map((c) =>
      `<div class="crowd-row${c.lost ? " lost" : ""}" style="border-left-color:${qcolor(c.quality)}" data-crowd="${c.id}" data-lat="${c.lat}" data-lon="${c.lon}">` +
      `<b>#${c.id}</b> ${c.lost ? "(lost) " : ""}${c.unseen_s > 0 ? `(unseen ${c.unseen_s.toFixed(1)} s) ` : ""}${esc(c.quality)}, r95 ${c.radius95_m.toFixed(1)} m, ${c.speed_m_s.toFixed(1)} m/s` +
      `<br>${fmtLatLon(c.lat, c.lon)}<br><span class="mgrs">${esc(spacedMgrs(c.mgrs))}</span></div>`);
    document.getElementById("crowds").innerHTML = crowds.join("") || '<p class="muted">none</p>';
  }

  // -- the view ---------------------------------------------------------------------------------
  function fit(force) {
    const st = S.last;
    if (!st || (S.cfg.center && !force)) return;
    const pts = st.vehicles.filter((v) => v.lat != null).map((v) => [v.lat, v.lon]).concat(st.crowds.map((c) => [c.lat, c.lon]));
    const ids = st.vehicles.filter((v) => v.lat != null).map((v) => v.id).concat(st.crowds.map((c) => c.id)).join(",");
    if (!pts.length || (!force && (S.userMoved || ids === S.knownIds))) return;
    S.knownIds = ids;
    if (pts.length === 1) S.map.setView(pts[0], 18);
    else S.map.fitBounds(L.latLngBounds(pts).pad(0.3), { maxZoom: 20 });
  }

  function render(st) {
    S.last = st;
    if (st.origin && (!S.origin || S.origin[0] !== st.origin[0] || S.origin[1] !== st.origin[1])) {
      S.origin = st.origin;
      if (S.grid && S.map.hasLayer(S.grid)) S.grid._draw();
    }
    st.vehicles.forEach(drawVehicle);
    const seen = new Set();
    for (const c of st.crowds) { seen.add(`${c.source}:${c.id}`); drawCrowd(c); }
    for (const k of Object.keys(S.crowds)) if (!seen.has(k)) removeCrowd(k);
    renderSide(st);
    fit(false);
    S.rendered += 1;
  }

  function connect() {
    const es = new EventSource("events");
    es.addEventListener("state", (ev) => render(JSON.parse(ev.data)));
    es.onerror = () => {
      const conn = document.getElementById("conn");
      conn.className = "bad";
      conn.textContent = "no connection to uvteam map, retrying\u2026";
    };
    S.events = es;
  }

  // what the UAV sees (uvteam map --video URL): an MJPEG <img>, tried again when the stream drops
  function showVideo(url) {
    const box = document.getElementById("video"), img = document.getElementById("video-img");
    box.hidden = false;
    img.onerror = () => { setTimeout(() => { img.src = url + (url.includes("?") ? "&" : "?") + "t=" + Date.now(); }, 2000); };
    img.src = url;
  }

  async function start() {
    const cfg = await (await fetch("config.json")).json();
    S.cfg = cfg;
    if (cfg.video) showVideo(cfg.video);
    document.getElementById("team").textContent = cfg.team;
    document.title = `uvteam map: ${cfg.team}`;
    if (cfg.origin) S.origin = cfg.origin;
    const map = L.map("map", { maxZoom: 23, minZoom: 2, zoomAnimation: false, fadeAnimation: false, markerZoomAnimation: false });
    S.map = map;
    map.attributionControl.setPrefix('<a href="https://leafletjs.com" title="Leaflet, BSD-2-Clause">Leaflet</a>');
    for (const [name, z] of [["grid", 250], ["footprints", 410], ["tracks", 420], ["circles", 430], ["arrows", 440], ["centres", 450], ["vehicles", 610]]) {
      map.createPane(name).style.zIndex = z;
    }
    map.getPane("grid").style.pointerEvents = "none";
    map.setView(cfg.center || [0, 0], cfg.center ? cfg.zoom || 18 : 3);
    const bases = {};
    cfg.basemaps.forEach((b, i) => {
      // shown from its own lowest zoom (no minNativeZoom: that would fetch deep tiles for a world view)
      const opt = { minZoom: b.min_zoom, maxZoom: 23, maxNativeZoom: b.max_zoom, attribution: esc(b.attribution || b.name) };
      if (b.bounds) opt.bounds = [[b.bounds[1], b.bounds[0]], [b.bounds[3], b.bounds[2]]];
      bases[b.name] = L.tileLayer(b.url, opt);
      if (i === 0) bases[b.name].addTo(map);
    });
    S.grid = new MetricGrid().addTo(map);
    L.control.layers(bases, { "metric grid": S.grid }, { collapsed: true, position: "topright" }).addTo(map);
    northArrow().addTo(map);
    L.control.scale({ imperial: false, maxWidth: 200, position: "bottomleft" }).addTo(map);
    legend().addTo(map);
    fitButton().addTo(map);
    map.on("dragstart", () => { S.userMoved = true; });
    map.getContainer().addEventListener("wheel", () => { S.userMoved = true; }, { passive: true });
    map.on("overlayadd overlayremove", () => S.legend.update());
    document.getElementById("crowds").addEventListener("click", (ev) => {
      const row = ev.target.closest(".crowd-row");
      if (row) { S.userMoved = true; map.panTo([+row.dataset.lat, +row.dataset.lon]); }
    });
    connect();
  }

  start();
})();
