"""`uvteam bench <what>`: benchmarks that print figures (not timed tests).

  localize   one localizer step (6 landmarks; 20 and 10,000 blobs) beside the step as it was (a source
             checkout) and a bare OpenCV findHomography + perspectiveTransform, interleaved, one core
  codec      a 20-blob Detections message: decode and encode beside plain msgpack, interleaved, one core
  vision     UAV motion detector beside the plain paper pipeline and the warp floor, interleaved, one core,
             on karma.mp4 and AU-AIR (1280x720, 1920x1080) and rendered frames; HOG fps at 640x480
  render     (from the simulator) renderer fps and the whole UAV pixel pipeline's fps on rendered frames
  latency    frame capture -> crowd message at a UGV service over loopback zenoh, and each process's memory
  frames     frames from the simulator to the UAV service over zenoh: shared memory on and off
  scaling    N teams of 1 UAV + 6 UGVs (sensor model) through one router, N = 1, 2, ... up to the knee
  all        everything above but scaling

Ratios (project / yardstick, measured interleaved in one process) are the figures to compare across
machines and days; absolute figures are printed beside them with the date.
"""

from __future__ import annotations

import argparse
import os


def _one_core() -> set[int] | None:
    """Pin this process to one core (and OpenCV to one thread); returns the old affinity."""
    old = None
    try:
        old = os.sched_getaffinity(0)
        os.sched_setaffinity(0, {min(old)})
    except (AttributeError, OSError):
        pass
    try:
        import cv2  # noqa: PLC0415

        cv2.setNumThreads(1)
    except ImportError:
        pass
    return old


def _all_cores(old: set[int] | None) -> None:
    if old:
        try:
            os.sched_setaffinity(0, old)
        except OSError:
            pass


def _plugins() -> dict:
    """Benchmarks other packages register in the ``uvteam.benchmarks`` entry-point group (name -> run())."""
    from importlib.metadata import entry_points  # noqa: PLC0415

    return {ep.name: ep for ep in entry_points(group="uvteam.benchmarks")}


def main(argv: list[str] | None = None) -> int:
    plugins = _plugins()
    ap = argparse.ArgumentParser(prog="uvteam bench", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["localize", "codec", "vision", "latency", "frames", "scaling", *sorted(plugins),
                                     "all"])
    ap.add_argument("--frames", choices=["pixels", "sensor"], default="pixels",
                    help="latency: rendered frames through the UAV's pixel pipeline (default), or the sensor model")
    ap.add_argument("--ugvs", type=int, default=None, help="latency: UGVs in the team (default: the demo's 6)")
    ap.add_argument("--rate", type=float, default=None, metavar="HZ",
                    help="latency: UAV frames a second (default: the demo's 10)")
    ap.add_argument("--duration", type=float, default=60.0, metavar="S", help="latency: seconds (default 60)")
    ap.add_argument("--max-teams", type=int, default=4, help="scaling: the most teams to try (default 4)")
    args = ap.parse_args(argv)
    old = _one_core()
    if args.what in ("localize", "all"):
        from .bench_localize import bench_localize  # noqa: PLC0415

        bench_localize()
    if args.what in ("codec", "all"):
        from uvteam_ground import bench_codec  # noqa: PLC0415

        bench_codec.run()
    if args.what in ("vision", "all"):
        from uvteam_ground import bench_vision  # noqa: PLC0415

        bench_vision.run()
    for name, ep in sorted(plugins.items()):
        if args.what in (name, "all"):
            ep.load()()
    _all_cores(old)  # the team is ten processes or more: they must not inherit the one-core pin
    if args.what in ("frames", "all"):
        from uvteam_ground import bench_frames  # noqa: PLC0415

        bench_frames.run()
    if args.what in ("latency", "all"):
        from uvteam_ground import bench_latency  # noqa: PLC0415

        bench_latency.run(duration_s=args.duration, frames=args.frames, ugvs=args.ugvs, rate_hz=args.rate)
    if args.what == "scaling":
        from uvteam_ground import bench_scaling  # noqa: PLC0415

        bench_scaling.run(max_teams=args.max_teams, duration_s=min(args.duration, 30.0))
    return 0
