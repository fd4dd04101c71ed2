"""The simulator service: runs a scenario in real time and plays every vehicle's autopilot and camera.

- each UGV and the UAV get a :class:`SimAutopilot` that streams MAVLink over UDP to its service's
  ``udpin`` port, serves missions, and steers the simulated vehicle with what it is sent;
- GNSS follows the scenario (rate, noise, bias, latency, drop-outs); a lost UGV (``events.lose_ugv``)
  goes silent, as a vehicle whose computer died;
- every frame: the rendered UAV camera frame on ``uvteam/<team>/<uav>/frame`` (``--frames pixels``, the
  default) or the sensor model's detections on ``uvteam/<team>/<uav>/sensor`` (``--frames sensor``), and
  the ground truth on ``uvteam/<team>/sim/truth``, all stamped with the frame's capture time.
"""

from __future__ import annotations

import argparse
import logging
import sys
import threading
import time

import numpy as np

from uvteam import keys
from uvteam.autopilot import MAV_CMD_DO_CHANGE_SPEED, MAV_CMD_NAV_WAYPOINT, mavlink2
from uvteam.io.zenoh_bus import ZenohBus, add_bus_args, bus_config_from_args
from uvteam.errors import ConfigError, LinkError
from uvteam.frames import encode_frame
from uvteam.messages import Blob, Detections, Landmark, Truth, TruthCrowd, TruthUgv
from uvteam.io.files import load_scenario
from uvteam.service import StopFlag, setup_logging

from .autopilot import SimAutopilot
from .render import Renderer
from .world import SimWorld

log = logging.getLogger("uvteam.sim")


def _vehicle_arg(s: str) -> tuple[str, int, int]:
    try:
        vid, port, sysid = s.split(":")
        return keys.check_id("vehicle", vid), int(port), int(sysid)
    except (ValueError, ConfigError):
        raise argparse.ArgumentTypeError(f"expected ID:UDP_PORT:SYSTEM_ID, got {s!r}") from None


def _mission_to_waypoints(world: SimWorld, items, default_speed: float) -> list[tuple[float, float, float]]:
    speed, out = default_speed, []
    for it in items:
        if it.command == MAV_CMD_DO_CHANGE_SPEED and it.param2 > 0:
            speed = float(it.param2)
        elif it.command == MAV_CMD_NAV_WAYPOINT:
            e, n = world.frame.wgs84_to_ground(it.lat_deg, it.lon_deg)
            out.append((float(e), float(n), speed))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="uvteam sim", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenario", required=True, help="scenario TOML (../shared/scenarios/*.toml)")
    ap.add_argument("--seed", type=int, default=None, help="seed (default: the scenario's first)")
    ap.add_argument("--team", default="demo")
    ap.add_argument("--uav", type=_vehicle_arg, required=True, metavar="ID:PORT:SYSID",
                    help="the UAV service's MAVLink udpin port and the autopilot's system id")
    ap.add_argument("--ugv", type=_vehicle_arg, action="append", default=[], metavar="ID:PORT:SYSID",
                    help="one per UGV, in the order of the scenario's colors")
    ap.add_argument("--duration", type=float, default=None, help="seconds (default: the scenario's)")
    ap.add_argument("--frames", choices=["pixels", "sensor"], default="pixels",
                    help="pixels: render the UAV camera and publish frames (.../<uav>/frame); "
                         "sensor: publish the sensor model's detections (.../<uav>/sensor)")
    ap.add_argument("--frame-jpeg", type=int, default=0, metavar="Q",
                    help="send frames as JPEG at quality Q (1-100) instead of raw BGR (0, default); the "
                         "scenario's own jpeg_quality is applied by the camera model either way")
    ap.add_argument("--log-level", default="INFO")
    add_bus_args(ap)
    args = ap.parse_args(argv)
    setup_logging(f"{args.team}/sim", args.log_level)
    try:
        sc = load_scenario(args.scenario)
    except ConfigError as exc:
        print(f"uvteam sim: {exc}", file=sys.stderr)
        return 2
    if len(args.ugv) != sc.ugvs.count:
        print(f"uvteam sim: the scenario has {sc.ugvs.count} UGVs, {len(args.ugv)} --ugv given", file=sys.stderr)
        return 2
    stop = StopFlag()
    try:
        return run(sc, args, stop)
    except LinkError as exc:
        log.error("link error: %s", exc)
        return 3


def run(sc, args, stop: StopFlag) -> int:
    seed = args.seed if args.seed is not None else sc.run.seeds[0]
    world = SimWorld(sc, seed)
    renderer = Renderer(world, np.random.default_rng([seed, 0x5EE])) if args.frames == "pixels" else None
    lock = threading.Lock()
    t0 = time.time()
    boot = t0 - 60.0
    ugv_aps: list[SimAutopilot] = []
    for i, (vid, port, sysid) in enumerate(args.ugv):
        def on_mission(items, i=i):
            with lock:
                world.set_mission(i, _mission_to_waypoints(world, items, sc.ugvs.station_speed_m_s))
        ugv_aps.append(SimAutopilot("127.0.0.1", port, sysid, boot_unix_s=boot, on_mission=on_mission).start())
    uav_id, uav_port, uav_sys = args.uav
    uav_ap = SimAutopilot("127.0.0.1", uav_port, uav_sys, boot_unix_s=boot,
                          mav_type=mavlink2.MAV_TYPE_QUADROTOR).start()
    duration = args.duration or sc.run.duration_s
    dt_frame, dt_fix = 1.0 / sc.run.frame_rate_hz, 1.0 / sc.gnss.fix_rate_hz
    lost = {int(i): float(t) for i, t in sc.events.lose_ugv}
    pending: list[tuple[float, int, tuple]] = []
    frame_seq = 0
    g = sc.world.ground_amsl_m
    try:
        with ZenohBus.open(bus_config_from_args(args)) as bus:
            bus.declare_alive(keys.alive(args.team, "sim"))
            sensor_key = keys.key(args.team, uav_id, "sensor")
            frame_key = keys.key(args.team, uav_id, "frame")
            truth_key = keys.key(args.team, "sim", "truth")
            log.info("scenario %s seed %d for %.0f s: %d UGVs, UAV at %.0f m", sc.name, seed, duration,
                     sc.ugvs.count, sc.uav.altitude_agl_m)
            t_sim, next_frame, next_fix = 0.0, 0.0, 0.0
            dt = 0.02
            while not stop.is_set() and t_sim <= duration:
                with lock:
                    world.step(dt)
                t_sim += dt
                # the world is now at t_sim: wait for that instant, so every stamp is a real capture time
                sleep = t0 + t_sim - time.time()
                if sleep > 0:
                    time.sleep(sleep)
                now_unix = t0 + t_sim
                for i, ap in enumerate(ugv_aps):
                    if i in lost and t_sim >= lost[i] and not ap._silent.is_set():
                        log.warning("%s is lost (scenario event at %.1f s)", args.ugv[i][0], lost[i])
                        ap.go_silent()
                while next_fix <= t_sim:
                    for i in range(sc.ugvs.count):
                        if world.in_dropout(i, next_fix):
                            continue
                        h_acc = float(np.sqrt(sc.gnss.sigma_m ** 2 + sc.gnss.bias_walk_m_per_sqrt_s ** 2
                                              * min(next_fix, 60.0))) or 0.02
                        with lock:
                            en, v = world.ugv_fix_en(i), world.ugv_fix_v(i)
                            hdg = float(world.ugv_heading_deg[i])
                        lat, lon = world.frame.ground_to_wgs84(en[0], en[1])
                        pending.append((next_fix + sc.gnss.latency_s, i,
                                        (t0 + next_fix, float(lat), float(lon), g, 0.0, hdg, float(v[0]), float(v[1]), h_acc)))
                    next_fix += dt_fix
                keep = []
                for rel, i, fx in pending:
                    if rel <= t_sim:
                        ugv_aps[i].send_position(*fx)
                    else:
                        keep.append((rel, i, fx))
                pending = keep
                if t_sim >= next_frame:
                    next_frame += dt_frame
                    frame_seq += 1
                    with lock:
                        pose = world.camera_pose()
                        if renderer is not None:
                            img = renderer.render(pose)
                        else:
                            sf = world.sense(pose, now_unix)
                        truth = world.truth_crowds()
                        ugv_p = world.ugv_p.copy()
                    ulat, ulon = world.frame.ground_to_wgs84(pose.east_m, pose.north_m)
                    uav_ap.send_position(now_unix, float(ulat), float(ulon), pose.up_m + g,
                                         sc.uav.altitude_agl_m, 0.0, 0.0, 0.0, 0.5)
                    if renderer is not None:
                        bus.publish(frame_key, encode_frame(uav_id, now_unix, frame_seq, img, args.frame_jpeg))
                    else:
                        bus.publish(sensor_key, Detections(
                            uav_id, now_unix, frame_seq, sc.camera.width_px, sc.camera.height_px, sc.uav.altitude_agl_m,
                            tuple(Landmark(c, float(x), float(y)) for c, (x, y) in sf.landmarks.items()),
                            tuple(Blob(float(c[0]), float(c[1]), *map(float, b), ugv=u)
                                  for c, b, u in zip(sf.blob_xy_px, sf.blob_xyxy_px, sf.blob_color))))
                    tl = [world.frame.ground_to_wgs84(c[0], c[1]) for c, _ in truth]
                    ul = world.frame.ground_to_wgs84(ugv_p[:, 0], ugv_p[:, 1])
                    bus.publish(truth_key, Truth(
                        now_unix, frame_seq,
                        tuple(TruthCrowd(float(la), float(lo), m) for (la, lo), (_, m) in zip(tl, truth)),
                        tuple(TruthUgv(args.ugv[i][0], float(ul[0][i]), float(ul[1][i])) for i in range(sc.ugvs.count))))
            log.info("scenario finished after %.1f s, %d frames; missions received: %s", t_sim, frame_seq,
                     [ap.missions_received for ap in ugv_aps])
    finally:
        for ap in ugv_aps + [uav_ap]:
            ap.stop()
    return 0
