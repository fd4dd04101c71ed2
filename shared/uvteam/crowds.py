"""From the localizer's per-frame estimates to the crowds the team is told about. Pure: no I/O, no clock.

The motion detector cuts a blob in two where two groups, each big enough to be a crowd, walk a gap
apart (:mod:`uvteam.vision.motion`, step 6), so two crowds that pass close by stay two. But one crowd
can have such a gap inside it too. Which it is shows in how the parts move: the parts of one crowd
keep their offset, two crowds drift together or apart. So each frame (:func:`report_crowds`):

1. every estimate is tracked on the ground (:class:`uvteam.tracking.CrowdTracker`), and its 95 % radius
   fitted to how the track's estimates over the last ``scatter_s`` scatter about a straight line at
   constant speed. A detector may declare only the offset a crowd's blob keeps (:mod:`uvteam.detector_noise`:
   the pixel pipeline does, one value for the worst ground it was tuned on) and leave what the blob does
   between frames (parts lost and found, ground texture, pixel noise) to be measured here, in these very
   frames. Both come from the same walkers lost and found against the ground, so a blob that holds
   steady keeps a small offset too: the declared steady part is narrowed to ``steady_per_scatter``
   times the blob's scatter (at least ``steady_min_m``, never more than declared). The blob's scatter is
   the estimates' less the part that the noise the landmarks' fixes declare makes (``fix_sigma_m``; at
   most the scatter within ``scatter_fast_s``): consumer GNSS on the UGVs (1 m per axis, white from fix to
   fix) scattered every crowd's estimates by 0.6 m per axis, which was taken for a blob that does not
   hold steady, so the declared steady part was kept whole and the -gnss1 worlds' radius held the truth
   in 0.98-1.00 of frames. The radius is widened by
   as much as the scatter exceeds what it already holds, each part against its own kind: the scatter
   within ``scatter_fast_s`` (about a line fitted within each such span) is noise from frame to frame,
   against the declared frame noise; the rest is the blob's offset changing over seconds, which the
   steady part holds (the detector's steady offset is what stays over a second, slow changes
   included), so only what exceeds the steady part widens the radius. Counted twice, the slow part
   made the median radius on real imagery 3-18 % wider (6-9 % on real-alt60/120-lm6, whose report
   seeds' truth it held in 0.983-0.990 of frames). With no steady part declared, all the scatter is set
   against the frame noise;
2. estimates closer than ``near_m`` are parts of one crowd, and so is a small part (``straggler_ratio``
   of the other's moving pixels) whose footprint is within ``near_gap_m`` of a bigger one's, as the
   walkers a UGV cuts off a crowd's edge, but not a part of another crowd (the crowd each part was last
   reported in; a young part of step 5 is the crowd's it joins): a crowd's blob cut in small pieces
   beside another crowd is still that crowd (field-alt100-lm6 seed 8 at 54.1 s: two crowds 12 m apart
   reported as one, 7.2 m off, when one's blob was cut in two); unless they move apart or together
   faster than ``max_rel_speed_m_s``: the slope of a straight line fitted to the distance between them
   in the frames of the last ``window_s`` in which both were seen, ``significance`` standard errors from
   zero (a part's centre jitters by up to a metre as walkers cross between parts, so a slope over
   many frames, not two positions); parts not seen apart over ``min_span_s`` are one crowd, unless they
   were parts of two crowds: then one only once seen not to drift (a part of a crowd that takes a new
   track near another crowd, field-alt100-lm6 seed 10 at 56.0 s, made the two one for a frame, 5.1 m
   off), which is more than a drift not significant: the slope plus ``two_upper_k`` standard errors
   under ``max_rel_speed_m_s`` (two crowds 9.7 m apart closing in at 0.33 m/s, tuning seed 100 of
   real-alt60-lm6-two at 16.1 s, were one crowd from the first frame their slope was not significant,
   reported between them 1.7-4.7 m off for the 4 s until their blobs became one). Parts that were one
   crowd in the last frame both were parts in stay one while such a drift has not yet latched them two
   (step 3): a crowd's blob cut in two drifts so for a few frames as the cut opens or heals (tuning
   seed 102 of real-alt60-lm6-winding: its two parts reported as two crowds, 2.5-3.5 m off, for 7
   frames), while two crowds that were two stay two meanwhile;
3. what is learnt sticks while both tracks live (:class:`GroupingState`): parts once ``apart_m`` or more
   apart, or moving apart or together in ``apart_frames`` frames in a row, stay two crowds. Two crowds
   that close in slowly, or part again after walking as one blob, are then not joined by a frame in
   which their drift is not (yet) significant; a single significant frame, which one crowd's jittering
   parts do show now and then, latches nothing; nor does a drift that does not go on: one whose slope over
   the later half of the frames fitted is not ``late_share`` of the whole fit's, the same way (a distance
   that stepped and then held: the two parts of a winding crowd's blob, 8.3 m apart, 7.0 m 0.8 s later,
   then 6.9-7.4 m, fitted -1.2 to -0.5 m/s over the window for ten frames in a row, were latched and
   reported as two crowds in 21 frames, real-alt60-lm6-winding seed 9 at 30.1-36.7 s); nor does a drift the
   parts' walkers do not make: where the detector measured both parts' walkers' velocity (``v_en_m_s``,
   motion step 8), a frame counts only if those part or close in along the line between the parts at
   ``walk_share`` of ``max_rel_speed_m_s``, the same way (:func:`_walkers_drift`). Parts latched for
   their drift alone (not for being ``apart_m`` apart) are one crowd again once, within ``near_m``, the
   slope of their distance over the last ``rejoin_s`` (both seen over most of it) is under half
   ``max_rel_speed_m_s``, significant or not:
   a loose crowd's rear part whose distance to the rest grew by 1.5 m in a second and then held at
   7.5-9 m was reported as a crowd of its own for 22 s (tuning seed 108 of real-alt120-lm6), where two
   crowds do not keep their distance for long. So does a crowd that comes out of a blob which took in
   such a pair (step 4);
4. two crowds known apart whose blobs become one (one of them unseen, both predicted centres in one
   blob's footprint) are remembered as that blob's track holding a second crowd
   (:attr:`GroupingState.holds`), until the unseen one's track is seen again; the memory goes on with
   whichever track takes the blob on. When a part first seen after the merge appears beside that
   track (within ``near_m``), it is the crowd coming out again: two crowds at once, with no wait for a
   drift to show (``min_span_s`` plus ``apart_frames`` frames, in which the two were reported as one);
5. only parts seen ``confirm_hits`` times take part (a blob of one frame neither is a crowd nor pulls
   one), and parts seen fewer times that lie in the footprint of a crowd seen in the last frame (whole,
   or partly, step 7: then up to the moving pixels it usually has)
   (:func:`_young_parts`): a crowd's blob cut in two leaves one part to a track of the crowd's and the
   other to a new one, and that part is the crowd's from its first frame (a young part joins a crowd;
   alone it is none, unless it holds ``seen_whole`` of what the crowd's parts had when it was last seen in
   two or more: their blobs become one on a new track, :func:`_whole_anew`); a crowd is the area-weighted
   mean of its parts (the detector's moving pixels), its footprint the box round theirs, its 95 % radius
   the largest of theirs, reported under its longest-seen part's track (id, velocity; of parts seen as
   often, the crowd's own, else the biggest: :func:`_lead_key`). A crowd whose blob
   is not known yet (its first ``confirm_hits`` frames reported, :func:`_unknown_blob`) has no footprint
   to go by: parts seen once less than
   ``confirm_hits`` whose nearest confirmed part is one of it, within ``near_m``, are its (:func:`_starting_parts`;
   real-alt60-lm6 seed 57 at 0.3 s: a loose crowd first seen in two parts 6.4 m apart was reported 3.6 m off,
   at the part confirmed first, and its other part, which then took its whole blob, came out as a crowd of its
   own for three frames at 1.1-1.3 s); a part seen once joins nothing (a blob of one frame beside a crowd),
   but a crowd about to be first reported with one beside it waits a frame to see which it is (:func:`_waits`);
6. a crowd once reported that has been seen for ``coast_min_seen_s`` (a walk fitted over less is no walk
   to hold it by) and goes unseen (its walkers on ground of their own shade, under a canopy, a vehicle's
   blob over them) is still reported for ``coast_s`` where its walk takes it, flagged with how long it
   has been unseen (``ReportedCrowd.unseen_s``). Its walk is the straight line fitted to its last
   ``scatter_s`` of estimates while it was seen whole (a crowd going out of sight goes part by part,
   step 7): those of the track it is reported under, moved by as much as the crowd is off that track's
   part in the frame (a crowd joined from parts walks where they are, not where its lead part does:
   real-alt60-lm6 seed 148 at 24.1 s, a main part's walk 3.4 m from the crowd seen in two parts). Its
   radius starts as the last estimate's, widened by how far its walk had it from where it
   was seen (a line fitted to a crowd that bends cuts the bend), and grows by the walk's velocity error
   (the fit's standard error, at least ``coast_sigma_v_m_s`` per axis, and no less than the walk's and
   the track's latest velocity disagree, per axis) times the time unseen and by the crowd's own change
   of pace and heading (``coast_sigma_a_m_s2`` per axis) times half the time unseen squared: a crowd
   does not walk on straight because it is no longer seen. It ends when a crowd is reported within
   ``near_m`` of where it should be (seen again, or walked into another crowd's blob) or after
   ``coast_s``; a new track found there keeps its id (a crowd found again by a new track is held only
   once that track is ``coast_min_seen_s`` old), and so does a track that was a part of it (one crowd, in
   the last frame both were parts, with a track the crowd was known by: its own, the one its id came
   from, one that took its id; the crowd's blob taken by two tracks in turns, as a cut part's track takes
   the whole blob for a frame, had the crowd's id change at each turn: 91 times in the 2,785 frames of
   each of five worlds' seeds 4-10), also while the crowd's own track, unseen, is still kept,
   and is partly seen (step 7) if it has fewer moving pixels than the crowd usually had (the desert
   world's seed 4 at 37.0 s: half its walkers, seen 4.2 m off on a new track, had been a new crowd with a
   fresh 1.3 m radius). A crowd reported near it does not end it when it is
   the crowd's own blob under another track: one younger than the crowd's own, which the crowd's own
   was seen again after and never in one frame with (a blob now and then centred past the tracker's
   gate by what joins it or hides part of it), and which holds no crowd of step 4 (a blob that took in
   two crowds known apart is the two of them: where they mingle they are one); that frame the crowd is
   held by its walk and the other track is not reported. A map that drops a crowd the moment its
   walkers blend in shows a crowd that vanished; one that holds it too long shows a crowd that is not
   there: ``coast_s`` is the bargain (docs/results-worlds.md measures it);
7. a crowd seen with fewer moving pixels than it usually has (its median over the last ``window_s``;
   counted afresh from a frame in which its blob let a crowd of step 4 out: what it had was two crowds',
   field-alt100-lm6 seed 3 at 45.4-47.0 s placed 2.4-3.1 m off, between the two; so too from a frame in
   which its parts became two crowds, the two-crowd world's seeds 141 and 143) is partly out of
   sight, and what is seen of it lies to one side: with ``seen_whole`` of them or more
   it is where it is seen, with ``seen_none`` or fewer where its walk takes it (step 6), and in
   between at a point between the two by the share seen, its radius the larger of the two. While it is
   partly seen its walk is the one it had when seen whole (what is seen of it would pull the walk
   aside, and the walk is what steps 6 and 7 place it by); its track keeps what was seen;
8. a crowd reported on its own for ``coast_min_seen_s`` that goes unseen where its walk has it in the footprint
   of another crowd's blob, that blob having its own usual moving pixels and ``held_share`` of the unseen
   one's, is in that blob (:attr:`GroupingState.inside`), for as long as it stays so (the blob keeps
   ``held_keep_share`` of it: one frame 126 pixels short of ``held_share``'s 5,818 forgot it for good, as did a
   frame that missed the blob, whose crowd is then held by its walk from the blob's centre, where it was
   reported; and a crowd seen on its own for a frame between two spells in the blob is again what it was
   before, so the blob takes it in again at once), up to ``coast_s`` after it was last seen on its own. A part
   first seen since then, with ``held_share`` of its moving pixels, nearer where its walk has it than where the
   blob's crowd's walk has it, is that crowd walking out (:func:`_came_out`): apart from the blob's crowd at
   once, under its own id (tuning seed 12 of real-alt60-lm6-two at 14.7 s: two crowds passing 9-10 m apart came
   out of one blob; the part that came out, young in the blob's footprint, joined it, and they were one crowd
   until a drift that never came). The blob is reported as one crowd, the one it is known by (as the scenarios
   score crowds that mingle, and the blob's centre is where their walkers' joint centroid is; reported as two,
   each where its walk takes it moved alike to keep that centroid, the second is a false crowd wherever they
   mingle: field-alt100-lm6's false crowds 163 -> 494 for recall 0.960 -> 0.977), but with a radius that holds
   that crowd, not the blob's joint centroid: each crowd is placed so, and the radius grows by the distance
   from the blob's centre to that crowd's place (tuning seed 100 of real-alt60-lm6-two at 20.1 s: two crowds
   8.8 m apart seen as one blob, its centre 1.8-2.8 m from the nearer crowd, its radius that of one crowd seen
   whole, 2.2 m). While it holds another crowd its own walk and usual size go on as they were before. Held no
   more (``coast_s`` after they were last seen on their own: the two-crowd world's tuning seeds have two crowds
   walk side by side in one blob for 4-13 s), its radius still reaches as far for its own crowd while the blob
   has the moving pixels it needed to hold them (:attr:`GroupingState.still_two`; a frame that misses the blob
   forgets nothing of it), and only the radius: its walk and usual size go on from what is seen;
9. two crowds reported whose footprints come within ``mingle_m`` of each other may be one: walkers of two
   crowds within 2 m of each other make one crowd (the scenarios' rule), and nothing seen tells which (the
   footprints are boxes round the moving pixels and their history; the detector cuts blobs 1.5 m apart).
   Each is reported where it is, its radius widened to hold also their joint centre (their positions
   weighted by moving pixels). Measured on tuning seeds (two-crowd world 1-2, field-alt100-lm6 1 and 3; 1,484
   frames with two crowds reported): footprints that overlap, mingling in 245 of 526; apart by up to
   1 m, 19 of 123; further apart, never (0 of 835). The two-crowd world's frames with its crowds mingling and
   reported as two held the joint centre in 15 of 211 frames before, 197 after (seeds 1-3). ``mingle_m`` was
   1 m for that table; it is the scoring's 2 m, under which walkers in the two footprints can be that close:
   the two-crowd world's fresh seed 123 had its crowds mingling for 5 s (8.3-13.8 s) with footprints 1.1-2.4 m
   apart, reported 3.1-4.6 m off with 0.8-0.9 m radii. And the converse: a crowd joined from parts whose
   footprints do not touch (step 2: parts that keep their distance, a small one beside a big one) may be two
   crowds, and so may its blob seen whole again with the moving pixels of both (the biggest group's and
   ``held_share`` of the rest), up to ``coast_s`` after it was last seen so: its radius widened to hold also
   the centre of its group of parts nearest its own (:func:`_may_be_two`; the two-crowd world's report seed 8
   at 1.2-10 s: crowds of 15 and 8 walkers 14 m apart walking side by side, the smaller joined as a straggler,
   one blob from 5.1 s, reported 3.3-4.5 m off with 1.1-2.1 m radii). The nearest: were the groups two crowds,
   one is that near, and the scoring, as anyone reading the map, takes the report for the crowd nearest it; the
   farthest group, until session 58, widened a crowd of 15 walkers seen in two groups 6 m apart to 4.6 m where
   it lay 0.1-0.3 m off (real-alt60-lm6 seed 178 at 3-14 s: 2.4 m now);
10. each crowd seen is reported where a constant-velocity filter of its estimates has it (:class:`Smoothed`, a
   Kalman filter per crowd id): its estimates' noise from frame to frame is what its track's scatter within
   ``scatter_fast_s`` measures (until there is such a measure, its track too young for it or for a velocity,
   the crowd is reported as estimated: paper-fig7-alt50 seed 4's maximum, 1.29 -> 1.37 m at 0.4 s with a
   filter started on a three-frame track; but a crowd with a filter whose blob went to such a track, as a cut
   part's track takes the whole blob, goes on on its filter at the noise its track last measured:
   real-alt60-lm6-gnss1 seed 182 at 28.5 s, reported as estimated, 3.67 m off, its filter then afresh there),
   its pace and heading change by
   ``smooth_accel_m_s2`` per axis (1 sigma), and an estimate more than ``smooth_gate`` standard deviations
   from where the filter has it, one whose moving pixels changed by more than ``smooth_area_ratio`` (walkers
   joined or left its blob), or one after a frame gap, starts it afresh (a crowd held by its walk, step 6,
   is reported as step 6 has it and starts it afresh when seen again); but an estimate off the gate with its
   moving pixels unchanged is first skipped for ``smooth_skip_frames`` frames in a row, the crowd reported where
   the filter has it: a frame's transform can jump where its crowd cannot (real-alt120-lm6-gnss1 seed 6 at
   39.0 s, a fit on four landmarks 3.3 m off the frames before and after; afresh there, the filter took a second
   to come back, 3.65 m off at worst). A crowd partly seen (step 7) is taken at the noise its radius
   declares, not its track's: where step 7 places it is no estimate (real-alt60-lm6 seed 148 at 24.2 s, a
   placement 2.1 m off was skipped, then started the filter afresh, 4.0 m off, and the filter took 0.6 s to come
   back). Its 95 % radius holds what is left of the declared frame noise after the filter in place of that
   noise. Landmarks with consumer GNSS jitter the
   transform from fix to fix, so a crowd's estimates scatter by a metre about where it walks:
   field-alt100-lm6's tuning seeds 1-3 (open loop, `docs/grouping_replay.py`) 1.199 -> 0.879 m of mean error
   with the filter, the other worlds' within 0.01 m (docs/results-worlds.md, session 41). That is white noise
   from fix to fix; a receiver's error is mostly a bias that drifts over minutes, which no filter over seconds
   takes out and this one leaves as it is (the -gnss1drift worlds: 0.848 -> 0.844 m, session 42).
   A crowd whose walkers' velocity the detector measured (corners on the walkers, :mod:`uvteam.vision.blob_velocity`;
   ``CrowdEstimate.v_en_m_s``) is filtered with it (:func:`_carried_step`): the velocity known to
   ``smooth_sigma_v_m_s`` and ``smooth_spread_k`` times the spread the detector declares (its median absolute
   deviation over the square root of the corners' count, measured 3-4 times too small: on the tuning recordings the
   error's median grows from 0.12 to 0.66 m/s from the least to the most declared spread), off by a bias the filter
   learns from the blob's places (``smooth_bias_m_s``: 2-8 % slow as shipped, which at paper-fig7-alt50's 3.1 m/s
   left the crowd 0.1-0.2 m behind), the blob's place also ``smooth_blob_sigma_m`` off its crowd, white from frame to
   frame, and, while the blob loses moving pixels, off by an offset that lasts (a state of the filter, spreading by
   ``smooth_lost_offset`` half-diagonals of the crowd's footprint per unit of log moving pixels lost, but not while
   step 7 takes the crowd for partly seen, going back to none over ``smooth_blob_tau_s``), and walkers that join or
   leave the blob start nothing afresh: a blob that drifts as walkers go out of sight (a canopy, ground of their own
   shade) no longer takes its crowd with it, since the walkers themselves do not drift. The lasting offset is session
   58's: real-alt60-lm6 seed 175 at 25.6-28.8 s, walkers going out of sight under a roof (the blob's moving pixels
   4,800 -> 3,200), the blob's place drifted east of them at 0.75 m/s for 3 s while their velocity was measured
   right, and the filter took the drift for its crowd's pace (3.3 m off; 2.6 m with it). An offset that lasts
   whatever the blob's pixels do (session 57) took the walkers' velocity measured slow at 3.1 m/s for an offset too
   (paper-fig7-alt50 0.481 -> 0.576 m); one that spreads only while pixels are lost leaves a steady gap to the bias
   (docs/results-worlds.md, session 58). Its radius is as without: the filter takes out the blob's drift, not the
   steady offset the radius holds (a radius narrowed by a share of that part held the truth in 0.68 of frames on
   paper-fig9-color-lm4, whose crowds' error is that offset; docs/results-worlds.md, session 51). A filter averages
   estimates off by one steady error: placed by the camera's pose, a crowd is off by the pose's bias, placed by a
   landmark fit by the landmarks', so a crowd placed by the one and then the other starts its filter afresh (with the
   pose's errors, real-alt60-lm6-gnss1-pose, the first fits' crowds were held towards the pose's bias).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from .localizer import R95_PER_SIGMA, CrowdEstimate
from .tracking import CrowdTrack, CrowdTracker
from .vocab import FitQuality

__all__ = ["GroupingConfig", "GroupingState", "Held", "LastSeen", "ReportedCrowd", "Smoothed", "crowd_groups",
           "report_crowds", "shifted_state", "steady_sigma_m", "straight_walk"]


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
    apart_frames: int = 10        # ... and so are parts whose distance changed significantly this many frames in a row,
    late_share: float = 0.5       # ... each time still changing over the later half of the fit at this share of its pace
    walk_share: float = 0.5       # ... and, where both parts' walkers' velocities are measured, those parting
                                  # or closing in along the line between them at this share of max_rel_speed_m_s
                                  # (0: not asked)
    rejoin_s: float = 6.0         # ... until, near, their distance holds over this long (0: never; <= the tracks' trail)
    scatter_s: float = 8.0        # a crowd's radius counts the scatter of its estimates over this long
    scatter_min_points: int = 5   # ... once there are this many
    scatter_fast_s: float = 1.0   # ... the scatter within this long is frame noise, the rest the steady offset changing
    steady_per_scatter: float = 1.2  # a crowd's blob keeps a steady offset of this times its scatter (0: as declared)
    steady_min_m: float = 0.3     # ... but at least this, and at most what the detector declares (1 sigma per axis)
    coast_s: float = 5.0          # a crowd gone unseen is reported where its walk takes it this long (0: never)
    coast_min_seen_s: float = 2.0  # ... if it was seen this long first
    coast_sigma_v_m_s: float = 0.3  # ... its velocity known no better than this per axis (1 sigma),
    coast_sigma_a_m_s2: float = 0.15  # ... and its pace and heading changing by this per axis (1 sigma)
    seen_whole: float = 0.85      # a crowd seen with this share of its usual moving pixels is seen whole;
    seen_none: float = 0.5        # ... with this share or less, where its walk takes it (step 7)
    two_upper_k: float = 2.0      # parts of two crowds are one once their drift plus this many standard errors is slow
    held_share: float = 0.5       # a crowd's blob with its usual pixels and this share of an unseen one's holds it (step 8)
    held_keep_share: float = 0.1   # ... and, holding it, keeps it with this share (one frame short forgot it)
    mingle_m: float = 2.0         # crowds whose footprints come this close may be one crowd: their radii hold both (step 9)
    smooth_accel_m_s2: float = 0.5  # a crowd seen is reported through a filter that lets its pace and heading change
                                    # by this per axis (1 sigma; 0: reported as estimated) (step 10)
    smooth_gate: float = 4.0      # ... an estimate this many standard deviations from the filter's starts it afresh
    smooth_min_sigma_m: float = 0.05  # ... and its estimates' noise from frame to frame is taken as at least this
    smooth_area_ratio: float = 1.3  # ... and so does one whose moving pixels changed by more than this factor
    smooth_skip_frames: int = 1   # ... but an estimate off the gate is first skipped this many frames in a row
    smooth_blob_sigma_m: float = 0.3  # > 0: a crowd whose walkers' velocity the detector measured is filtered with
                                  # it, its blob's place taken as also this far off (1 sigma per axis) (step 10)
    smooth_lost_offset: float = 0.25  # ... and, while its walkers go out of sight, off by an offset that lasts, its
                                  # spread (1 sigma per axis) this many half-diagonals of its footprint per unit of
                                  # log moving pixels lost (0: none),
    smooth_area_fast_s: float = 0.5   # ... "lost": the log of its moving pixels averaged over this long below
    smooth_area_slow_s: float = 4.0   # ... their average over this long,
    smooth_blob_tau_s: float = 3.0    # ... the offset going back to none over this long (its time constant)
    smooth_sigma_v_m_s: float = 0.15  # ... that velocity known to this per axis (1 sigma),
    smooth_spread_k: float = 6.0  # ... and to this many times the spread the detector declares for it
    smooth_bias_m_s: float = 0.1  # ... and to be off by a bias the filter learns, at first this (1 sigma per axis;
    smooth_bias_walk_m_s: float = 0.01  # 0: none), which changes by this per axis per square root of a second

    def __post_init__(self) -> None:
        for name in ("near_m", "window_s", "min_span_s", "max_rel_speed_m_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not (0.0 <= self.straggler_ratio <= 1.0 and self.near_gap_m >= 0.0 and self.significance >= 0.0
                and self.mingle_m >= 0.0):
            raise ValueError("straggler_ratio must be in [0, 1], near_gap_m, significance and mingle_m >= 0")
        if not 0.0 <= self.held_keep_share <= self.held_share:
            raise ValueError(f"need 0 <= held_keep_share <= held_share, got {self.held_keep_share}, {self.held_share}")
        if not (self.coast_s >= 0.0 and self.coast_min_seen_s >= 0.0 and self.coast_sigma_v_m_s >= 0.0
                and self.coast_sigma_a_m_s2 >= 0.0):
            raise ValueError("coast_s, coast_min_seen_s, coast_sigma_v_m_s and coast_sigma_a_m_s2 must be >= 0")
        if not 0.0 <= self.seen_none < self.seen_whole:
            raise ValueError(f"need 0 <= seen_none < seen_whole, got {self.seen_none}, {self.seen_whole}")
        if not self.scatter_fast_s > 0.0:
            raise ValueError(f"scatter_fast_s must be > 0, got {self.scatter_fast_s}")
        if not (self.steady_per_scatter >= 0.0 and self.steady_min_m >= 0.0):
            raise ValueError("steady_per_scatter and steady_min_m must be >= 0")
        if not (self.smooth_accel_m_s2 >= 0.0 and self.smooth_gate > 0.0 and self.smooth_min_sigma_m > 0.0
                and self.smooth_area_ratio >= 1.0 and self.smooth_skip_frames >= 0):
            raise ValueError("smooth_accel_m_s2 must be >= 0, smooth_gate and smooth_min_sigma_m > 0, "
                             "smooth_area_ratio >= 1, smooth_skip_frames >= 0")
        if not (self.smooth_blob_sigma_m >= 0.0 and self.smooth_sigma_v_m_s > 0.0 and self.smooth_spread_k >= 0.0
                and self.smooth_bias_m_s >= 0.0 and self.smooth_bias_walk_m_s >= 0.0
                and self.smooth_lost_offset >= 0.0):
            raise ValueError("smooth_blob_sigma_m, smooth_lost_offset, smooth_spread_k, smooth_bias_m_s and "
                             "smooth_bias_walk_m_s must be >= 0, smooth_sigma_v_m_s > 0")
        if not (self.smooth_area_fast_s > 0.0 and self.smooth_area_slow_s > 0.0 and self.smooth_blob_tau_s > 0.0):
            raise ValueError("smooth_area_fast_s, smooth_area_slow_s and smooth_blob_tau_s must be > 0")
        if not 0.0 <= self.late_share <= 1.0:
            raise ValueError(f"late_share must be in [0, 1], got {self.late_share}")
        if not self.walk_share >= 0.0:
            raise ValueError(f"walk_share must be >= 0, got {self.walk_share}")
        if not (self.apart_m >= self.near_m and self.apart_frames >= 1 and self.rejoin_s >= 0.0):
            raise ValueError(f"apart_m must be >= near_m, apart_frames >= 1 and rejoin_s >= 0, got {self.apart_m}, "
                             f"{self.apart_frames}, {self.rejoin_s}")


HOLD_MARGIN_M = 2.0        # a predicted centre this far outside a footprint is still in it (track velocities are rough)
Pair = tuple[int, int]   # two track ids, the smaller first


def _pair(a: int, b: int) -> Pair:
    return (a, b) if a < b else (b, a)


@dataclass(frozen=True, slots=True, order=True)
class Held:
    """A crowd a blob took in (step 4)."""

    since_s: float                 # when the blob took it in
    pair: Pair                     # the two tracks known apart that became one blob
    lost: tuple[int, ...]          # the tracks the blob took in (unseen since)
    drifted: bool = False          # the pair was known apart for its drift alone (what comes out may rejoin)


@dataclass(frozen=True, slots=True)
class GroupingState:
    """What :func:`report_crowds` carries from frame to frame; never mutated, each frame makes a new one."""
    tracker: CrowdTracker = field(default_factory=CrowdTracker)
    apart: frozenset[Pair] = frozenset()                        # pairs of tracks known to be two crowds
    streak: Mapping[Pair, int] = field(default_factory=dict)    # frames in a row each pair's distance changed
    holds: Mapping[int, tuple[Held, ...]] = field(default_factory=dict)  # per track, the other crowds its blob took in
    last_seen: Mapping[int, "LastSeen"] = field(default_factory=dict)  # per reported crowd id, the crowd as last seen
    alias: Mapping[int, int] = field(default_factory=dict)  # track id -> the id of the crowd it found again
    drifted: frozenset[Pair] = frozenset()   # the pairs in ``apart`` for their drift alone (they may rejoin)
    joined: frozenset[Pair] = frozenset()    # pairs of tracks one crowd in the last frame both were parts in
    crowd_of: Mapping[int, int] = field(default_factory=dict)  # per track, the crowd it was last reported in
    inside: Mapping[int, tuple["LastSeen", ...]] = field(default_factory=dict)  # per crowd id, the crowds its
                                                                              # blob holds, as last seen (step 8)
    still_two: Mapping[int, tuple[float, float]] = field(default_factory=dict)  # per crowd id whose blob held
    # crowds (step 8): how far its radius reached for its own crowd (m), and the moving pixels the blob had to have
    smoothed: Mapping[int, "Smoothed"] = field(default_factory=dict)  # per crowd id seen, its filter (step 10)
    in_parts: Mapping[int, tuple[float, float, float, float]] = field(default_factory=dict)  # per crowd id last
    # seen in parts apart (step 9): when, the nearest group's distance from its centre (m), the biggest group's
    # moving pixels and the others'


def crowd_groups(tracks: list[CrowdTrack], stamp_s: float, cfg: GroupingConfig = GroupingConfig(),
                 boxes_en: np.ndarray | None = None, areas: np.ndarray | None = None,
                 apart: frozenset[Pair] = frozenset(), streak: Mapping[Pair, int] | None = None,
                 drifted: frozenset[Pair] = frozenset(), joined: frozenset[Pair] = frozenset(),
                 crowds: list[int | None] | None = None, v_en: np.ndarray | None = None
                 ) -> tuple[list[int], frozenset[Pair], dict[Pair, int], frozenset[Pair]]:
    """A group label per track (this frame's estimates): tracks with one label are one crowd.
    ``boxes_en`` (n, 4): each estimate's footprint as east/north min/max; ``areas`` (n,): its moving pixels;
    ``apart``, ``streak``, ``drifted``, ``joined``: what earlier frames learnt (:class:`GroupingState`);
    ``crowds`` (n,): the id of the crowd each was a part of, or None (parts of two crowds are not each
    other's stragglers, nor one crowd before their drift is measured); ``v_en`` (n, 2): each estimate's
    walkers' velocity (NaN where not measured). Returns the labels and the pairs known apart, the streaks
    and the pairs apart for their drift after this frame."""
    n = len(tracks)
    parent = list(range(n))
    apart = set(apart)
    streak, new_streak = streak or {}, {}
    drifted = set(drifted)

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    since = stamp_s - cfg.window_s - 1e-6      # the drift is fitted over the last window_s of the trails
    trails = [_trail_since(t, since) for t in tracks]
    en = np.array([[t.east_m, t.north_m] for t in tracks], float).reshape(-1, 2)
    dist = np.sqrt(((en[:, None] - en[None]) ** 2).sum(-1))
    near = dist < cfg.near_m
    two = np.zeros((n, n), bool)    # parts last reported in two crowds
    if crowds is not None and n:
        c = np.array([-1 if x is None else x for x in crowds])
        two = (c[:, None] >= 0) & (c[None] >= 0) & (c[:, None] != c[None])
    if boxes_en is not None and areas is not None and n:
        a = np.asarray(areas, float)
        small = np.minimum(a[:, None], a[None]) <= cfg.straggler_ratio * np.maximum(a[:, None], a[None])
        stray = small & (_box_gaps_m(boxes_en) <= cfg.near_gap_m)
        near |= stray & ~two
    far = ~near & (dist >= cfg.apart_m)
    ids = [t.track_id for t in tracks]
    for i, j in np.argwhere(np.triu(near | far, 1)).tolist():   # in (i, j) order, as pairs were always taken
        pair = _pair(ids[i], ids[j])
        if pair in apart:
            # apart for a drift that has stopped: two crowds do not keep their distance for long (step 3)
            # rejoining asks for the drift itself to be small over rejoin_s, significant or not (a slope
            # fitted across a drift that stopped is seldom significant)
            if pair in drifted and near[i, j] and cfg.rejoin_s > 0 and _rel_speed_m_s(
                    _trail_since(tracks[i], stamp_s - cfg.rejoin_s), _trail_since(tracks[j], stamp_s - cfg.rejoin_s),
                    stamp_s, replace(cfg, window_s=cfg.rejoin_s, min_span_s=0.9 * cfg.rejoin_s, significance=0.0)
                    ) <= 0.5 * cfg.max_rel_speed_m_s:
                apart.discard(pair)
                drifted.discard(pair)
                parent[root(j)] = root(i)
            continue
        if far[i, j]:
            apart.add(pair)
            continue
        fit = _distance_slope(trails[i], trails[j], stamp_s, cfg)
        rel = _significant_speed(fit, cfg.significance)
        if rel > cfg.max_rel_speed_m_s:
            # a step that stopped counts toward no streak, nor a drift the parts' walkers do not make
            if _goes_on(trails[i], trails[j], stamp_s, fit[0], cfg) and _walkers_drift(v_en, en, i, j, fit[0], cfg):
                new_streak[pair] = streak.get(pair, 0) + 1
            if new_streak.get(pair, 0) >= cfg.apart_frames:
                apart.add(pair)
                drifted.add(pair)
                del new_streak[pair]
            elif pair in joined:       # one crowd the last frame: one until the drift latches (step 2)
                parent[root(j)] = root(i)
        elif not two[i, j] or (fit is not None and abs(fit[0]) + cfg.two_upper_k * fit[1] <= cfg.max_rel_speed_m_s):
            parent[root(j)] = root(i)       # not significant, or NaN (not seen apart long enough): one crowd;
                                            # but parts of two crowds only once seen not to drift
    return [root(i) for i in range(n)], frozenset(apart), new_streak, frozenset(drifted & apart)


def _walkers_drift(v_en: np.ndarray | None, en: np.ndarray, i: int, j: int, slope_m_s: float,
                   cfg: GroupingConfig) -> bool:
    """Whether parts i and j, whose distance changes at ``slope_m_s``, have walkers that move so: their
    velocities (``v_en``) parting or closing in along the line between them, the same way, at
    ``walk_share`` of ``max_rel_speed_m_s``. True where either velocity is not measured. The parts of
    one crowd drift as walkers cross between them or go out of sight and back; their walkers move
    alike (real-alt120-lm6-winding seed 175 at 35.4-36.3 s: two parts of one crowd 6.2 -> 7.1 m apart,
    fitted 0.40-0.62 m/s over 3 s, latched as two crowds 3.3-3.6 m off, while their walkers' velocities
    agreed within 0.3 m/s)."""
    if v_en is None or cfg.walk_share <= 0.0 or not (np.isfinite(v_en[i]).all() and np.isfinite(v_en[j]).all()):
        return True
    d = en[j] - en[i]
    norm = float(np.hypot(*d))
    if norm <= 0.0:
        return True
    parting = float(np.dot(v_en[j] - v_en[i], d)) / norm
    return parting * np.sign(slope_m_s) >= cfg.walk_share * cfg.max_rel_speed_m_s


def _trail_since(track: CrowdTrack, since_s: float) -> dict:
    """A track's estimates after ``since_s``: {stamp s rounded to ms: (east m, north m)}."""
    return {k: (s[1], s[2]) for s in track.trail if (k := round(s[0], 3)) > since_s}


def _rel_speed_m_s(a: dict, b: dict, stamp_s: float, cfg: GroupingConfig) -> float:
    """How fast the distance between two parts changes, m/s (0 when not significant; NaN when they were
    not seen apart long enough)."""
    return _significant_speed(_distance_slope(a, b, stamp_s, cfg), cfg.significance)


def _significant_speed(fit: tuple[float, float] | None, significance: float) -> float:
    """The size of a fitted slope (:func:`_distance_slope`), 0 when under ``significance`` standard errors,
    NaN for no fit."""
    if fit is None:
        return float("nan")
    slope, stderr = fit
    return abs(slope) if abs(slope) > significance * stderr else 0.0


def _both_seen(a: dict, b: dict, stamp_s: float, window_s: float) -> list[float]:
    """The stamps in the last ``window_s`` at which both parts (trails as :func:`_trail_since`) were seen."""
    return [s for s in sorted(set(a) & set(b)) if s > stamp_s - window_s - 1e-6]


def _goes_on(a: dict, b: dict, stamp_s: float, slope: float, cfg: GroupingConfig) -> bool:
    """Whether a drift of ``slope`` (m/s, :func:`_distance_slope` over the last ``window_s``) goes on over the
    later half of the frames it was fitted on, at ``late_share`` of its pace or more, the same way (step 3).
    A distance that stepped and then held fits a slope over the window, not over its later half; true when
    the later half has too few frames to tell."""
    both = _both_seen(a, b, stamp_s, cfg.window_s)
    half = 0.5 * (both[-1] - both[0]) if both else 0.0
    if cfg.late_share <= 0.0 or not half > 0.0:
        return True
    late = _distance_slope(a, b, stamp_s, replace(cfg, window_s=half, min_span_s=0.5 * half))
    return late is None or late[0] * np.sign(slope) >= cfg.late_share * abs(slope)


def _distance_slope(a: dict, b: dict, stamp_s: float, cfg: GroupingConfig) -> tuple[float, float] | None:
    """The slope (m/s) of a straight line fitted to the distance between two parts (trails as
    :func:`_trail_since`) in the frames of the last ``window_s`` both were seen, and its standard error;
    None when they were not seen apart long enough."""
    both = _both_seen(a, b, stamp_s, cfg.window_s)
    if len(both) < 5 or both[-1] - both[0] < cfg.min_span_s - 1e-6:
        return None
    t = np.array(both) - both[-1]
    dist = np.array([np.hypot(*np.subtract(a[s], b[s])) for s in both])
    tc = t - t.mean()
    slope = (tc * (dist - dist.mean())).sum() / (tc ** 2).sum()
    resid = dist - dist.mean() - slope * tc
    stderr = np.sqrt((resid ** 2).sum() / (len(t) - 2) / (tc ** 2).sum())
    return float(slope), float(stderr)


def _line_fit(trail: tuple[tuple[float, float, float], ...], min_points: int):
    """A straight line at constant speed through (stamp s, east m, north m) points, least squares in time
    per axis: (mean time, mean position, velocity, 1-sigma residual per axis, sum of squared time
    offsets), or None with fewer than ``min_points`` (or 3) points or no time spanned."""
    n = len(trail)
    if n < max(min_points, 3):
        return None
    a = np.asarray(trail, float)
    t0 = float(a[:, 0].mean())
    t = a[:, 0] - t0
    stt = float(t @ t)
    if not stt > 0:
        return None
    mean = a[:, 1:].mean(0)
    y = a[:, 1:] - mean
    slope = (t @ y) / stt
    r = y - t[:, None] * slope[None]
    return t0, mean, slope, float(np.sqrt((r * r).sum() / (2 * (n - 2)))), stt


def trail_scatter_m(trail: tuple[tuple[float, float, float], ...], min_points: int) -> float:
    """1-sigma per axis of a track's recent estimates about a straight line at constant speed fitted to
    them (least squares in time, per axis; the residuals' sum over both axes / (2 (n - 2))); 0 with fewer
    than ``min_points``."""
    fit = _line_fit(trail, min_points)
    return 0.0 if fit is None else fit[3]


def fast_scatter_m(trail: tuple[tuple[float, float, float], ...], span_s: float) -> float | None:
    """1-sigma per axis of a track's estimates about straight lines fitted within each ``span_s`` of the
    trail (spans counted back from the newest estimate; each fitted on its own, least squares in time per
    axis, pooled over the spans with 4 or more estimates): the scatter that changes within ``span_s``,
    not what the blob's offset does over longer. None with no such span."""
    if len(trail) < 4:
        return None
    a = np.asarray(trail, float)
    span = np.floor((a[-1, 0] - a[:, 0]) / span_s + 1e-9).astype(np.intp)
    used = np.bincount(span)[span] >= 4
    if not used.any():
        return None
    span, a = span[used], a[used]
    m = int(span.max()) + 1

    def sums(v: np.ndarray) -> np.ndarray:   # per span
        return np.bincount(span, weights=v, minlength=m)

    t = a[:, 0] - a[-1, 0]
    nn = sums(np.ones(len(t)))
    ok = nn > 0
    st, stt = sums(t), sums(t * t)
    ctt = stt - np.divide(st * st, nn, out=np.zeros(m), where=ok)
    ss = 0.0
    for ax in (1, 2):
        y = a[:, ax] - a[:, ax].mean()
        sy, syy, sty = sums(y), sums(y * y), sums(t * y)
        cyy = syy - np.divide(sy * sy, nn, out=np.zeros(m), where=ok)
        cty = sty - np.divide(st * sy, nn, out=np.zeros(m), where=ok)
        ss += float(np.sum(cyy - np.divide(cty * cty, ctt, out=np.zeros(m), where=ctt > 1e-12)))
    dof = 2.0 * float(np.sum(nn[ok] - 2.0))    # every span kept has 4 or more estimates
    return float(np.sqrt(max(ss, 0.0) / dof))


def straight_walk(trail: tuple[tuple[float, float, float], ...], at_s: float, min_points: int
                  ) -> tuple[tuple[float, float], tuple[float, float], float] | None:
    """The straight line at constant speed fitted to ``trail`` (as :func:`trail_scatter_m`): its position
    at ``at_s`` (east, north m), its velocity (m/s) and the velocity's standard error per axis; None
    with fewer than ``min_points`` (or 3) points or no time spanned."""
    fit = _line_fit(trail, min_points)
    if fit is None:
        return None
    t0, mean, slope, sigma_m, stt = fit
    at = mean + slope * (at_s - t0)
    return (float(at[0]), float(at[1])), (float(slope[0]), float(slope[1])), sigma_m / float(np.sqrt(stt))


def steady_sigma_m(scatter_m: float, declared_sigma_m: float, cfg: GroupingConfig) -> float:
    """The steady offset (1 sigma per axis) a crowd's blob keeps, from its measured ``scatter_m`` (step 1):
    ``steady_per_scatter`` times it, within [``steady_min_m``, ``declared_sigma_m``]."""
    if not cfg.steady_per_scatter > 0:
        return declared_sigma_m
    return min(max(cfg.steady_per_scatter * scatter_m, cfg.steady_min_m), declared_sigma_m)


def _scatter_trail(track: CrowdTrack, cfg: GroupingConfig) -> tuple[tuple[float, float, float], ...]:
    """A track's estimates over the last ``scatter_s``, what its scatter is measured on (steps 1 and 10)."""
    return tuple(p for p in track.trail if p[0] >= track.stamp_s - cfg.scatter_s)


def _with_scatter(c: CrowdEstimate, track: CrowdTrack, fast: float | None, cfg: GroupingConfig) -> CrowdEstimate:
    """The estimate with its 95 % radius fitted to its own track's measured scatter (step 1): the declared
    steady part (``steady_radius95_m``) narrowed to what the scatter says (:func:`steady_sigma_m`), then
    widened by what the scatter shows beyond what the radius holds: its fast part (:func:`fast_scatter_m`)
    beyond the frame-to-frame noise (``frame_radius95_m``), the rest beyond the steady part. With no steady
    part declared, all of it beyond the frame noise. ``fast``: :func:`fast_scatter_m` of its trail."""
    fit = _line_fit(_scatter_trail(track, cfg), cfg.scatter_min_points)
    if fit is None:
        return c
    s = fit[3]
    r2 = c.radius95_m ** 2
    frame2 = c.frame_radius95_m ** 2
    if c.steady_radius95_m > 0:
        fast = s if fast is None else min(fast, s)
        landmarks = min(fast, c.fix_sigma_m)   # the fixes' noise, declared and seen as fast
        own = R95_PER_SIGMA * steady_sigma_m(float(np.sqrt(s * s - landmarks * landmarks)),
                                             c.steady_radius95_m / R95_PER_SIGMA, cfg)
        r2 = max(r2 - c.steady_radius95_m ** 2 + own ** 2, frame2)
        r2 += max((R95_PER_SIGMA * fast) ** 2 - frame2, 0.0) + \
            max(R95_PER_SIGMA ** 2 * (s * s - fast * fast) - own ** 2, 0.0)
    else:
        r2 += max((R95_PER_SIGMA * s) ** 2 - frame2, 0.0)
    if r2 == c.radius95_m ** 2:
        return c
    return replace(c, radius95_m=float(np.sqrt(r2)))


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
    """A crowd the team is told about: its (joined) estimate and the track it is reported under;
    ``unseen_s`` > 0: not seen in this frame, the estimate is where its walk takes it (step 6)."""

    estimate: CrowdEstimate
    track: CrowdTrack
    crowd_id: int                      # the id the team knows it by: its track's, or that of the crowd it was
                                       # before it went unseen (step 6)
    unseen_s: float = 0.0
    partly_seen: bool = False          # placed towards where its walk takes it (step 7)


@dataclass(frozen=True, slots=True)
class LastSeen:
    """A reported crowd as it was last seen, and its walk when last seen whole (steps 6, 7)."""

    crowd: ReportedCrowd
    seen_s: float
    walk_s: float                      # when it was last seen whole; then
    en_m: tuple[float, float]          # ... where its straight walk over the last scatter_s had it,
    v_en_m_s: tuple[float, float]      # ... that walk's velocity
    sigma_v_m_s: float                 # ... and its 1-sigma per axis (inf: too few points for a walk),
    r95_m: float                       # ... and the 95 % radius it is held by from there
    areas: tuple[tuple[float, float], ...] = ()   # (stamp s, moving pixels) over the last window_s

    def usual_px(self) -> float:
        """The moving pixels it usually has: their median over ``areas`` (step 7)."""
        return float(np.median([a for _, a in self.areas]))

    def walk_at(self, stamp_s: float, cfg: GroupingConfig) -> tuple[np.ndarray, float]:
        """Where its walk takes it at ``stamp_s`` (east, north m), and the 95 % radius that holds it."""
        dt = stamp_s - self.walk_s
        sigma_v = max(self.sigma_v_m_s if np.isfinite(self.sigma_v_m_s) else 0.0, cfg.coast_sigma_v_m_s)
        at = np.add(self.en_m, np.multiply(self.v_en_m_s, dt))
        drift_m = np.hypot(sigma_v * dt, 0.5 * cfg.coast_sigma_a_m_s2 * dt * dt)   # 1 sigma per axis
        return at, float(np.hypot(self.r95_m, R95_PER_SIGMA * drift_m))


def _remembered(state: GroupingState, seen_crowds: list[ReportedCrowd], stamp_s: float, cfg: GroupingConfig,
                live: Mapping[int, CrowdTrack], holding: frozenset[int] = frozenset(),
                released: frozenset[int] = frozenset(), came_out: Mapping[int, int] | None = None
                ) -> tuple[list[ReportedCrowd], dict[int, LastSeen], dict[int, int], list[ReportedCrowd],
                           dict[int, tuple[LastSeen, ...]], dict[int, tuple[float, float]]]:
    """Steps 6-8: the crowds seen this frame under the ids the team knows them by (placed by their walk
    where partly seen; a radius that holds the crowd of a blob that took another in), what is remembered
    of them, the ids carried over, the crowds unseen this frame still reported (``holding``: the tracks
    that hold crowds of step 4), the crowds each crowd's blob holds (step 8) and what the radius of each
    blob that held crowds reached for (:attr:`GroupingState.still_two`). ``came_out``: per track, the crowd
    held in a blob (step 8) that it is, walking out of it."""
    alias = {t: c for t, c in state.alias.items() if t in live}
    alias.update((t, c) for t, c in (came_out or {}).items() if t in live)
    out = [replace(r, crowd_id=alias.get(r.track.track_id, r.crowd_id)) for r in seen_crowds]
    last = dict(state.last_seen)
    seen = np.array([[r.estimate.east_m, r.estimate.north_m] for r in out], float).reshape(-1, 2)
    taken = {r.crowd_id for r in out}
    for cid, ls in list(last.items()):    # found again: a new track where the crowd should be
        d = np.hypot(*(seen - ls.walk_at(stamp_s, cfg)[0]).T) if len(seen) else np.empty(0)
        # its own track, if still tracked, missed this frame (a track seen this frame is the crowd)
        if cid in taken or (cid in live and live[cid].misses == 0) or not len(d) or d.min() >= cfg.near_m:
            continue
        k = int(np.argmin(d))
        r = out[k]
        # a new track, or one that was a part of this crowd (its blob taken in turns by two tracks): a part
        # of a track it was known by (its own now, the one it was first, those that took its id)
        mine = {ls.crowd.track.track_id, cid} | {t for t, c in state.alias.items() if c == cid}
        was_part = any(_pair(t, r.track.track_id) in state.joined for t in mine)
        # or one as old as the crowd's own and never reported: its blob's other part from its first frames
        first = r.track.track_id not in state.crowd_of and r.track.first_s <= ls.crowd.track.first_s
        if r.crowd_id == r.track.track_id and (r.track.first_s > ls.seen_s or was_part or first):
            alias[r.track.track_id] = cid
            taken.discard(r.crowd_id)
            taken.add(cid)
            out[k] = replace(r, crowd_id=cid)
    ids = [r.crowd_id for r in out]
    for k, r in enumerate(out):    # a track that took an id and one found again both seen: the first keeps it
        if ids.count(r.crowd_id) > 1 and r.crowd_id != r.track.track_id:
            ids[k] = r.track.track_id
            out[k] = replace(r, crowd_id=r.track.track_id)
            alias.pop(r.track.track_id, None)
    for held in state.inside.values():   # a crowd a blob held, seen again: what it was before it went in
        for ls in held:
            if ls.crowd.crowd_id in ids and ls.crowd.crowd_id not in last:
                last[ls.crowd.crowd_id] = ls
    inside = _inside(state, last, out, ids, stamp_s, cfg)
    for k, r in enumerate(out):
        tr, prev = r.track, last.get(r.crowd_id)
        if k in inside:    # its blob holds another crowd: its walk and usual size go on as they were
            last[r.crowd_id] = replace(prev, crowd=r, seen_s=stamp_s)
            continue
        # a blob that let a crowd out is one crowd less: the size it had is no longer this crowd's usual
        known = prev if tr.track_id not in released else None
        areas = tuple(a for a in (known.areas if known is not None else ()) if a[0] >= stamp_s - cfg.window_s - 1e-6)
        areas += ((stamp_s, r.estimate.area_px),)
        out[k] = r = _partly_seen(r, known, stamp_s, cfg)
        if r.partly_seen:      # its walk seen whole goes on: the part seen would pull it aside
            last[r.crowd_id] = replace(prev, crowd=r, seen_s=stamp_s, areas=areas)
            continue
        c = r.estimate
        walk = straight_walk(tuple(p for p in tr.trail if p[0] >= stamp_s - cfg.scatter_s - 1e-6), stamp_s,
                             cfg.scatter_min_points)
        at, v, sigma_v = walk or ((c.east_m, c.north_m), (tr.v_east_m_s, tr.v_north_m_s), float("inf"))
        if walk is not None and tr.trail and tr.trail[-1][0] == stamp_s:
            # the walk is its lead part's: a crowd joined from parts walks where they are, off that part
            # by as much as the crowd is this frame (real-alt60-lm6 seed 148 at 24.1 s: a main part's
            # walk 3.4 m from the crowd seen in two parts placed it there once the other part went)
            at = (at[0] + c.east_m - tr.trail[-1][1], at[1] + c.north_m - tr.trail[-1][2])
        # where its walk has it and where it is seen, the walk's velocity and the track's latest, disagree
        # on a crowd that bends (the line cuts the bend): it is held no surer than they agree
        r95 = float(np.hypot(c.radius95_m, np.hypot(at[0] - c.east_m, at[1] - c.north_m)))
        if walk is not None:
            sigma_v = max(sigma_v, float(np.hypot(v[0] - tr.v_east_m_s, v[1] - tr.v_north_m_s)) / np.sqrt(2.0))
        last[r.crowd_id] = LastSeen(r, stamp_s, stamp_s, at, v, sigma_v, r95, areas)
    coasted, hidden = [], set()
    for cid, ls in list(last.items()):
        dt = stamp_s - ls.seen_s
        if dt <= 0.0:
            continue
        at, r95 = ls.walk_at(stamp_s, cfg)
        if cid in state.inside:   # a blob holding crowds, reported at its centre, goes on from there
            at = np.add((ls.crowd.estimate.east_m, ls.crowd.estimate.north_m), np.multiply(ls.v_en_m_s, dt))
        near = np.flatnonzero(np.hypot(*(seen - at).T) < cfg.near_m) if len(seen) else np.empty(0, int)
        own = live.get(ls.crowd.track.track_id)
        took = [k for k in near if out[k].track.track_id not in holding and _took_its_blob(out[k].track, own)]
        if (dt > cfg.coast_s or not ls.seen_s - ls.crowd.track.first_s >= cfg.coast_min_seen_s
                or len(near) > len(took)):
            del last[cid]
            continue
        hidden.update(took)
        c = ls.crowd.estimate
        moved = replace(c, east_m=float(at[0]), north_m=float(at[1]), radius95_m=max(r95, c.radius95_m),
                        footprint_en_m=c.footprint_en_m + (at - [c.east_m, c.north_m]))
        coasted.append(replace(ls.crowd, estimate=moved, unseen_s=dt, partly_seen=False))
    for k in hidden:
        if out[k].crowd_id == out[k].track.track_id:
            last.pop(out[k].crowd_id, None)
    still_two = {}
    for k, held in inside.items():
        if k in hidden:      # reported as the crowd whose blob it took, not as itself
            continue
        host = last[out[k].crowd_id]
        off_m = _holding_offset_m([host] + list(held), stamp_s, cfg)
        still_two[out[k].crowd_id] = (off_m, host.usual_px() + sum(cfg.held_share * h.usual_px() for h in held))
        out[k] = replace(out[k], estimate=replace(out[k].estimate, radius95_m=out[k].estimate.radius95_m + off_m))
    for k, r in enumerate(out):    # held no more (coast_s since the crowds it took in were seen), still both
        kept = state.still_two.get(r.crowd_id)
        if k in inside or k in hidden or kept is None or not r.estimate.area_px >= kept[1]:
            continue
        still_two[r.crowd_id] = kept
        out[k] = replace(r, estimate=replace(r.estimate, radius95_m=r.estimate.radius95_m + kept[0]))
    # a blob missed for a frame (its crowd held by its walk, step 6) is the same blob when seen again
    still_two.update((cid, kept) for cid, kept in state.still_two.items() if cid not in ids and cid in last)
    # a blob missed for a frame, its crowd held by its walk (step 6), still holds what it held
    carried = {cid: kept for cid, held in state.inside.items() if cid not in ids and cid in last
               and (kept := tuple(ls for ls in held if stamp_s - ls.seen_s <= cfg.coast_s))}
    return ([r for k, r in enumerate(out) if k not in hidden], last, alias, coasted,
            carried | {out[k].crowd_id: held for k, held in inside.items() if k not in hidden}, still_two)


def _inside(state: GroupingState, last: dict[int, LastSeen], out: list[ReportedCrowd], ids: list[int],
            stamp_s: float, cfg: GroupingConfig) -> dict[int, tuple[LastSeen, ...]]:
    """Step 8: the crowds each crowd seen this frame (index in ``out``) holds in its blob: those it held
    the last frame and those unseen this frame (ids in ``last`` not in ``ids``; taken out of ``last``),
    while their walk has them in its footprint, it has its own usual moving pixels and ``held_share`` of
    theirs, and they were last seen no more than ``coast_s`` ago."""
    inside: dict[int, tuple[LastSeen, ...]] = {}

    def holds(k: int, ls: LastSeen, share: float) -> bool:
        host = last.get(out[k].crowd_id)
        if host is None or len(host.areas) < cfg.scatter_min_points or not 0.0 < stamp_s - ls.seen_s <= cfg.coast_s:
            return False
        fp = out[k].estimate.footprint_en_m
        at, _ = ls.walk_at(stamp_s, cfg)
        have = host.usual_px() + sum(share * h.usual_px() for h in inside.get(k, ()) + (ls,))
        return (out[k].estimate.area_px >= have
                and bool(_in_boxes(at, np.hstack([fp.min(0), fp.max(0)]), HOLD_MARGIN_M)[0, 0]))

    at_k = {r.crowd_id: k for k, r in enumerate(out)}
    for cid, held in state.inside.items():
        k = at_k.get(cid)
        for ls in held if k is not None else ():
            if ls.crowd.crowd_id not in ids and holds(k, ls, cfg.held_keep_share):
                inside[k] = inside.get(k, ()) + (ls,)
    for cid, ls in list(last.items()):
        if (cid in ids or len(ls.areas) < cfg.scatter_min_points
                or not ls.seen_s - ls.crowd.track.first_s >= cfg.coast_min_seen_s):
            continue
        for k in range(len(out)):
            if out[k].crowd_id != cid and holds(k, ls, cfg.held_share):
                inside[k] = inside.get(k, ()) + (last.pop(cid),)
                break
    return inside


def _holding_offset_m(crowds: list[LastSeen], stamp_s: float, cfg: GroupingConfig) -> float:
    """Step 8: how far the 95 % radius of a blob that holds several crowds (``crowds``, as last seen: the one
    it is reported as first) reaches beyond the blob's own: each crowd is where its walk takes it, all moved
    alike so that their mean weighted by their usual moving pixels is the blob's centre, and the radius
    grows by how far that puts the crowd it is reported as from that centre."""
    p = np.array([ls.walk_at(stamp_s, cfg)[0] for ls in crowds])
    u = np.array([ls.usual_px() for ls in crowds])
    w = u / u.sum()
    off = p - w @ p       # each crowd from the blob's centre
    return float(np.hypot(*off[0]))


def _took_its_blob(young: CrowdTrack, own: CrowdTrack | None) -> bool:
    """Whether ``young`` is the blob of the crowd whose own track (``own``, still tracked) missed this
    frame: a track younger than it that the crowd's own track was seen again after, never in one frame
    with it (the crowd's blob, now and then centred past the tracker's gate by what joins it or hides
    part of it, taken by another track). A blob whose centre jumped for good is not: its own track is
    not seen again."""
    if own is None or not own.stamp_s > young.first_s > own.first_s:
        return False
    mine = {round(p[0], 3) for p in own.trail}
    return not any(round(p[0], 3) in mine for p in young.trail)


def _partly_seen(r: ReportedCrowd, ls: LastSeen | None, stamp_s: float, cfg: GroupingConfig) -> ReportedCrowd:
    """Step 7: a crowd seen with fewer moving pixels than it usually has, placed between where it is
    seen and where its walk takes it (``ls``: the crowd as last seen, before this frame)."""
    if ls is None or not ls.seen_s < stamp_s or len(ls.areas) < cfg.scatter_min_points:
        return r
    c = r.estimate
    usual = ls.usual_px()
    share = (c.area_px / usual - cfg.seen_none) / (cfg.seen_whole - cfg.seen_none) if usual > 0 else 1.0
    if not share < 1.0:
        return r
    share = max(share, 0.0)
    (pe, pn), walk_r95 = ls.walk_at(stamp_s, cfg)
    e, n = pe + share * (c.east_m - pe), pn + share * (c.north_m - pn)
    # the footprint stays as seen
    placed = replace(c, east_m=float(e), north_m=float(n), radius95_m=max(c.radius95_m, walk_r95))
    return replace(r, estimate=placed, partly_seen=True)


def report_crowds(state: GroupingState, estimates: tuple[CrowdEstimate, ...], stamp_s: float,
                  cfg: GroupingConfig = GroupingConfig(), shift_en_m: tuple[float, float] | None = None
                  ) -> tuple[GroupingState, list[ReportedCrowd]]:
    """Track this frame's estimates, join the parts of each crowd; the confirmed crowds, longest-seen first.
    ``shift_en_m``: this frame's estimates are placed so much off where the last frame's placement would have
    put them (a landmark fit taking over from the camera's pose, ``StepResult.placement_shift_en_m``): what is
    carried from the last frames is moved with them first (:func:`shifted_state`)."""
    if shift_en_m is not None:
        state = shifted_state(state, *shift_en_m)
    en = np.array([[c.east_m, c.north_m] for c in estimates]).reshape(-1, 2)
    tracker, trk = state.tracker.update(en, stamp_s)
    boxes_all = _boxes_en(estimates)
    live = {t.track_id: t for t in tracker.tracks}
    holds = _merged(state, live, trk, boxes_all, stamp_s)
    fast_of = {t.track_id: fast_scatter_m(_scatter_trail(t, cfg), cfg.scatter_fast_s) for t in trk}
    estimates = tuple(_with_scatter(c, t, fast_of[t.track_id], cfg) for c, t in zip(estimates, trk))
    confirmed = [k for k in range(len(trk)) if trk[k].hits >= cfg.confirm_hits]  # a one-frame blob joins nothing
    apart, drifted = set(state.apart), set(state.drifted)
    released = set()    # tracks whose blob let a crowd it took in out this frame
    for x, since in list(holds.items()):    # crowds coming out of the blob that took them in
        at = live[x].predicted(stamp_s)
        # the blob's own track if seen, and parts first seen since the merge beside where it is
        out_of = [trk[k].track_id for k in confirmed if trk[k].track_id == x or (
            trk[k].first_s > since[0].since_s and np.hypot(trk[k].east_m - at[0], trk[k].north_m - at[1]) < cfg.near_m)]
        for y in out_of[1:]:
            pair = _pair(out_of[0], y)
            if pair not in apart and since:
                apart.add(pair)
                if since[-1].drifted:
                    drifted.add(pair)
                since = holds[x] = since[:-1]
                released.add(x)
    came_out = _came_out(state, estimates, en, trk, stamp_s, cfg)
    for k, (host, _) in came_out.items():   # a crowd a blob held (step 8) walks out of it: two crowds at once
        if host in live:
            apart.add(_pair(host, trk[k].track_id))
    groups: dict[int, list[int]] = {}
    young = _young_parts(state, estimates, confirmed, stamp_s, holds, cfg, frozenset(came_out))
    young.update((k, cid) for k, (_, cid) in came_out.items() if k not in confirmed)
    parts = confirmed + list(young)
    boxes_en = boxes_all[parts].reshape(-1, 4)
    areas = np.array([estimates[k].area_px for k in parts], float)
    crowds = [came_out[k][1] if k in came_out else young.get(k, state.crowd_of.get(trk[k].track_id)) for k in parts]
    v_en = np.array([estimates[k].v_en_m_s if estimates[k].v_en_m_s is not None else (np.nan, np.nan)
                     for k in parts], float).reshape(-1, 2)
    labels, apart, streak, drifted = crowd_groups([trk[k] for k in parts], stamp_s, cfg, boxes_en, areas,
                                                  frozenset(apart), state.streak, frozenset(drifted), state.joined,
                                                  crowds, v_en)
    # the parts a new crowd showed in from its first frames, in the group of the nearest confirmed part
    of_part = dict(zip(parts, labels))
    for k, j in _starting_parts(state, en, trk, confirmed, frozenset(young), cfg).items():
        if all(_unknown_blob(state, trk[m], cfg) for m in confirmed if of_part[m] == of_part[j]):   # j's included
            parts.append(k)
            labels.append(of_part[j])
    joined = _joined_after(state.joined, [trk[k].track_id for k in parts], labels, live)
    for k, g in zip(parts, labels):
        groups.setdefault(g, []).append(k)
    out, of_lead, apart_now = [], {}, {}
    once = [k for k in range(len(trk)) if trk[k].hits < cfg.confirm_hits - 1 and k not in of_part]
    anew: dict[int, int] = {}    # a crowd seen whole on young tracks alone: their lead's track -> the crowd's id
    seen_ids = {state.crowd_of.get(trk[k].track_id, trk[k].track_id) for k in confirmed}
    for members in groups.values():
        lead = min(members, key=lambda k: _lead_key(state, trk[k], estimates[k]))
        if not any(k in confirmed for k in members):    # young parts join a crowd; alone they are none
            if (cid := _whole_anew(state, estimates, members, trk[lead].track_id, young, seen_ids, cfg)) is None:
                continue
            anew[trk[lead].track_id] = cid
        if _waits(state, en, trk, members, lead, once, cfg):
            continue
        out.append(ReportedCrowd(_merge([estimates[k] for k in members]), trk[lead], trk[lead].track_id))
        of_lead[trk[lead].track_id] = [trk[k].track_id for k in members]
        if (apart_parts := _parts_apart([estimates[k] for k in members])) is not None:
            apart_now[trk[lead].track_id] = apart_parts
    # a crowd whose parts are two crowds from this frame is one crowd less too: what it had is no part seen
    was: dict[int, set[int]] = {}
    for lead_id, members in of_lead.items():
        for t in members:
            if (cid := state.crowd_of.get(t)) is not None:
                was.setdefault(cid, set()).add(lead_id)
    released.update(t for leads in was.values() if len(leads) > 1 for t in leads)
    out, last_seen, alias, coasted, inside, still_two = _remembered(
        state, out, stamp_s, cfg, live, frozenset(holds), frozenset(released),
        {trk[k].track_id: cid for k, (_, cid) in came_out.items()} | anew)
    crowd_of = {t: c for t, c in state.crowd_of.items() if t in live}
    crowd_of.update((t, r.crowd_id) for r in out for t in of_lead[r.track.track_id])
    out, in_parts = _may_be_two(state.in_parts, out, apart_now, stamp_s, cfg)
    out = _mingling(out + coasted, cfg)
    out.sort(key=lambda c: (-c.track.hits, c.crowd_id))
    apart = frozenset(p for p in apart if p[0] in live and p[1] in live)   # forgotten with either track
    holds = {x: v for x, v in holds.items() if v and x in live}
    out, smoothed = _smoothed(state.smoothed, out, fast_of, stamp_s, cfg)
    return GroupingState(tracker, apart, streak, holds, last_seen, alias, drifted & apart, joined, crowd_of,
                         inside, still_two, smoothed, in_parts), out


def shifted_state(state: GroupingState, d_east_m: float, d_north_m: float) -> GroupingState:
    """``state`` with every place it carries moved by (``d_east_m``, ``d_north_m``): the tracks and their trails,
    the crowds as last seen and their walks, those their blobs hold, and the filters. The placement changed under
    them (the camera's pose, off by its bias, gave way to a landmark fit: real-alt120-lm6-gnss1-pose's tuning seeds
    174-180 at 0.7-1.0 s, 3-6 m): moved with it, a crowd's track takes its next estimate, not a new track that
    reports it afresh after ``confirm_hits`` frames under a new id."""
    d = np.array([d_east_m, d_north_m])

    def crowd(r: ReportedCrowd) -> ReportedCrowd:
        c = r.estimate
        return replace(r, estimate=replace(c, east_m=c.east_m + d_east_m, north_m=c.north_m + d_north_m,
                                           footprint_en_m=c.footprint_en_m + d),
                       track=r.track.shifted(d_east_m, d_north_m))

    def seen(ls: LastSeen) -> LastSeen:
        return replace(ls, crowd=crowd(ls.crowd), en_m=(ls.en_m[0] + d_east_m, ls.en_m[1] + d_north_m))

    def filt(f: Smoothed) -> Smoothed:
        x = f.x.copy()
        x[:2] += d
        return replace(f, x=x)

    tracker = replace(state.tracker, tracks=tuple(t.shifted(d_east_m, d_north_m) for t in state.tracker.tracks))
    return replace(state, tracker=tracker, last_seen={k: seen(v) for k, v in state.last_seen.items()},
                   inside={k: tuple(seen(v) for v in vs) for k, vs in state.inside.items()},
                   smoothed={k: filt(v) for k, v in state.smoothed.items()})


def _parts_apart(parts: list[CrowdEstimate]) -> tuple[float, float, float] | None:
    """The parts of one crowd (step 2) in groups whose footprints touch: with two or more such groups, how far
    the nearest group's centre lies from the crowd's (both weighted by moving pixels, m), the biggest group's
    moving pixels and the other groups'; None with one group."""
    if len(parts) < 2:
        return None
    touch = _box_gaps_m(_boxes_en(parts)) <= 0.0
    group = [-1] * len(parts)
    for start in range(len(parts)):
        if group[start] >= 0:
            continue
        group[start], todo = start, [start]
        while todo:
            k = todo.pop()
            for j in np.flatnonzero(touch[k]).tolist():
                if group[j] < 0:
                    group[j] = start
                    todo.append(j)
    if len(set(group)) < 2:
        return None
    w = np.array([max(p.area_px, 1e-9) for p in parts])
    en = np.array([[p.east_m, p.north_m] for p in parts])
    centre = w @ en / w.sum()
    g = np.array(group)
    areas = {x: float(w[g == x].sum()) for x in set(group)}
    off_m = min(float(np.hypot(*(w[g == x] @ en[g == x] / a - centre))) for x, a in areas.items())
    biggest = max(areas.values())
    return off_m, biggest, float(sum(areas.values()) - biggest)


def _may_be_two(prev: Mapping[int, tuple[float, float, float, float]], crowds: list[ReportedCrowd],
                apart_now: Mapping[int, tuple[float, float, float]], stamp_s: float, cfg: GroupingConfig
                ) -> tuple[list[ReportedCrowd], dict[int, tuple[float, float, float, float]]]:
    """Step 9, the converse: each crowd seen in parts whose footprints lie apart (``apart_now``, per lead track:
    :func:`_parts_apart`) may be two crowds, and so may its blob seen whole again with the moving pixels of both
    (the biggest group's and ``held_share`` of the others') up to ``coast_s`` after (``prev``, per crowd id): its
    radius widened to hold also the nearest group's centre. Returns the crowds and what is remembered."""
    out, kept = [], {}
    for r in crowds:
        c = r.estimate
        now = apart_now.get(r.track.track_id)
        if now is not None:
            kept[r.crowd_id] = (stamp_s, *now)
        elif r.crowd_id in prev:
            seen_s, _, biggest, others = prev[r.crowd_id]
            if stamp_s - seen_s > cfg.coast_s or c.area_px < biggest + cfg.held_share * others:
                out.append(r)
                continue
            kept[r.crowd_id] = prev[r.crowd_id]
        else:
            out.append(r)
            continue
        r95 = float(np.hypot(c.radius95_m, kept[r.crowd_id][1]))
        out.append(replace(r, estimate=replace(c, radius95_m=r95)))
    seen = {r.crowd_id for r in crowds}
    # a crowd missed for a frame (held by its walk, step 6) is the same blob when seen again
    kept.update((cid, v) for cid, v in prev.items() if cid not in seen and stamp_s - v[0] <= cfg.coast_s)
    return out, kept


def _mingling(crowds: list[ReportedCrowd], cfg: GroupingConfig) -> list[ReportedCrowd]:
    """Step 9: each crowd whose footprint comes within ``mingle_m`` of another's, its radius widened to hold
    also the two crowds' joint centre (their mean weighted by moving pixels): the walkers of two crowds that
    close may be within the 2 m that makes them one crowd, and no cut in the blobs tells."""
    if len(crowds) < 2:
        return crowds
    en = np.array([[r.estimate.east_m, r.estimate.north_m] for r in crowds], float)
    w = np.array([r.estimate.area_px for r in crowds], float)
    gap = _box_gaps_m(_boxes_en([r.estimate for r in crowds]))
    out = list(crowds)
    for i, j in np.argwhere(np.triu(gap <= cfg.mingle_m, 1)).tolist():
        joint = (w[i] * en[i] + w[j] * en[j]) / (w[i] + w[j])
        for k in (i, j):
            c = out[k].estimate
            r95 = float(np.hypot(crowds[k].estimate.radius95_m, np.hypot(*(en[k] - joint))))
            if r95 > c.radius95_m:
                out[k] = replace(out[k], estimate=replace(c, radius95_m=r95))
    return out


@dataclass(frozen=True, slots=True)
class Smoothed:
    """Step 10: a crowd's constant-velocity filter at ``stamp_s``: east, north (m) and their rates (m/s), and
    their covariance."""

    stamp_s: float
    x: np.ndarray                      # (4,), or (6,) with the measured velocity's bias (``_carried_step``)
    P: np.ndarray                      # (4, 4), or (6, 6)
    area_px: float                     # the moving pixels of the estimate it last took
    skipped: int = 0                   # estimates off its gate skipped in a row, up to this frame
    by_pose: bool = False              # the estimates it took were placed by the camera's pose (POSE)
    noise_m: float = 0.0               # the frame noise (1 sigma per axis) its crowd's track last measured
    log_area_fast: float = 0.0         # the log of its estimates' moving pixels averaged over smooth_area_fast_s
    log_area_slow: float = 0.0         # ... and over smooth_area_slow_s (first-order, from the filter's start)


SMOOTH_GAP_S = 0.5          # a crowd unseen (or unreported) this long starts its filter afresh
SMOOTH_START_SIGMA_V_M_S = 1.0   # a fresh filter's velocity (its track's) known to this per axis (1 sigma)


def _smoothed(prev: Mapping[int, Smoothed], crowds: list[ReportedCrowd], fast_of: Mapping[int, float | None],
              stamp_s: float, cfg: GroupingConfig) -> tuple[list[ReportedCrowd], dict[int, Smoothed]]:
    """Step 10: each crowd seen placed where its filter has it, its radius holding what the filter leaves of the
    declared frame noise in place of that noise; the filters, per crowd id. ``fast_of``: per track seen this
    frame, :func:`fast_scatter_m` of its trail (step 1's); a crowd whose track has none yet is reported as
    estimated, unless it has a filter (within ``SMOOTH_GAP_S``), which goes on at the noise it last took."""
    if not cfg.smooth_accel_m_s2 > 0.0:
        return crowds, {}
    out, kept = [], {}
    for r in crowds:
        fast = fast_of.get(r.track.track_id)
        f = prev.get(r.crowd_id)
        if fast is None and f is not None and 0.0 < stamp_s - f.stamp_s <= SMOOTH_GAP_S:
            fast = f.noise_m        # its blob went to a young track (a cut part's): the noise its own track measured
        if r.unseen_s > 0.0 or fast is None:    # held by its walk (step 6): a prediction already; or its track
            out.append(r)                       # too young to have measured its noise, nor its velocity
            continue
        c = r.estimate
        sigma_m = max(fast, cfg.smooth_min_sigma_m)
        if r.partly_seen:
            sigma_m = max(sigma_m, c.radius95_m / R95_PER_SIGMA)
        by_pose = c.quality == FitQuality.POSE
        if f is not None and f.by_pose != by_pose:   # the steady error its estimates share changed: afresh
            f = None
        quick, slow = _area_means(f, c.area_px, stamp_s, cfg)   # a crowd partly seen was placed by its walk (step 7)
        f = _filter_step(f, r, sigma_m, stamp_s, cfg, 0.0 if r.partly_seen else max(slow - quick, 0.0))
        f = replace(f, by_pose=by_pose, noise_m=fast, log_area_fast=quick, log_area_slow=slow)
        kept[r.crowd_id] = f
        left95 = R95_PER_SIGMA * float(np.sqrt((f.P[0, 0] + f.P[1, 1]) / 2.0))
        noise95 = min(R95_PER_SIGMA * sigma_m, c.frame_radius95_m, c.radius95_m)
        r95 = float(np.sqrt(max(c.radius95_m ** 2 - noise95 ** 2 + left95 ** 2, left95 ** 2)))
        shift = f.x[:2] - (c.east_m, c.north_m)
        out.append(replace(r, estimate=replace(c, east_m=float(f.x[0]), north_m=float(f.x[1]), radius95_m=r95,
                                               footprint_en_m=c.footprint_en_m + shift)))
    return out, kept


def _area_means(prev: Smoothed | None, area_px: float, stamp_s: float, cfg: GroupingConfig) -> tuple[float, float]:
    """The log of a crowd's moving pixels averaged over ``smooth_area_fast_s`` and ``smooth_area_slow_s`` (first-order)
    up to this frame's ``area_px``, from its filter ``prev``; afresh (both this frame's) without one or after a gap."""
    now = float(np.log(max(area_px, 1.0)))
    if prev is None or not 0.0 < stamp_s - prev.stamp_s <= SMOOTH_GAP_S:
        return now, now
    dt = stamp_s - prev.stamp_s
    return (prev.log_area_fast + (1.0 - np.exp(-dt / cfg.smooth_area_fast_s)) * (now - prev.log_area_fast),
            prev.log_area_slow + (1.0 - np.exp(-dt / cfg.smooth_area_slow_s)) * (now - prev.log_area_slow))


def _filter_step(prev: Smoothed | None, r: ReportedCrowd, sigma_m: float, stamp_s: float, cfg: GroupingConfig,
                 lost: float = 0.0) -> Smoothed:
    """One Kalman step of a crowd's constant-velocity filter (white acceleration of ``smooth_accel_m_s2`` per
    axis) with its estimate at ``sigma_m`` per axis; afresh at the estimate, with its track's velocity, when
    there is none, after a gap, when the estimate's moving pixels changed by more than ``smooth_area_ratio``
    (walkers that joined or left its blob move its centre: field-alt100-lm6 seed 9 at 47.2-47.8 s, the second
    crowd leaving, followed 1-2 m behind), or when the estimate lies ``smooth_gate`` standard deviations off
    for more than ``smooth_skip_frames`` frames in a row (before that, the estimate is skipped: predicted, not
    updated). With ``smooth_blob_sigma_m``, a crowd whose walkers' velocity was measured: :func:`_carried_step`."""
    if cfg.smooth_blob_sigma_m > 0.0 and r.estimate.v_en_m_s is not None:
        return _carried_step(prev, r, sigma_m, stamp_s, cfg, lost)
    if prev is not None and len(prev.x) > 4:   # the walkers' velocity not measured this frame: its bias kept aside
        prev = replace(prev, x=prev.x[:4], P=prev.P[:4, :4])
    z = np.array([r.estimate.east_m, r.estimate.north_m])
    R = sigma_m ** 2 * np.eye(2)
    area = r.estimate.area_px
    if (prev is not None and 0.0 < stamp_s - prev.stamp_s <= SMOOTH_GAP_S
            and prev.area_px <= area * cfg.smooth_area_ratio and area <= prev.area_px * cfg.smooth_area_ratio):
        F, Q = _transition(stamp_s - prev.stamp_s, 4, cfg)
        x, P = F @ prev.x, F @ prev.P @ F.T + Q
        S = P[:2, :2] + R
        y = z - x[:2]
        if float(y @ np.linalg.solve(S, y)) <= cfg.smooth_gate ** 2:
            K = np.linalg.solve(S, P[:2, :]).T     # P H^T S^-1, H picking the position
            return Smoothed(stamp_s, x + K @ y, P - K @ P[:2, :], area)
        if prev.skipped < cfg.smooth_skip_frames:  # one frame's jump: the transform's, not the crowd's
            return Smoothed(stamp_s, x, P, prev.area_px, prev.skipped + 1)
    v = (r.track.v_east_m_s, r.track.v_north_m_s)
    return Smoothed(stamp_s, np.array([z[0], z[1], v[0], v[1]]),
                    np.diag([sigma_m ** 2, sigma_m ** 2, SMOOTH_START_SIGMA_V_M_S ** 2, SMOOTH_START_SIGMA_V_M_S ** 2]),
                    area)


def _layout(cfg: GroupingConfig) -> tuple[int, int | None, int | None]:
    """Step 10's filter with the walkers' velocity (:func:`_carried_step`): its number of states and where the
    measured velocity's bias (``smooth_bias_m_s`` > 0) and the blob's lasting offset from its crowd
    (``smooth_lost_offset`` > 0) start in it (None: not in it), after east, north and their rates."""
    n, bias, off = 4, None, None
    if cfg.smooth_bias_m_s > 0.0:
        bias, n = n, n + 2
    if cfg.smooth_lost_offset > 0.0:
        off, n = n, n + 2
    return n, bias, off


def _place_rows(n: int, off: int | None) -> np.ndarray:
    """(2, ``n``): what of :func:`_carried_step`'s ``n`` states makes its crowd's blob's place: the crowd's, and the
    blob's lasting offset from it where that starts at ``off`` (:func:`_layout`)."""
    H = np.eye(n)[:2]
    if off is not None:
        H[0, off] = H[1, off + 1] = 1.0
    return H


def _transition(dt: float, n: int, cfg: GroupingConfig, offset_sigma_m: float = 0.0
                ) -> tuple[np.ndarray, np.ndarray]:
    """Step 10's filters over ``dt`` s: the state's transition and process noise, ``n`` states (east, north, their
    rates; more: :func:`_layout`'s): white acceleration of ``smooth_accel_m_s2`` per axis, the bias walking
    ``smooth_bias_walk_m_s`` per square root of a second, the blob's offset from its crowd going back to none
    over ``smooth_blob_tau_s`` (first-order, spreading towards ``offset_sigma_m`` per axis)."""
    F = np.eye(n)
    F[0, 2] = F[1, 3] = dt
    G = np.array([[dt * dt / 2.0, 0.0], [0.0, dt * dt / 2.0], [dt, 0.0], [0.0, dt]])
    Q = np.zeros((n, n))
    Q[:4, :4] = cfg.smooth_accel_m_s2 ** 2 * (G @ G.T)
    if n > 4:
        _, bias, off = _layout(cfg)
        if bias is not None:
            Q[bias, bias] = Q[bias + 1, bias + 1] = cfg.smooth_bias_walk_m_s ** 2 * dt
        if off is not None:
            a = float(np.exp(-dt / cfg.smooth_blob_tau_s))
            F[off, off] = F[off + 1, off + 1] = a
            Q[off, off] = Q[off + 1, off + 1] = offset_sigma_m ** 2 * (1.0 - a * a)
    return F, Q


def _carried_step(prev: Smoothed | None, r: ReportedCrowd, sigma_m: float, stamp_s: float, cfg: GroupingConfig,
                  lost: float = 0.0) -> Smoothed:
    """One Kalman step of a crowd's constant-velocity filter that also takes its walkers' velocity as measured
    (``CrowdEstimate.v_en_m_s``: white noise of ``smooth_sigma_v_m_s`` and ``smooth_spread_k`` times its declared
    spread per axis, plus a bias the filter learns, ``smooth_bias_m_s``; a measurement off the gate is left out)
    and weighs the blob's place as also off by its offset from the crowd (walkers out of sight or back): white from
    frame to frame (``smooth_blob_sigma_m``), and a state of the filter that lasts, spreading by
    ``smooth_lost_offset`` times ``lost`` (the log of the moving pixels lost, :func:`_area_means`) half-diagonals of
    the footprint: a blob that drifts as walkers go out of sight does not take the crowd with it, and walkers that
    join or leave the blob start nothing afresh. The states: :func:`_layout` (the bias kept aside in frames whose
    velocity was not measured, :func:`_filter_step`, and the offset dropped). A gap, a first estimate, or one off
    the gate (after ``smooth_skip_frames``) start it afresh."""
    c = r.estimate
    z = np.array([c.east_m, c.north_m])
    zv = np.asarray(c.v_en_m_s, float)
    nb, bias, off = _layout(cfg)
    rp = sigma_m ** 2 + cfg.smooth_blob_sigma_m ** 2
    rv = cfg.smooth_sigma_v_m_s ** 2 + (cfg.smooth_spread_k * c.sigma_v_m_s) ** 2
    area = c.area_px
    prior = np.zeros(nb)                         # the variances of the states past the first four, as at a start
    if bias is not None:
        prior[bias:bias + 2] = cfg.smooth_bias_m_s ** 2
    if prev is not None and len(prev.x) != nb:
        x6, P6 = np.zeros(nb), np.diag(prior)
        m = min(nb, len(prev.x))
        x6[:m], P6[:m, :m] = prev.x[:m], prev.P[:m, :m]
        prev = replace(prev, x=x6, P=P6)
    Hp = _place_rows(nb, off)
    if prev is not None and 0.0 < stamp_s - prev.stamp_s <= SMOOTH_GAP_S:
        offset_sigma_m = 0.0
        if off is not None and lost > 0.0:   # the footprint's half-diagonal sets the scale of what the loss moves
            offset_sigma_m = cfg.smooth_lost_offset * lost * 0.5 * float(
                np.hypot(*np.ptp(np.asarray(c.footprint_en_m, float), axis=0)))
        F, Q = _transition(stamp_s - prev.stamp_s, nb, cfg, offset_sigma_m)
        x, P = F @ prev.x, F @ prev.P @ F.T + Q
        y = z - Hp @ x
        Hv = np.zeros((2, nb))
        Hv[0, 2] = Hv[1, 3] = 1.0
        if bias is not None:
            Hv[0, bias] = Hv[1, bias + 1] = 1.0
        if float(y @ np.linalg.solve(Hp @ P @ Hp.T + rp * np.eye(2), y)) <= cfg.smooth_gate ** 2:
            yv = zv - Hv @ x
            take_v = float(yv @ np.linalg.solve(Hv @ P @ Hv.T + rv * np.eye(2), yv)) <= cfg.smooth_gate ** 2
            Hm = np.vstack([Hp, Hv]) if take_v else Hp
            R = np.diag([rp, rp, rv, rv]) if take_v else rp * np.eye(2)
            yy = np.concatenate([y, yv]) if take_v else y
            K = np.linalg.solve(Hm @ P @ Hm.T + R, Hm @ P).T
            P = P - K @ Hm @ P
            return Smoothed(stamp_s, x + K @ yy, (P + P.T) / 2.0, area)
        if prev.skipped < cfg.smooth_skip_frames:
            return Smoothed(stamp_s, x, P, prev.area_px, prev.skipped + 1)
    x0 = np.concatenate([z, zv, np.zeros(nb - 4)])
    P0 = np.diag([sigma_m ** 2, sigma_m ** 2, rv, rv] + list(prior[4:]))
    return Smoothed(stamp_s, x0, P0, area)


def _came_out(state: GroupingState, estimates: tuple[CrowdEstimate, ...], en: np.ndarray, trk: list[CrowdTrack],
              stamp_s: float, cfg: GroupingConfig) -> dict[int, tuple[int, int]]:
    """Step 8's crowds walking out of the blob that held them: per estimate (index; ``en`` their east/north m),
    the host's track and the held crowd's id. An estimate is a held crowd coming out when its track was first seen
    after the crowd was last seen on its own, it has ``held_share`` of the crowd's usual moving pixels, and it
    lies nearer where the crowd's walk has it than where the host's does (within ``near_m``); the nearest such
    estimate per held crowd. Two crowds passing each other (the two-crowd world's tuning seed 12 at 14.7 s) came
    out of one blob 9-10 m apart and, the part that came out young in the host's footprint, were one crowd until a
    drift that never came."""
    out: dict[int, tuple[int, int]] = {}
    for cid, held in state.inside.items():
        host = state.last_seen.get(cid)
        if host is None:
            continue
        host_track = host.crowd.track.track_id
        d_host = np.hypot(*(en - host.walk_at(stamp_s, cfg)[0]).T)
        for ls in held:
            d = np.hypot(*(en - ls.walk_at(stamp_s, cfg)[0]).T)
            ok = [k for k in range(len(trk)) if trk[k].track_id != host_track and trk[k].first_s > ls.seen_s
                  and k not in out and estimates[k].area_px >= cfg.held_share * ls.usual_px()
                  and d[k] < min(d_host[k], cfg.near_m)]
            if ok:
                out[min(ok, key=lambda k: d[k])] = (host_track, ls.crowd.crowd_id)
    return out


def _boxes_en(estimates) -> np.ndarray:
    """(n, 4): each estimate's footprint as the box east/north min/max."""
    return np.array([[*c.footprint_en_m.min(0), *c.footprint_en_m.max(0)] for c in estimates], float).reshape(-1, 4)


def _box_gaps_m(boxes_en: np.ndarray) -> np.ndarray:
    """(n, n): the distance between each two boxes (east/north min/max), 0 where they touch or overlap."""
    lo, hi = boxes_en[:, :2], boxes_en[:, 2:]
    gap = np.maximum(0.0, np.maximum(lo[:, None] - hi[None], lo[None] - hi[:, None]))
    return np.sqrt((gap ** 2).sum(-1))


def _joined_after(joined: frozenset[Pair], ids: list[int], labels: list[int], live: Mapping[int, CrowdTrack]
                  ) -> frozenset[Pair]:
    """:attr:`GroupingState.joined` after this frame: each pair of this frame's parts (track ``ids``, group
    ``labels``) is in it if they were one crowd; pairs not both parts this frame keep what they were, until
    either track is forgotten."""
    out = set(joined)
    for a in range(len(ids)):
        for b in range(a + 1, len(ids)):
            pair = _pair(ids[a], ids[b])
            if labels[a] == labels[b]:
                out.add(pair)
            else:
                out.discard(pair)
    return frozenset(p for p in out if p[0] in live and p[1] in live)


def _in_boxes(points_en: np.ndarray, boxes_en: np.ndarray, margin_m: float = 0.0) -> np.ndarray:
    """(boxes, points): whether each point (east, north) lies in each box (e0, n0, e1, n1) widened by
    ``margin_m`` on every side, its edges included."""
    p = np.asarray(points_en, float).reshape(1, -1, 2)
    b = np.asarray(boxes_en, float).reshape(-1, 1, 4)
    return ((b[..., :2] - margin_m <= p) & (p <= b[..., 2:] + margin_m)).all(-1)


def _young_parts(state: GroupingState, estimates: tuple[CrowdEstimate, ...], confirmed: list[int],
                 stamp_s: float, holds: Mapping, cfg: GroupingConfig, skip: frozenset[int] = frozenset()
                 ) -> dict[int, int]:
    """Step 5's exception: the estimates of tracks seen fewer than ``confirm_hits`` times whose centre
    lies in the footprint of a crowd seen in the last frame that crowds were seen in (moved on by
    its track's velocity), unless that crowd's track holds crowds of step 4, and only as much as the
    crowd's confirmed parts there miss of its moving pixels then, or of those it usually has if it was
    partly seen (they hold under ``seen_whole`` of them; with the young parts, biggest first, no more
    than that share over). A crowd's blob cut in two gives its old track one part and a new track the
    other: that part is the crowd's from its first frame, not a blob to be confirmed while the crowd is
    reported as the other part alone; a stray blob beside a crowd seen whole still joins nothing until
    confirmed."""
    seen = [ls for ls in state.last_seen.values() if ls.seen_s < stamp_s and ls.crowd.unseen_s == 0.0
            and ls.crowd.track.track_id not in holds]
    if not seen:
        return {}
    last_s = max(ls.seen_s for ls in seen)
    centres = np.array([[c.east_m, c.north_m] for c in estimates], float).reshape(-1, 2)
    young: dict[int, int] = {}    # estimate -> the id of the crowd it is a part of
    for ls in seen:
        if ls.seen_s != last_s:
            continue
        tr, dt = ls.crowd.track, stamp_s - ls.seen_s
        fp = ls.crowd.estimate.footprint_en_m + (tr.v_east_m_s * dt, tr.v_north_m_s * dt)
        inside = np.flatnonzero(_in_boxes(centres, np.hstack([fp.min(0), fp.max(0)]))[0]).tolist()
        whole = ls.crowd.estimate.area_px
        if ls.crowd.partly_seen:   # what it usually has: its own part plus the parts it lost
            whole = max(whole, ls.usual_px())
        # only what the crowd's confirmed parts miss of it: a blob beside a crowd seen whole is no part
        have = sum(estimates[k].area_px for k in inside if k in confirmed)
        for k in sorted((k for k in inside if k not in confirmed and k not in young and k not in skip),
                        key=lambda k: -estimates[k].area_px):
            if have < cfg.seen_whole * whole and have + estimates[k].area_px <= whole / cfg.seen_whole:
                young[k] = ls.crowd.crowd_id
                have += estimates[k].area_px
    return young


def _whole_anew(state: GroupingState, estimates: tuple[CrowdEstimate, ...], members: list[int], track_id: int,
                young: Mapping[int, int], seen_ids: set[int], cfg: GroupingConfig) -> int | None:
    """Step 5's young part alone: the id of the crowd it is a part of (:func:`_young_parts`) when the crowd was
    last seen in two or more parts, the young part holds ``seen_whole`` of the moving pixels they had and no
    confirmed part of the crowd is seen (``seen_ids``: the crowds of the confirmed parts), or the young part's
    track (``track_id``) was so taken for the crowd the frame before, else None. A crowd seen in parts whose
    blobs become one on a new track is that crowd seen whole from the first frame, not a crowd unseen held by
    its lead part's walk (real-alt120-lm6-gnss1 seed 148 at 15.9 s: two parts 8 m apart, 4.6 m off for two
    frames). Young parts alone in twos are a blob breaking up, two crowds as often as one (field-alt100-lm6
    seed 9 at 47.9 s); a crowd seen in one part is held by its own walk."""
    cid = young.get(members[0]) if len(members) == 1 else None
    ls = state.last_seen.get(cid) if cid is not None and cid not in seen_ids else None
    if ls is None or (state.crowd_of.get(track_id) != cid and sum(
            state.crowd_of.get(t.track_id) == cid and t.stamp_s == ls.seen_s for t in state.tracker.tracks) < 2):
        return None
    whole = max(ls.crowd.estimate.area_px, ls.usual_px()) if ls.crowd.partly_seen else ls.crowd.estimate.area_px
    return cid if sum(estimates[k].area_px for k in members) >= cfg.seen_whole * whole else None


def _lead_key(state: GroupingState, track: CrowdTrack, estimate: CrowdEstimate) -> tuple:
    """Sort key of a crowd's part to report it under (step 5): the longest seen; of parts seen as often, the
    crowd's own track (the one its id is), else, reported in no crowd yet, the biggest. Parts first seen in
    one frame tie for as long as both are seen (a crowd first seen when the motion detector's lagged test
    starts: :mod:`uvteam.vision.motion`); the track's id broke the tie, and the two-crowd world's fresh seed
    211 was reported under the track of a crowd's straggler, which later parted from it (the world's seeds
    209-215 replayed with the warm-up: 63 id changes, 47 with this key and without the warm-up)."""
    own = state.crowd_of.get(track.track_id)
    return (-track.hits, own != track.track_id, -estimate.area_px if own is None else 0.0, track.track_id)


def _unknown_blob(state: GroupingState, track: CrowdTrack, cfg: GroupingConfig) -> bool:
    """Whether a confirmed part is of a crowd with no blob known yet: one its own track was seen in fewer than
    ``2 confirm_hits - 1`` frames (reported in fewer than ``confirm_hits``), a part of no other crowd."""
    return (track.hits < 2 * cfg.confirm_hits - 1
            and state.crowd_of.get(track.track_id, track.track_id) == track.track_id)


def _waits(state: GroupingState, en: np.ndarray, trk: list[CrowdTrack], members: list[int], lead: int,
           once: list[int], cfg: GroupingConfig) -> bool:
    """Whether a crowd about to be reported for the first time (its parts, ``members``, and ``lead`` as
    estimate indices; ``en``: the estimates' east/north m) waits a frame: its lead track was seen
    ``confirm_hits`` times, just now, none of its parts is of a crowd, and a blob seen fewer than
    ``confirm_hits - 1`` times (``once``: in no group) lies within ``near_m`` of a part of it. Seen again,
    that blob is a part of it (:func:`_starting_parts`); gone, it was not. paper-fig7-alt50 and -alt200
    seed 4 at 0.3 s: a crowd's second part, first seen in the frame the crowd was, 7.7 m from the first;
    the crowd reported from the first part 1.61 / 1.66 m off, 0.17 / 0.37 m the frame after."""
    if trk[lead].hits != cfg.confirm_hits or not once or any(trk[k].track_id in state.crowd_of for k in members):
        return False
    d = np.hypot(*(en[members][:, None] - en[once][None]).transpose(2, 0, 1))
    return bool((d < cfg.near_m).any())


def _starting_parts(state: GroupingState, en: np.ndarray, trk: list[CrowdTrack], confirmed: list[int],
                    taken: frozenset[int], cfg: GroupingConfig) -> dict[int, int]:
    """Step 5's other exception: the estimates (``en``: their east/north m) of tracks seen once less than
    ``confirm_hits`` times, never parts of a crowd (nor in ``taken``), whose nearest confirmed part lies within
    ``near_m``, each with that part (estimate indices); :func:`report_crowds` takes them into that part's crowd
    when no confirmed part of it, that one included, has a blob known (:func:`_unknown_blob`). A crowd whose
    blob shows in two parts from its first frames has no footprint yet that tells its parts from a blob beside
    it; reported from the part confirmed first, it is that part's distance off."""
    if not confirmed:
        return {}
    anchors = np.array(confirmed)
    out = {}
    for k in range(len(trk)):
        if (not cfg.confirm_hits - 1 <= trk[k].hits < cfg.confirm_hits or k in taken
                or trk[k].track_id in state.crowd_of):
            continue
        d = np.hypot(*(en[anchors] - en[k]).T)
        j = int(anchors[int(np.argmin(d))])
        if d.min() < cfg.near_m:
            out[k] = j
    return out


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
        return np.flatnonzero(_in_boxes(p, boxes_en, HOLD_MARGIN_M).all(1))

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
            held = tuple(sorted(holds.get(x, ()) + taken
                                + (Held(stamp_s, (a, b), lost, (a, b) in state.drifted),) * hidden))
            if held:
                holds[x] = held
    return holds
