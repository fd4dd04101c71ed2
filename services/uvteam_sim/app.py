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
import time

import numpy as np

from uvteam import keys
from uvteam.autopilot import mavlink2
from uvteam.io.zenoh_bus import ZenohBus, add_bus_args, bus_config_from_args
from uvteam.errors import ConfigError, LinkError
from uvteam.frames import encode_frame
from uvteam.io.files import load_scenario
from uvteam.service import StopFlag, setup_logging

from .autopilot import SimAutopilot
from .render import Renderer
from .simulation import Simulation

log = logging.getLogger("uvteam.sim")


def _vehicle_arg(s: str) -> tuple[str, int, int]:
    try:
        vid, port, sysid = s.split(":")
        return keys.check_id("vehicle", vid), int(port), int(sysid)
    except (ValueError, ConfigError):
        raise argparse.ArgumentTypeError(f"expected ID:UDP_PORT:SYSTEM_ID, got {s!r}") from None


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
    except ConfigError as exc:
        log.error("configuration error: %s", exc)
        return 2
    except LinkError as exc:
        log.error("link error: %s", exc)
        return 3


def run(sc, args, stop: StopFlag) -> int:
    seed = args.seed if args.seed is not None else sc.run.seeds[0]
    t0 = time.time()
    sim = Simulation(sc, seed, t0)
    renderer = Renderer(sim.world, np.random.default_rng([seed, 0x5EE])) if args.frames == "pixels" else None
    boot = t0 - 60.0
    ugv_ids = [vid for vid, _, _ in args.ugv]
    ugv_aps = [SimAutopilot("127.0.0.1", port, sysid, boot_unix_s=boot,
                            on_mission=lambda items, i=i: sim.set_mission(i, items)).start()
               for i, (vid, port, sysid) in enumerate(args.ugv)]
    uav_id, uav_port, uav_sys = args.uav
    uav_ap = SimAutopilot("127.0.0.1", uav_port, uav_sys, boot_unix_s=boot, mav_type=mavlink2.MAV_TYPE_QUADROTOR).start()
    duration = args.duration or sc.run.duration_s
    # the scenario's clock starts now that the renderer is built (its terrain takes seconds): started
    # before, the first seconds of frames went out late, stamped on time
    t0 = sim.t0_unix_s = time.time()
    try:
        with ZenohBus.open(bus_config_from_args(args)) as bus:
            bus.declare_alive(keys.alive(args.team, "sim"))
            sensor_key = keys.key(args.team, uav_id, "sensor")
            frame_key = keys.key(args.team, uav_id, "frame")
            truth_key = keys.key(args.team, "sim", "truth")
            log.info("scenario %s seed %d for %.0f s: %d UGVs, UAV at %.0f m", sc.name, seed, duration,
                     sc.ugvs.count, sc.uav.altitude_agl_m)
            frames = 0
            for tick in sim.ticks(duration):
                if stop.is_set():
                    break
                if tick.frame_seq is not None:
                    # the world is at tick.t_s already: the frame is made before that instant and goes out
                    # at it, as a camera's does when its exposure ends (rendering is the simulator's cost,
                    # not the team's latency)
                    with sim.lock:
                        pose = sim.world.camera_pose()
                        img = renderer.render(pose) if renderer is not None else None
                        det = sim.sensor_detections(pose, tick.t_s, tick.frame_seq, uav_id) if renderer is None else None
                        truth = sim.truth(tick.t_s, tick.frame_seq, ugv_ids)
                        uav_state = sim.uav_state(pose, tick.t_s)
                    frame = encode_frame(uav_id, t0 + tick.t_s, tick.frame_seq, img, args.frame_jpeg) if img is not None else None
                # wait for the tick's instant, so every stamp is a real capture time
                sleep = t0 + tick.t_s - time.time()
                if sleep > 0:
                    time.sleep(sleep)
                for i in tick.lost:
                    log.warning("%s is lost (scenario event at %.1f s)", ugv_ids[i], tick.t_s)
                    ugv_aps[i].go_silent()
                for f in tick.fixes:
                    ugv_aps[f.ugv_index].send_state(f.state)
                if tick.frame_seq is None:
                    continue
                uav_ap.send_state(uav_state)
                if frame is not None:
                    bus.publish(frame_key, frame)
                else:
                    bus.publish(sensor_key, det)
                bus.publish(truth_key, truth)
                frames += 1
            log.info("scenario finished after %.1f s, %d frames; missions received: %s", time.time() - t0, frames,
                     [ap.missions_received for ap in ugv_aps])
    finally:
        for ap in ugv_aps + [uav_ap]:
            ap.stop()
    return 0
