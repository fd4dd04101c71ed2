"""The speed work's pieces: the motion detector's shortcuts against the plain way of doing the same
step, and the benchmarks' own machinery (yardstick, interleaving, scenario variants, /proc readers)."""

import os
from pathlib import Path

import cv2
import numpy as np
import pytest

from uvteam.io.files import load_scenario
from uvteam.vision import motion
from uvteam.vision.motion import MotionConfig, MotionDetector


def texture(h, w, seed=0):
    rng = np.random.default_rng(seed)
    t = cv2.GaussianBlur(rng.integers(0, 255, (h, w)).astype(np.uint8), (0, 0), 2.0)
    return cv2.cvtColor(cv2.normalize(t, None, 0, 255, cv2.NORM_MINMAX), cv2.COLOR_GRAY2BGR)


def panning(n=12, walkers=True):
    """A camera panning and zooming slowly over texture, with a few dark walkers crossing."""
    ground = texture(1000, 1600, seed=3)
    for k in range(n):
        H = cv2.getRotationMatrix2D((800, 500), 0.1 * k, 1.0 + 0.003 * k)
        H[:, 2] += (4 * k, 2 * k)
        img = cv2.warpAffine(ground, H, (1600, 1000))[140:860, 160:1440].copy()
        if walkers:
            for i in range(5):
                cv2.circle(img, (500 + 30 * i + 6 * k, 300 + 11 * i), 7, (15, 15, 15), -1)
        yield k, img


def test_corners_are_followed_not_detected_every_frame(monkeypatch):
    # goodFeaturesToTrack on the first pair only: afterwards the inliers are followed and topped up
    calls = []
    real = cv2.goodFeaturesToTrack
    monkeypatch.setattr(motion.cv2, "goodFeaturesToTrack", lambda *a, **k: calls.append(1) or real(*a, **k))
    det = MotionDetector(MotionConfig(speckle="neighbours", max_corners=200, lk_window_px=15))
    for k, img in panning():
        r = det.update(img, 0.1 * k)
        if k:
            assert r.registration.n_inliers > 80 and r.residual_px < 0.3, (k, r.registration)
    assert 1 <= len(calls) <= 3, len(calls)


def reference_history(frames, cfg):
    """Step 4 the plain way: the whole age map warped with the camera every frame, never clamped."""
    det = MotionDetector(cfg)
    seen = []
    orig = det._history

    def full(moving, warp, M, dt_s):
        age = warp(det._ref_age, cv2.INTER_NEAREST, 255) if hasattr(det, "_ref_age") else np.full(moving.shape, 255, np.uint8)
        age = cv2.add(age, int(min(255, max(0, round(dt_s / motion.AGE_UNIT_S)))))
        age[moving > 0] = 0
        det._ref_age = age
        _, recent_ref = cv2.threshold(age, int(round(cfg.history_s / motion.AGE_UNIT_S)), 255, cv2.THRESH_BINARY_INV)
        recent = orig(moving, warp, M, dt_s)
        seen.append((recent_ref, recent))
        return recent
    det._history = full
    for k, img in frames:
        det.update(img, 0.1 * k)
    return seen


@pytest.mark.parametrize("speckle", ["open", "neighbours"])   # the history opened (neighbours) or not
def test_history_warped_in_its_box_is_the_whole_warped_history(speckle):
    cfg = MotionConfig(speckle=speckle, history_s=0.4)
    seen = reference_history(panning(10), cfg)
    assert len(seen) >= 8
    for k, (ref, got) in enumerate(seen):
        raw = got if speckle == "open" else None
        if raw is not None:
            assert np.array_equal(ref, raw), f"frame {k}: {np.count_nonzero(ref != raw)} pixels differ"
        else:   # neighbours: the returned history is opened; the reference is not
            assert np.array_equal(cv2.morphologyEx(ref, cv2.MORPH_OPEN, MotionDetector(cfg)._k_open), got), k


def _perspective(tilt):
    """A homography between two views of a hovering, wobbling camera: a shift, a small turn and ``tilt``
    of projective part (per px), far from affine over a 1280 x 720 frame."""
    return np.array([[1.002, 0.004, 2.7], [-0.003, 0.998, -1.9], [tilt, -0.6 * tilt, 1.0]])


@pytest.mark.parametrize("interp", [cv2.INTER_LINEAR, cv2.INTER_NEAREST])
def test_a_perspective_warp_through_source_maps_is_warp_perspectives(interp):
    # the maps are exact every 8 px and bilinear between (within 0.001 px): they round to another 1/32 px
    # only where the exact source lies within a hair of a step
    img = cv2.cvtColor(texture(720, 1280, seed=4), cv2.COLOR_BGR2GRAY)
    M = _perspective(2e-5)
    assert motion._source_maps(M, 1280, 720) is not None
    warp = motion._warper(M, 1280, 720)
    got = warp(img, interp, 7)
    ref = cv2.warpPerspective(img, M, (1280, 720), flags=interp, borderMode=cv2.BORDER_CONSTANT, borderValue=7)
    diff = cv2.absdiff(got, ref)
    if interp == cv2.INTER_LINEAR:   # a step of 1/32 px moves a pixel by a grey level, seldom more
        assert np.count_nonzero(diff) < 0.005 * diff.size and np.count_nonzero(diff > 1) < 1e-4 * diff.size
    else:                            # rounded to the other whole pixel where the source is a hair from .5
        assert np.count_nonzero(diff) < 5e-4 * diff.size
    roi = (300, 120, 700, 500)
    assert np.array_equal(warp(img, interp, 7, roi), got[120:500, 300:700])    # a part is the whole's part


def test_a_warp_that_bends_between_the_maps_points_is_warp_perspective():
    img = cv2.cvtColor(texture(720, 1280, seed=4), cv2.COLOR_BGR2GRAY)
    M = _perspective(1e-3)    # a steep view: over 8 px the source bends by more than the maps allow
    assert motion._source_maps(M, 1280, 720) is None
    horizon = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0 / 600.0, 0.0, 1.0]])   # a source at infinity at x 600
    with np.errstate(divide="ignore", invalid="ignore"):
        assert motion._source_maps(horizon, 1280, 720) is None
    ref = cv2.warpPerspective(img, M, (1280, 720), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                              borderValue=0)
    assert np.array_equal(motion._warper(M, 1280, 720)(img, cv2.INTER_LINEAR, 0), ref)


def test_plain_pipeline_and_interleaved_comparison():
    from uvteam_ground.bench_vision import PlainPipeline, compare

    cfg = MotionConfig(speckle="neighbours", merge_px=13, min_area_px=200.0)
    frames = [img for _, img in panning(8)]
    plain = PlainPipeline(cfg)
    counts = [plain.update(f) for f in frames]
    assert counts[0] == 0 and max(counts[2:]) >= 1       # the walkers, seen by the yardstick too
    r = compare(frames, cfg, 0.1)
    assert r["frames"] == len(frames) - 1
    assert r["fps_warp"] > r["fps_plain"] > 0 and r["fps_project"] > 0
    assert r["ratio_project_plain"] == pytest.approx(r["fps_project"] / r["fps_plain"])


def test_uav_motion_config_is_the_pipelines():
    from uvteam_ground.bench_vision import uav_motion_config

    cfg = uav_motion_config(1280, 720, 50.0)
    assert (cfg.process_scale, cfg.speckle, cfg.max_corners, cfg.lk_window_px) == (0.5, "neighbours", 200, 15)
    assert uav_motion_config(1280, 720, 200.0).process_scale == 1.0     # a person under 3 px at half scale


@pytest.mark.parametrize("ugvs, rate", [(None, None), (12, 30.0), (3, None)])   # the demo's; issue 15's; fewer
def test_scenario_variant_loads(tmp_path, ugvs, rate):
    from uvteam_ground.bench_latency import scenario_variant

    sc = load_scenario(scenario_variant(tmp_path, ugvs, rate))
    assert sc.ugvs.count == (ugvs or 6) and len(sc.ugvs.colors) == sc.ugvs.count
    assert sc.run.frame_rate_hz == (rate or 10.0)


def test_proc_readers_see_this_process():
    from uvteam_ground.bench_frames import cpu_s, rss_mb

    assert 5.0 < rss_mb(os.getpid()) < 4000.0
    assert cpu_s(os.getpid()) > 0.0
    assert rss_mb(2 ** 22 + 17) != rss_mb(2 ** 22 + 17) and cpu_s(2 ** 22 + 17) == 0.0   # no such process


def test_codec_bench_figures():
    from uvteam_ground.bench_codec import interleaved, realistic_detections
    from uvteam.messages import Detections, decode, encode

    m = realistic_detections()
    assert len(m.blobs) == 20 and len(m.landmarks) == 6 and decode(Detections, encode(m)) == m
    a, b = interleaved(lambda: sum(range(200)), lambda: None, block=50, blocks=4)
    assert a > b > 0


def test_rendered_frames_entry_point():
    from importlib.metadata import entry_points

    eps = {e.name: e for e in entry_points(group="uvteam.bench_frames")}
    assert "rendered" in eps
    if not (Path(__file__).resolve().parents[3] / "shared" / "scenarios").is_dir():
        pytest.skip("../shared/scenarios is not beside the checkout")
    sets = eps["rendered"].load()(n=3)
    assert [s[0] for s in sets] == ["rendered paper-fig7-alt50 1280x720", "rendered paper-fig7-alt200 1280x720",
                                    "rendered real-alt120-lm6 1280x720"]
    assert all(len(s[1]) == 3 and s[1][0].shape == (720, 1280, 3) for s in sets)
