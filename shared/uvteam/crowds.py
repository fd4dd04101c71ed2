"""From the localizer's per-frame estimates to the crowds the team is told about. Pure: no I/O, no clock.

The motion detector cuts a blob in two where two groups, each big enough to be a crowd, walk a gap
apart (:mod:`uvteam.vision.motion`, step 6), so two crowds that pass close by stay two. But one crowd
can have such a gap inside it too. Which it is shows in how the parts move: the parts of one crowd
keep their offset, two crowds drift together or apart. So each frame (:func:`report_crowds`):

1. every estimate is tracked on the ground (:class:`uvteam.tracking.CrowdTracker`), and its 95 % radius
   widened when the track's estimates over the last ``scatter_s`` scatter about a straight line at
   constant speed more than the noise the radius holds changes from frame to frame: a detector
   may declare only the offset a crowd's blob keeps (:mod:`uvteam.detector_noise`: the pixel
   pipeline does) and leave what the blob does between frames (parts lost and found, ground texture,
   pixel noise) to be measured here, in these very frames;
2. estimates closer than ``near_m`` are parts of one crowd, and so is a small part (``straggler_ratio``
   of the other's moving pixels) whose footprint is within ``near_gap_m`` of a bigger one's, as the
   walkers a UGV cuts off a crowd's edge; unless they move apart or together faster than
   ``max_rel_speed_m_s``: the slope of a straight line fitted to the distance between them in the
   frames of the last ``window_s`` in which both were seen, ``significance`` standard errors from
   zero (a part's centre jitters by up to a metre as walkers cross between parts, so a slope over
   many frames, not two positions); parts not seen apart over ``min_span_s`` are one crowd;
3. what is learnt sticks while both tracks live (:class:`GroupingState`): parts once ``apart_m`` or more
   apart, or moving apart or together in ``apart_frames`` frames in a row, stay two crowds. Two crowds
   that close in slowly, or part again after walking as one blob, are then not joined by a frame in
   which their drift is not (yet) significant; a single significant frame, which one crowd's jittering
   parts do show now and then, latches nothing;
4. two crowds known apart whose blobs become one (one of them unseen, both predicted centres in one
   blob's footprint) are remembered as that blob's track holding a second crowd
   (:attr:`GroupingState.holds`), until the unseen one's track is seen again; the memory goes on with
   whichever track takes the blob on. When a part first seen after the merge appears beside that
   track (within ``near_m``), it is the crowd coming out again: two crowds at once, with no wait for a
   drift to show (``min_span_s`` plus ``apart_frames`` frames, in which the two were reported as one);
5. only parts seen ``confirm_hits`` times take part (a blob of one frame neither is a crowd nor pulls
   one); a crowd is the area-weighted mean of its parts (the detector's moving pixels), its footprint
   the box round theirs, its 95 % radius the largest of theirs, reported under its longest-seen
   part's track (id, velocity).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from .localizer import R95_PER_SIGMA, CrowdEstimate
from .tracking import CrowdTrack, CrowdTracker

__all__ = ["GroupingConfig", "GroupingState", "Held", "ReportedCrowd", "crowd_groups", "report_crowds"]


@dataclass(frozen=True, slots=True)
class GroupingConfig:
    near_m: float = 12.0          # parts of one crowd lie within this of each other (three crowd spreads)
    near_gap_m: float = 4.0       # ... or their footprints this close (the detector's crowd spacing), when
    straggler_ratio: float = 0.4  # ... one has at most this fraction of the other's moving pixels
    window_s: float = 3.0         # the distance between two parts is fitted over this long
    min_span_s: float = 1.0       # the frames in which both parts were seen must span this long
    max_rel_speed_m_s: float = 0.4  # two parts moving apart or together faster than this are two crowds
    significance: float = 4.0     # ... and by this many standard errors of the fitted slope
    confirm_hits: int = 3         # a crowd is reported once its longest-seen part was seen this often
    apart_m: float = 18.0         # parts once this far apart are two crowds while both are tracked,
    apart_frames: int = 10        # ... and so are parts whose distance changed significantly this many frames in a row
    scatter_s: float = 10.0       # a crowd's radius counts the scatter of its estimates over this long
    scatter_min_points: int = 5   # ... once there are this many

    def __post_init__(self) -> None:
        for name in ("near_m", "window_s", "min_span_s", "max_rel_speed_m_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not (0.0 <= self.straggler_ratio <= 1.0 and self.near_gap_m >= 0.0 and self.significance >= 0.0):
            raise ValueError("straggler_ratio must be in [0, 1], near_gap_m and significance >= 0")
        if not (self.apart_m >= self.near_m and self.apart_frames >= 1):
            raise ValueError(f"apart_m must be >= near_m and apart_frames >= 1, got {self.apart_m}, {self.apart_frames}")


HOLD_MARGIN_M = 2.0        # a predicted centre this far outside a footprint is still in it (track velocities are rough)
Pair = tuple[int, int]   # two track ids, the smaller first


@dataclass(frozen=True, slots=True, order=True)
class Held:
    """A crowd a blob took in (step 4)."""

    since_s: float                 # when the blob took it in
    pair: Pair                     # the two tracks known apart that became one blob
    lost: tuple[int, ...]          # the tracks the blob took in (unseen since)


@dataclass(frozen=True, slots=True)
class GroupingState:
    """What :func:`report_crowds` carries from frame to frame; never mutated, each frame makes a new one."""
    tracker: CrowdTracker = field(default_factory=CrowdTracker)
    apart: frozenset[Pair] = frozenset()                        # pairs of tracks known to be two crowds
    streak: Mapping[Pair, int] = field(default_factory=dict)    # frames in a row each pair's distance changed
    holds: Mapping[int, tuple[Held, ...]] = field(default_factory=dict)  # per track, the other crowds its blob took in


def crowd_groups(tracks: list[CrowdTrack], stamp_s: float, cfg: GroupingConfig = GroupingConfig(),
                 boxes_en: np.ndarray | None = None, areas: np.ndarray | None = None,
                 apart: frozenset[Pair] = frozenset(), streak: Mapping[Pair, int] | None = None
                 ) -> tuple[list[int], frozenset[Pair], dict[Pair, int]]:
    """A group label per track (this frame's estimates): tracks with one label are one crowd.
    ``boxes_en`` (n, 4): each estimate's footprint as east/north min/max; ``areas`` (n,): its moving pixels;
    ``apart``, ``streak``: what earlier frames learnt (:class:`GroupingState`). Returns the labels and
    the pairs known apart and the streaks after this frame."""
    n = len(tracks)
    parent = list(range(n))
    apart = set(apart)
    streak, new_streak = streak or {}, {}

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    since = stamp_s - cfg.window_s - 1e-6      # the drift is fitted over the last window_s of the trails
    trails = [{k: (s[1], s[2]) for s in t.trail if (k := round(s[0], 3)) > since} for t in tracks]
    en = np.array([[t.east_m, t.north_m] for t in tracks], float).reshape(-1, 2)
    dist = np.sqrt(((en[:, None] - en[None]) ** 2).sum(-1))
    near = dist < cfg.near_m
    if boxes_en is not None and areas is not None and n:
        a = np.asarray(areas, float)
        small = np.minimum(a[:, None], a[None]) <= cfg.straggler_ratio * np.maximum(a[:, None], a[None])
        lo, hi = boxes_en[:, :2], boxes_en[:, 2:]
        gap = np.maximum(0.0, np.maximum(lo[:, None] - hi[None], lo[None] - hi[:, None]))
        near |= small & (np.sqrt((gap ** 2).sum(-1)) <= cfg.near_gap_m)
    far = ~near & (dist >= cfg.apart_m)
    ids = [t.track_id for t in tracks]
    for i, j in np.argwhere(np.triu(near | far, 1)).tolist():   # in (i, j) order, as pairs were always taken
        pair = (min(ids[i], ids[j]), max(ids[i], ids[j]))
        if pair in apart:
            continue
        if far[i, j]:
            apart.add(pair)
            continue
        if _rel_speed_m_s(trails[i], trails[j], stamp_s, cfg) > cfg.max_rel_speed_m_s:
            new_streak[pair] = streak.get(pair, 0) + 1
            if new_streak[pair] >= cfg.apart_frames:
                apart.add(pair)
                del new_streak[pair]
        else:                          # not significant, or NaN (not seen apart long enough): one crowd
            parent[root(j)] = root(i)
    return [root(i) for i in range(n)], frozenset(apart), new_streak


def _rel_speed_m_s(a: dict, b: dict, stamp_s: float, cfg: GroupingConfig) -> float:
    """How fast the distance between two parts changes, m/s (0 when not significant; NaN when they were
    not seen apart long enough)."""
    both = [s for s in sorted(set(a) & set(b)) if s > stamp_s - cfg.window_s - 1e-6]
    if len(both) < 5 or both[-1] - both[0] < cfg.min_span_s - 1e-6:
        return float("nan")
    t = np.array(both) - both[-1]
    dist = np.array([np.hypot(*np.subtract(a[s], b[s])) for s in both])
    tc = t - t.mean()
    slope = (tc * (dist - dist.mean())).sum() / (tc ** 2).sum()
    resid = dist - dist.mean() - slope * tc
    stderr = np.sqrt((resid ** 2).sum() / (len(t) - 2) / (tc ** 2).sum())
    return float(abs(slope)) if abs(slope) > cfg.significance * stderr else 0.0


def trail_scatter_m(trail: tuple[tuple[float, float, float], ...], min_points: int) -> float:
    """1-sigma per axis of a track's recent estimates about a straight line at constant speed fitted to
    them (least squares in time, per axis; the residuals' sum over both axes / (2 (n - 2))); 0 with fewer
    than ``min_points``."""
    n = len(trail)
    if n < max(min_points, 3):
        return 0.0
    a = np.asarray(trail, float)
    t = a[:, 0] - a[:, 0].mean()
    stt = float(t @ t)
    if not stt > 0:
        return 0.0
    y = a[:, 1:] - a[:, 1:].mean(0)
    slope = (t @ y) / stt
    r = y - t[:, None] * slope[None]
    return float(np.sqrt((r * r).sum() / (2 * (n - 2))))


def _with_scatter(c: CrowdEstimate, track: CrowdTrack, cfg: GroupingConfig) -> CrowdEstimate:
    """The estimate with its 95 % radius widened by its own track's measured scatter (step 1), by what
    the scatter shows beyond the frame-to-frame noise the radius already holds (``frame_radius95_m``)."""
    s = trail_scatter_m(tuple(p for p in track.trail if p[0] >= track.stamp_s - cfg.scatter_s), cfg.scatter_min_points)
    extra2 = (R95_PER_SIGMA * s) ** 2 - c.frame_radius95_m ** 2
    if not extra2 > 0:
        return c
    return replace(c, radius95_m=float(np.sqrt(c.radius95_m ** 2 + extra2)))


def _merge(parts: list[CrowdEstimate]) -> CrowdEstimate:
    if len(parts) == 1:
        return parts[0]
    w = np.array([max(p.area_px, 1e-9) for p in parts])
    w = w / w.sum()
    east = float(np.dot(w, [p.east_m for p in parts]))
    north = float(np.dot(w, [p.north_m for p in parts]))
    corners = np.vstack([p.footprint_en_m for p in parts])
    (e0, n0), (e1, n1) = corners.min(0), corners.max(0)
    biggest = max(parts, key=lambda p: p.area_px)
    return replace(biggest, east_m=east, north_m=north, footprint_en_m=np.array([[e0, n1], [e1, n1], [e1, n0], [e0, n0]]),
                   radius95_m=max(p.radius95_m for p in parts), area_px=float(sum(p.area_px for p in parts)))


@dataclass(frozen=True, slots=True)
class ReportedCrowd:
    """A crowd the team is told about: its (joined) estimate and the track it is reported under."""

    estimate: CrowdEstimate
    track: CrowdTrack


def report_crowds(state: GroupingState, estimates: tuple[CrowdEstimate, ...], stamp_s: float,
                  cfg: GroupingConfig = GroupingConfig()) -> tuple[GroupingState, list[ReportedCrowd]]:
    """Track this frame's estimates, join the parts of each crowd; the confirmed crowds, longest-seen first."""
    en = np.array([[c.east_m, c.north_m] for c in estimates]).reshape(-1, 2)
    tracker, trk = state.tracker.update(en, stamp_s)
    boxes_all = np.array([[*c.footprint_en_m.min(0), *c.footprint_en_m.max(0)] for c in estimates], float).reshape(-1, 4)
    live = {t.track_id: t for t in tracker.tracks}
    holds = _merged(state, live, trk, boxes_all, stamp_s)
    estimates = tuple(_with_scatter(c, t, cfg) for c, t in zip(estimates, trk))
    confirmed = [k for k in range(len(trk)) if trk[k].hits >= cfg.confirm_hits]  # a one-frame blob joins nothing
    apart = set(state.apart)
    for x, since in list(holds.items()):    # crowds coming out of the blob that took them in
        at = live[x].predicted(stamp_s)
        # the blob's own track if seen, and parts first seen since the merge beside where it is
        out_of = [trk[k].track_id for k in confirmed if trk[k].track_id == x or (
            trk[k].first_s > since[0].since_s and np.hypot(trk[k].east_m - at[0], trk[k].north_m - at[1]) < cfg.near_m)]
        for y in out_of[1:]:
            pair = (min(out_of[0], y), max(out_of[0], y))
            if pair not in apart and since:
                apart.add(pair)
                since = holds[x] = since[:-1]
    groups: dict[int, list[int]] = {}
    boxes_en = boxes_all[confirmed].reshape(-1, 4)
    areas = np.array([estimates[k].area_px for k in confirmed], float)
    labels, apart, streak = crowd_groups([trk[k] for k in confirmed], stamp_s, cfg, boxes_en, areas,
                                         frozenset(apart), state.streak)
    for k, g in zip(confirmed, labels):
        groups.setdefault(g, []).append(k)
    out = []
    for members in groups.values():
        lead = min(members, key=lambda k: (-trk[k].hits, trk[k].track_id))
        out.append(ReportedCrowd(_merge([estimates[k] for k in members]), trk[lead]))
    out.sort(key=lambda c: (-c.track.hits, c.track.track_id))
    apart = frozenset(p for p in apart if p[0] in live and p[1] in live)   # forgotten with either track
    return GroupingState(tracker, apart, streak, {x: v for x, v in holds.items() if v and x in live}), out


def _merged(state: GroupingState, live: Mapping[int, CrowdTrack], trk: list[CrowdTrack], boxes_en: np.ndarray,
            stamp_s: float) -> dict[int, tuple[Held, ...]]:
    """:attr:`GroupingState.holds` after this frame's merges: a pair known apart, one or both of them
    unseen this frame (while still tracked), whose predicted centres both lie in one estimate's
    footprint (``boxes_en``, per estimate ``trk``; ``live``: the tracks after this frame, by id): that
    estimate's track now holds both crowds, and what the unseen ones held.
    A holding track unseen hands what it holds to the one other track (not of its pairs, holding
    nothing) whose footprint holds its predicted centre; a crowd held is let go when a track the blob
    took it from is seen again (the blob was one only for a frame or two)."""
    prev = {t.track_id: t for t in state.tracker.tracks}
    seen = {t.track_id for t in trk}
    holds = {x: tuple(h for h in v if not seen & set(h.lost)) for x, v in state.holds.items() if x in live}
    holds = {x: v for x, v in holds.items() if v}

    def holding(ids: tuple[int, ...]) -> np.ndarray:
        """The estimates whose footprints hold the predicted centres of all these tracks."""
        p = np.array([prev[y].predicted(stamp_s) for y in ids])
        return np.flatnonzero(((boxes_en[:, None, :2] - HOLD_MARGIN_M <= p[None])
                               & (p[None] <= boxes_en[:, None, 2:] + HOLD_MARGIN_M)).all((1, 2)))

    for x in [x for x in holds if live[x].misses >= 1]:   # another track took the blob on (its centre jumped)
        lost = {y for h in holds[x] for y in h.lost}
        took = [k for k in holding((x,)) if trk[k].track_id not in lost and trk[k].track_id not in holds]
        if len(took) == 1:
            holds[trk[took[0]].track_id] = holds.pop(x)
    known = {h.pair for v in holds.values() for h in v}
    for a, b in sorted(state.apart):
        if (a, b) in known or any(y not in live for y in (a, b)):
            continue
        gone = [y for y in (a, b) if live[y].misses >= 1]
        if not gone:
            continue
        inside = holding((a, b))
        if len(inside):
            x = trk[int(inside[0])].track_id
            taken = tuple(s for y in gone if y != x for s in holds.pop(y, ()))
            lost = tuple(y for y in gone if y != x)
            hidden = len(gone) - (x not in (a, b))    # crowds in the blob, less the one seen as it
            held = tuple(sorted(holds.get(x, ()) + taken + (Held(stamp_s, (a, b), lost),) * hidden))
            if held:
                holds[x] = held
    return holds
