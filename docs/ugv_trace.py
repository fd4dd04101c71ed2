"""Per frame between two times: each UGV as the localizer holds it (fix, 1-sigma, source, speed), where the
frame's transform puts it in the image and which blob it was paired with, then every blob and each crowd
estimate's pixel distance to every UGV. A diagnostic for docs/results-worlds.md (session 26: a UGV whose own
blob is a piece of it); not part of the product. Use it on tuning seeds or to trace a figure already reported.

    .venv/bin/python docs/ugv_trace.py scenarios/real-alt60-lm6-gnss1.toml 4 4.3 4.5
"""

import sys

import numpy as np

import uvteam.localizer as L
import uvteam.nodes.localizer as node_module
from uvteam.io.files import load_scenario
from uvteam_sim.experiment import T0, SimTeam


def main(path: str, seed: int, t0_s: float, t1_s: float) -> None:
    team = SimTeam(load_scenario(path), seed, "pixels")
    step = node_module.localize_step

    def looked_at(state, obs, tracks, cfg):
        new_state, res = step(state, obs, tracks, cfg)
        t = obs.stamp_s - T0
        if not t0_s <= t <= t1_s:
            return new_state, res
        pos = L.ugv_positions(tracks, obs.stamp_s, cfg)
        pairing = L.pair_landmarks(state, obs, cfg)
        fit = L.fit_transform(state, obs.stamp_s, L.landmark_pixels(obs, pairing, cfg), pos, cfg,
                              L.prior_of(state, obs, cfg))
        to_px = fit.fit.ground_to_px if fit.fit is not None else None
        print(f"t {t:.2f} s  {res.quality.value}, used {res.landmarks_used}, outliers {res.outlier_landmarks}, "
              f"{obs.px_per_m or float('nan'):.2f} px/m")
        b = obs.blobs
        for u in sorted(pos):
            p = pos[u]
            x, y = to_px(p.en_m[None])[0] if to_px else (float("nan"),) * 2
            print(f"   {u}: ({p.en_m[0]:.2f}, {p.en_m[1]:.2f}) m, sigma {p.sigma_m:.2f} m, {p.source}, "
                  f"{p.speed_m_s or 0.0:.2f} m/s -> ({x:.1f}, {y:.1f}) px, its blob {pairing.blob_of_ugv.get(u)}")
        for j in range(len(b.xy_px)):
            m2 = b.area_px[j] / obs.px_per_m ** 2 if obs.px_per_m else float("nan")
            print(f"   blob {j}: ({b.xy_px[j][0]:.1f}, {b.xy_px[j][1]:.1f}) px, {b.area_px[j]:.0f} px ({m2:.1f} m2), "
                  f"label {b.ugv[j] if j < len(b.ugv) and b.ugv[j] else '-'}")
        for c in res.crowds:
            d = {u: round(float(np.hypot(*(to_px(pos[u].en_m[None])[0] - b.xy_px[c.blob_index]))), 1)
                 for u in pos} if to_px else {}
            print(f"   crowd on blob {c.blob_index}: ({c.east_m:.2f}, {c.north_m:.2f}) m, px to each UGV {d}")
        return new_state, res

    node_module.localize_step = looked_at
    team.run(t1_s + 0.2)


if __name__ == "__main__":
    if len(sys.argv) != 5:
        raise SystemExit(__doc__)
    main(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]))
