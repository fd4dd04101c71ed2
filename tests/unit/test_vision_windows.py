"""Where the UAV's vision looks for roof labels (uvteam.vision.uav): in windows round each UGV's prediction
and last place, the whole frame only to acquire."""

import numpy as np

import uvteam.vision.uav as uav
from uvteam.vision.uav import ACQUIRE_EVERY, LabelExpectation, UavVision, UavVisionConfig
from uvteam_sim.render import LABEL_BGR

ALT_M, FOCAL_PX = 60.0, 1000.0
LABEL_PX = int(FOCAL_PX / ALT_M)          # a 1 m roof label at 60 m
SPOTS = {"red": (300.0, 200.0), "blue": (900.0, 500.0)}


def searched(monkeypatch, expect_colors, frames=2 * ACQUIRE_EVERY + 2):
    """Run the vision on a still frame with a red and a blue roof label, predicted (where they are) for
    ``expect_colors``: per frame, whether the label search covered the whole frame, the colors of the
    label-sized blobs it found, and the labels taken."""
    img = np.full((720, 1280, 3), 90, np.uint8)
    for color, (x, y) in SPOTS.items():
        img[int(y) - LABEL_PX // 2:int(y) + LABEL_PX // 2, int(x) - LABEL_PX // 2:int(x) + LABEL_PX // 2] = LABEL_BGR[color]
    vision = UavVision(UavVisionConfig(FOCAL_PX, tuple(SPOTS)))
    whole, seen, taken = [], [], []
    real = uav.label_candidates

    def spy(frame, cfg, colors, windows):
        cands = real(frame, cfg, colors, windows)
        whole.append(not windows)
        seen.append({c.color for c in cands})
        return cands

    monkeypatch.setattr(uav, "label_candidates", spy)
    for k in range(frames):
        expect = {c: LabelExpectation(SPOTS[c], 3.0 * LABEL_PX, False) for c in expect_colors}
        taken.append(set(vision.update(img, 0.1 * k, ALT_M, expect).landmarks.ugv))
    return whole, seen, taken


def test_every_color_predicted_the_whole_frame_is_never_searched(monkeypatch):
    # each label is found in its prediction's window (taking it is the label tracks' business: parked, never)
    whole, seen, _ = searched(monkeypatch, ("red", "blue"))
    assert not any(whole) and all(s == {"red", "blue"} for s in seen)


def test_labels_without_predictions_are_acquired_on_the_whole_frame_every_so_often(monkeypatch):
    # found, each is looked for round its last place; the whole frame again every ACQUIRE_EVERY frames
    whole, seen, taken = searched(monkeypatch, ())
    assert [k for k, w in enumerate(whole) if w] == [0, ACQUIRE_EVERY, 2 * ACQUIRE_EVERY]
    assert all(t == {"red", "blue"} for t in taken)


def test_a_color_without_a_prediction_nor_a_last_place_is_looked_for_on_the_whole_frame(monkeypatch):
    # blue is not predicted while red is: its label is not taken (no confirmed track), so never has a last place
    whole, seen, taken = searched(monkeypatch, ("red",))
    assert all(whole) and all("blue" in s for s in seen) and not any("blue" in t for t in taken)
