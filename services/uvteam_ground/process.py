"""`uvteam process`: the UAV pipeline and the localizer, offline, on a recorded flight.

    uvteam process --video FLIGHT.mp4 --fixes FIXES.csv --config TEAM.toml --altitude-agl-m 80 --out out/flight
    uvteam process --video FLIGHT.mp4 --fixes FIXES.csv --config TEAM.toml --pose POSE.csv --out out/flight

The deployed services' own classes (:class:`uvteam.nodes.uav.UavNode`, :class:`uvteam.nodes.localizer.LocalizerNode`)
run over the in-memory bus in the recording's time: frames from the video, the UGVs' fixes from
FIXES.csv published as their services would, the UAV's autopilot state from POSE.csv (or a fixed height).

Inputs (CSV with a header; other columns are ignored; a bad row is reported with its line number and
skipped):
- FIXES.csv: ``t_s,ugv,lat_deg,lon_deg`` and optionally ``h_acc_m,heading_deg,v_east_m_s,v_north_m_s``;
- POSE.csv: ``t_s,alt_agl_m`` and optionally ``lat_deg,lon_deg,roll_deg,pitch_deg,yaw_deg``;
- TEAM.toml: a vehicle config (deploy/vehicles/*.toml format) whose ``[uav]`` section (colors, camera
  field of view, mounting) and ``[localizer]`` section (landmark UGVs, ...) are used; other sections
  are ignored.
Times: a frame's time is its index / the video's frame rate, plus ``--video-start-s``; ``t_s`` in the
CSVs is in the same time base (seconds; UNIX time or relative, either).

Outputs in --out: ``crowds.csv`` (``frame,t_s,crowd_id,lat_deg,lon_deg,radius95_m,quality,unseen_s``),
``crowds.geojson`` (one point feature per crowd per frame, RFC 7946), and with ``--annotated-video``
the frames with blobs, landmarks and crowds drawn.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np

from uvteam import keys
from uvteam.autopilot import MemoryAutopilot, VehicleState
from uvteam.bus import InMemoryBus
from uvteam.config import VehicleConfig, vehicle_config_from_dict
from uvteam.errors import ConfigError, MessageError
from uvteam.io.files import read_toml
from uvteam.messages import Crowds, Detections, Fix
from uvteam.nodes.localizer import LocalizerNode
from uvteam.nodes.uav import UavNode
from uvteam.vocab import is_id

__all__ = ["main", "read_fixes", "read_pose", "process"]

EPOCH_S = 1_000_000_000.0    # relative times are carried as UNIX times from here on the bus
GPS_FIX_3D = 3
DEFAULT_H_ACC_M = 2.0


class InputError(ValueError):
    """A bad input row: the file, its line and why."""


@dataclass(frozen=True, slots=True)
class PoseRow:
    t_s: float
    alt_agl_m: float
    lat_deg: float | None = None
    lon_deg: float | None = None
    roll_deg: float = 0.0
    pitch_deg: float = 0.0
    yaw_deg: float | None = None


def _rows(path: Path, required: tuple[str, ...]):
    """(line number, row dict) for each data row; InputError when the header lacks a required column."""
    try:
        f = open(path, newline="", encoding="utf-8")
    except OSError as exc:
        raise InputError(f"{path}: cannot be read: {exc.strerror or exc}") from None
    with f:
        reader = csv.DictReader(f)
        missing = [c for c in required if c not in (reader.fieldnames or ())]
        if missing:
            raise InputError(f"{path}:1: the header lacks {', '.join(missing)} (has {', '.join(reader.fieldnames or [])})")
        for row in reader:
            yield reader.line_num, row


def _num(row: dict, name: str, path: Path, line: int, *, optional: bool = False, lo=-math.inf, hi=math.inf):
    v = (row.get(name) or "").strip()
    if not v:
        if optional:
            return None
        raise InputError(f"{path}:{line}: {name} is empty")
    try:
        x = float(v)
    except ValueError:
        raise InputError(f"{path}:{line}: {name} is not a number: {v!r}") from None
    if not (math.isfinite(x) and lo <= x <= hi):
        raise InputError(f"{path}:{line}: {name} out of range [{lo}, {hi}]: {v!r}")
    return x


def read_fixes(path: Path, report) -> list[tuple[float, str, dict]]:
    """(t_s, ugv, fields) per good row, in time order; bad rows go to ``report`` with their line."""
    out = []
    for line, row in _rows(path, ("t_s", "ugv", "lat_deg", "lon_deg")):
        try:
            ugv = (row.get("ugv") or "").strip()
            if not is_id(ugv):
                raise InputError(f"{path}:{line}: ugv is no id: {ugv!r}")
            f = {"lat_deg": _num(row, "lat_deg", path, line, lo=-90, hi=90),
                 "lon_deg": _num(row, "lon_deg", path, line, lo=-180, hi=180),
                 "h_acc_m": _num(row, "h_acc_m", path, line, optional=True, lo=0),
                 "heading_deg": _num(row, "heading_deg", path, line, optional=True, lo=0, hi=360),
                 "v_east_m_s": _num(row, "v_east_m_s", path, line, optional=True, lo=-100, hi=100),
                 "v_north_m_s": _num(row, "v_north_m_s", path, line, optional=True, lo=-100, hi=100)}
            out.append((_num(row, "t_s", path, line), ugv, f))
        except InputError as exc:
            report(str(exc))
    return sorted(out, key=lambda r: r[0])


def read_pose(path: Path, report) -> list[PoseRow]:
    out = []
    for line, row in _rows(path, ("t_s", "alt_agl_m")):
        try:
            out.append(PoseRow(_num(row, "t_s", path, line), _num(row, "alt_agl_m", path, line, lo=1.0, hi=10_000),
                               _num(row, "lat_deg", path, line, optional=True, lo=-90, hi=90),
                               _num(row, "lon_deg", path, line, optional=True, lo=-180, hi=180),
                               _num(row, "roll_deg", path, line, optional=True, lo=-90, hi=90) or 0.0,
                               _num(row, "pitch_deg", path, line, optional=True, lo=-90, hi=90) or 0.0,
                               _num(row, "yaw_deg", path, line, optional=True, lo=-360, hi=360)))
        except InputError as exc:
            report(str(exc))
    return sorted(out, key=lambda r: r.t_s)


def _pose_at(rows: list[PoseRow], t: float) -> PoseRow:
    ts = [r.t_s for r in rows]
    i = int(np.searchsorted(ts, t))
    return rows[min(max(i - (i > 0 and (i == len(rows) or t - ts[i - 1] < ts[i] - t)), 0), len(rows) - 1)]


def _configs(path: str) -> tuple[VehicleConfig, VehicleConfig]:
    raw = read_toml(path)
    for role in ("uav", "localizer"):
        if role not in raw:
            raise ConfigError(path, role, "missing: uvteam process needs the [uav] and [localizer] sections")
    base = {k: v for k, v in raw.items() if k in ("uav", "localizer")}
    team = raw.get("vehicle", {}).get("team", "offline") if isinstance(raw.get("vehicle"), dict) else "offline"
    uav = vehicle_config_from_dict({"vehicle": {"team": team, "id": raw["localizer"].get("uav", "uav1"), "role": "uav"},
                                    "autopilot": {"url": "memory"}, **base}, path)
    loc = vehicle_config_from_dict({"vehicle": {"team": team, "id": "loc1", "role": "localizer"}, **base}, path)
    return uav, loc


def process(video: Path, fixes: list, uav_cfg: VehicleConfig, loc_cfg: VehicleConfig, pose: list[PoseRow] | None,
            alt_agl_m: float | None, video_start_s: float, out: Path, annotate: bool = False) -> dict:
    cap = cv2.VideoCapture(str(video))
    if not cap.isOpened():
        raise InputError(f"{video}: not a video OpenCV can read")
    fps = float(cap.get(cv2.CAP_PROP_FPS) or 0.0)
    if not fps > 0:
        raise InputError(f"{video}: no frame rate in the file")
    shift = EPOCH_S if (fixes and fixes[0][0] < 1e8) or video_start_s < 1e8 else 0.0
    clock = [shift + video_start_s]
    hub = InMemoryBus()
    ap = MemoryAutopilot()
    team = uav_cfg.team
    uav = UavNode(replace(uav_cfg, uav=replace(uav_cfg.uav, detector="pixels", camera="zenoh")), InMemoryBus(hub), ap,
                  lambda: clock[0])
    loc = LocalizerNode(loc_cfg, InMemoryBus(hub), lambda: clock[0])
    uav.start()
    loc.start()
    fix_bus = InMemoryBus(hub)
    rows, features, dets = [], [], {}
    seen_bus = InMemoryBus(hub)
    seen_bus.subscribe(keys.key(team, loc_cfg.id, "crowds"), Crowds, lambda k, m: dets.__setitem__("crowds", m))
    seen_bus.subscribe(keys.key(team, uav_cfg.id, "detections"), Detections, lambda k, m: dets.__setitem__("det", m))
    writer = None
    k_fix = 0
    first_ll = next(((f["lat_deg"], f["lon_deg"]) for _, _, f in fixes), (0.0, 0.0))
    frame_idx = 0
    while True:
        ok, img = cap.read()
        if not ok:
            break
        t_rel = video_start_s + frame_idx / fps
        clock[0] = shift + t_rel
        while k_fix < len(fixes) and fixes[k_fix][0] <= t_rel + 1e-9:   # the UGVs' fixes as they would arrive
            t_f, ugv, f = fixes[k_fix]
            v = (f["v_east_m_s"], f["v_north_m_s"]) if f["v_east_m_s"] is not None and f["v_north_m_s"] is not None else (None, None)
            fix_bus.publish(keys.key(team, ugv, "fix"), Fix(ugv, shift + t_f, f["lat_deg"], f["lon_deg"], 0.0, f["heading_deg"],
                                                            f["h_acc_m"] if f["h_acc_m"] is not None else DEFAULT_H_ACC_M,
                                                            *v, GPS_FIX_3D))
            k_fix += 1
        p = _pose_at(pose, t_rel) if pose else PoseRow(t_rel, alt_agl_m)
        lat, lon = (p.lat_deg, p.lon_deg) if p.lat_deg is not None and p.lon_deg is not None else first_ll
        ap.set_state(VehicleState(clock[0], "autopilot", lat, lon, 0.0, p.alt_agl_m, p.yaw_deg, None, None, None,
                                  p.roll_deg, p.pitch_deg, p.yaw_deg, GPS_FIX_3D))
        dets.clear()
        uav.process_frame(clock[0], frame_idx, img)
        loc.step(0.0)
        msg = dets.get("crowds")
        for c in (msg.crowds if msg is not None else ()):
            rows.append((frame_idx, t_rel, c.crowd_id, c.lat_deg, c.lon_deg, c.radius95_m, c.quality, c.unseen_s))
            features.append({"type": "Feature", "geometry": {"type": "Point", "coordinates": [round(c.lon_deg, 8), round(c.lat_deg, 8)]},
                             "properties": {"frame": frame_idx, "t_s": t_rel, "crowd_id": c.crowd_id,
                                            "radius95_m": round(c.radius95_m, 3), "quality": c.quality,
                                            "unseen_s": round(c.unseen_s, 2)}})
        if annotate:
            writer = writer or cv2.VideoWriter(str(out / "annotated.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), fps,
                                               (img.shape[1], img.shape[0]))
            writer.write(_annotate(img, dets.get("det"), msg))
        frame_idx += 1
    cap.release()
    if writer is not None:
        writer.release()
    with open(out / "crowds.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["frame", "t_s", "crowd_id", "lat_deg", "lon_deg", "radius95_m", "quality", "unseen_s"])
        for r in rows:
            w.writerow([r[0], f"{r[1]:.3f}", r[2], f"{r[3]:.8f}", f"{r[4]:.8f}", f"{r[5]:.3f}", r[6], f"{r[7]:.2f}"])
    (out / "crowds.geojson").write_text(json.dumps({"type": "FeatureCollection", "features": features}))
    return {"frames": frame_idx, "crowd_rows": len(rows), "fixes": len(fixes), "uav": uav.metrics(), "localizer": loc.metrics()}


def _annotate(img: np.ndarray, det: Detections | None, crowds: Crowds | None) -> np.ndarray:
    """Motion blobs (grey, UGV blobs orange), landmarks (their UGV ids) and the crowds' lat/lon."""
    out = img.copy()
    if det is not None:
        for (x0, y0, x1, y1), u in zip(det.blobs.xyxy_px, det.blobs.ugv):
            cv2.rectangle(out, (int(x0), int(y0)), (int(x1), int(y1)), (0, 140, 255) if u else (200, 200, 200), 1)
        for u, (x, y) in zip(det.landmarks.ugv, det.landmarks.xy_px):
            cv2.circle(out, (int(x), int(y)), 6, (0, 255, 255), 2)
            cv2.putText(out, u, (int(x) + 8, int(y) - 8), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 255, 255), 1)
    if crowds is not None:
        for i, c in enumerate(crowds.crowds):
            cv2.putText(out, f"crowd {c.crowd_id}: {c.lat_deg:.6f}, {c.lon_deg:.6f} r95 {c.radius95_m:.1f} m {c.quality}",
                        (10, 24 + 20 * i), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (0, 0, 255), 2)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="uvteam process", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--video", required=True, help="the UAV's video file")
    ap.add_argument("--fixes", required=True, help="the UGVs' fixes (CSV)")
    ap.add_argument("--config", required=True, help="TOML with the [uav] and [localizer] sections")
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--pose", help="the UAV's pose (CSV: t_s, alt_agl_m, optionally lat/lon/roll/pitch/yaw)")
    g.add_argument("--altitude-agl-m", type=float, help="a fixed height above ground instead of a pose file")
    ap.add_argument("--video-start-s", type=float, default=0.0, help="the first frame's time in the CSVs' time base")
    ap.add_argument("--out", required=True, help="folder for crowds.csv and crowds.geojson")
    ap.add_argument("--annotated-video", action="store_true", help="also write annotated.mp4")
    args = ap.parse_args(argv)
    problems: list[str] = []

    def report(msg: str) -> None:
        problems.append(msg)
        print(f"uvteam process: skipped {msg}", file=sys.stderr)

    try:
        uav_cfg, loc_cfg = _configs(args.config)
        fixes = read_fixes(Path(args.fixes), report)
        pose = read_pose(Path(args.pose), report) if args.pose else None
        if not fixes:
            raise InputError(f"{args.fixes}: no usable fix")
        if pose is not None and not pose:
            raise InputError(f"{args.pose}: no usable pose row")
        if args.altitude_agl_m is not None and not args.altitude_agl_m > 1.0:
            raise InputError(f"--altitude-agl-m must be > 1, got {args.altitude_agl_m}")
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        summary = process(Path(args.video), fixes, uav_cfg, loc_cfg, pose, args.altitude_agl_m, args.video_start_s, out,
                          args.annotated_video)
    except (ConfigError, InputError, MessageError) as exc:
        print(f"uvteam process: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"uvteam process: {exc}", file=sys.stderr)
        return 2
    print(f"uvteam process: {summary['frames']} frames, {summary['fixes']} fixes ({len(problems)} rows skipped), "
          f"{summary['crowd_rows']} crowd positions -> {Path(args.out) / 'crowds.csv'}, crowds.geojson")
    return 0
