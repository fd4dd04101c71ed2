"""The renderer's objects cover each pixel by the share of its area they cover, as a lens integrates
light, so a still object that moves by a fraction of a pixel (hover wobble) does not flicker."""

import cv2
import numpy as np
import pytest

from uvteam_sim.render import _ONE, _fill


def _diamond(cx: float, cy: float, r: float = 8.3) -> np.ndarray:
    return np.array([[cx, cy - r], [cx + r, cy], [cx, cy + r], [cx - r, cy]])


def _fixed(poly: np.ndarray) -> np.ndarray:
    return np.rint(poly * _ONE).astype(np.int32)


@pytest.mark.parametrize("dx, dy", [(0.0, 0.0), (0.3125, 0.5625), (0.75, 0.125)])
def test_a_polygon_covers_its_area_and_no_pixel_outside_it(dx, dy):
    img = np.zeros((40, 40), np.uint8)
    poly = _diamond(20 + dx, 20 + dy)
    _fill(img, _fixed(poly), 255)
    area_px = 2 * 8.3 ** 2      # OpenCV fills the cells an edge runs through on the right and lower sides (+1 %)
    assert abs(img.sum() / 255 - area_px) < 0.02 * area_px
    # a pixel wholly inside is full, one wholly outside untouched
    assert img[20, 20] == 255 and img[20 + int(dy), 20 + int(dx) + 10] == 0
    # each pixel's share against a 64 x 64 count of the same polygon
    fine = np.zeros((40 * 64, 40 * 64), np.uint8)
    cv2.fillPoly(fine, [np.rint(((poly + 0.5) * 64 - 0.5) * _ONE).astype(np.int32)], 255, cv2.LINE_8, 4)
    share = cv2.resize(fine, (40, 40), interpolation=cv2.INTER_AREA).astype(float)
    assert np.abs(img.astype(float) - share).max() <= 20      # of 255: the 16 x 16 count's resolution


def test_a_still_polygon_moved_by_a_fraction_of_a_pixel_changes_no_pixel_by_much():
    """OpenCV's anti-aliased fill changes a pixel by up to 188 of 255 for a 1/32 px step of this diamond;
    the share of area changes by at most 1/32 px times the edge's length in the pixel (~11 grey levels),
    plus the count's resolution."""
    prev, worst = None, 0
    for k in range(65):
        img = np.zeros((40, 40), np.uint8)
        _fill(img, _fixed(_diamond(20 + 0.37 * k / 64, 20 + k / 64)), 255)
        if prev is not None:
            worst = max(worst, int(np.abs(img.astype(int) - prev).max()))
        prev = img.astype(int)
    assert worst <= 32


def test_fill_blends_a_colour_and_clips_at_the_image_edge():
    img = np.full((10, 10, 3), 100, np.uint8)
    _fill(img, _fixed(np.array([[-5.0, -5.0], [4.5, -5.0], [4.5, 4.5], [-5.0, 4.5]])), (200, 0, 50))
    assert tuple(img[0, 0]) == (200, 0, 50) and tuple(img[9, 9]) == (100, 100, 100)
    # pixel x covers [x - 0.5, x + 0.5): the edge at x = 4.5 is pixel 4's right edge
    # (and the edge's own cells, a 16th of pixel 5)
    assert tuple(img[2, 4]) == (200, 0, 50) and np.abs(img[2, 5].astype(int) - 100).max() <= 100 // 16 + 1
    half = np.full((10, 10), 0, np.uint8)
    _fill(half, _fixed(np.array([[2.0, 2.0], [6.0, 2.0], [6.0, 6.0], [2.0, 6.0]])), 255)
    # half of pixels 2 and 6 (OpenCV's fill takes the cells an edge runs between on its right: +1/16)
    assert abs(int(half[4, 2]) - 128) <= 17 and abs(int(half[4, 6]) - 128) <= 17 and half[4, 4] == 255
    before = half.copy()
    _fill(half, _fixed(np.array([[50.0, 50.0], [60.0, 50.0], [60.0, 60.0]])), 255)    # wholly outside: nothing
    assert (half == before).all() and half[0].sum() == 0


def test_objects_are_drawn_by_area_unless_a_scenario_asks_for_opencvs_fill():
    from uvteam.scenario import Lens
    assert Lens().area_fill and Lens(objects="area").area_fill
    assert not Lens(objects="opencv").area_fill
