"""Render one camera frame of each scenario in scenarios/ as PNG, 10 s into seed 1 (UGVs on their way to
station, driven by the team's own nodes over the sensor model).

    .venv/bin/python docs/make_worlds_png.py             # docs/worlds/<name>.png, on the procedural ground
    .venv/bin/python docs/make_worlds_png.py --imagery   # out/worlds/<name>.png, on the scenario's own ground

The real imagery (AU-AIR, SDD) is non-commercial: a frame rendered from it is a derivative, so those go
to out/ (ignored by git) and only procedural-ground frames (same camera, tilt, lens, distractors) are
kept under docs/worlds/.
"""

from __future__ import annotations

import argparse
import hashlib
import sys
from dataclasses import replace
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--imagery", action="store_true", help="keep each scenario's own ground (output under out/worlds)")
    ap.add_argument("--at-s", type=float, default=10.0, help="seconds into the run")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("scenarios", nargs="*", type=Path, default=sorted((REPO / "scenarios").glob("*.toml")))
    args = ap.parse_args(argv)
    import cv2  # noqa: PLC0415
    import numpy as np  # noqa: PLC0415

    from uvteam.io.files import ImageryMissing, load_scenario  # noqa: PLC0415
    from uvteam.scenario import Ground  # noqa: PLC0415
    from uvteam_sim.experiment import SimTeam  # noqa: PLC0415
    from uvteam_sim.render import Renderer  # noqa: PLC0415

    out = REPO / ("out/worlds" if args.imagery else "docs/worlds")
    out.mkdir(parents=True, exist_ok=True)
    written: dict[bytes, Path] = {}
    for path in args.scenarios:
        try:
            sc = load_scenario(path)
        except ImageryMissing as exc:
            print(f"skipping {path}: {exc.key}: {exc.reason}", file=sys.stderr)
            continue
        name = sc.name
        if not args.imagery and sc.ground != Ground():
            sc = replace(sc, ground=Ground(), lens=replace(sc.lens, prefilter="auto"))
            name += "-procedural"
        team = SimTeam(sc, args.seed, "sensor")
        team.run(args.at_s)
        world = team.sim.world
        frame = Renderer(world, np.random.default_rng([args.seed, 0x5EE])).render(world.camera_pose())
        dst = out / f"{name}.png"
        key = hashlib.sha256(frame.tobytes()).digest()
        if key in written:     # e.g. real-alt60-lm6 on the procedural ground is desert-alt60-lm6-distractors
            print(f"{dst.name}: the same frame as {written[key].name}; not written", file=sys.stderr)
            continue
        written[key] = dst
        cv2.imwrite(str(dst), frame, [cv2.IMWRITE_PNG_COMPRESSION, 9])
        print(dst)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
