"""Monte-Carlo accuracy of the localizer step with a nadir pinhole camera over flat ground.

1 px landmark noise, 2 px crowd-centre noise, exact GNSS; 4 and 6 landmarks on a ring around the
crowd; 50 m and 200 m AGL. Prints the error statistics; asserts that the reported 95 % radius holds
the truth in 90-98 % of trials.
"""

import numpy as np
import pytest

from uvteam.camera import CameraPose, PinholeCamera, project
from uvteam.blobs import Blobs, Landmarks
from uvteam.localizer import FrameObservation, LocalizerConfig, LocalizerState, UgvTrack, localize_step

CAM = PinholeCamera(1280, 720, 78.0)
NAMES = ["red", "green", "blue", "yellow", "magenta", "cyan"]


def run_trials(alt_m, ring_m, n_landmarks, trials, seed):
    rng = np.random.default_rng(seed)
    cfg = LocalizerConfig(image_coordinates="color", gate_px=4.0)
    errs, inside = [], []
    for _ in range(trials):
        crowd = rng.uniform(-3, 3, 2)
        ang = np.sort(rng.uniform(0, 2 * np.pi, n_landmarks))
        ang = np.linspace(0, 2 * np.pi, n_landmarks, endpoint=False) + rng.uniform(-0.3, 0.3, n_landmarks) + ang[0]
        r = ring_m * rng.uniform(0.8, 1.2, n_landmarks)
        lm = crowd + np.column_stack([r * np.sin(ang), r * np.cos(ang)])
        pose = CameraPose(*(crowd + rng.normal(0, 2, 2)), alt_m, yaw_deg=rng.uniform(0, 360))
        lm_px = project(CAM, pose, lm) + rng.normal(0, 1.0, (n_landmarks, 2))
        c_px = project(CAM, pose, crowd[None]) + rng.normal(0, 2.0, (1, 2))
        names = NAMES[:n_landmarks]
        tracks = {u: UgvTrack(np.array([0.0, 2.0]), np.array([lm[i], lm[i]]), np.zeros(2)) for i, u in enumerate(names)}
        # the detector declares its noise with its detections: 1 px for labels, 2 px for crowd centres
        obs = FrameObservation(1.0, Landmarks(tuple(names), lm_px), Blobs(c_px, np.column_stack([c_px - 10, c_px + 10]),
                                                                          np.ones(1)), sigma_color_px=1.0,
                               sigma_crowd_blob_px=2.0)
        _, res = localize_step(LocalizerState(), obs, tracks, cfg)
        assert len(res.crowds) == 1
        c = res.crowds[0]
        e = np.hypot(c.east_m - crowd[0], c.north_m - crowd[1])
        errs.append(e)
        inside.append(e <= c.radius95_m)
    return np.array(errs), float(np.mean(inside))


@pytest.mark.parametrize("alt_m, ring_m", [(50.0, 12.0), (200.0, 40.0)])
@pytest.mark.parametrize("n_landmarks", [4, 6])
def test_uncertainty_coverage(alt_m, ring_m, n_landmarks):
    errs, coverage = run_trials(alt_m, ring_m, n_landmarks, trials=1500, seed=int(alt_m) + n_landmarks)
    print(f"\nalt {alt_m:.0f} m, {n_landmarks} landmarks: error mean {errs.mean():.3f} m, "
          f"p95 {np.percentile(errs, 95):.3f} m, max {errs.max():.3f} m; 95% radius coverage {coverage:.3f}")
    assert 0.90 <= coverage <= 0.98
