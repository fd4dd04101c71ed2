"""The services' own classes on the in-memory bus: what they take in, refuse, and put out.

Each test wires a node as its service shell does (bus, autopilot, clock) and talks to it through the
bus only, as the other vehicles would.
"""

import math

import cv2
import numpy as np
import pytest

from uvteam import keys
from uvteam.autopilot import MemoryAutopilot, VehicleState
from uvteam.blobs import Blobs, Landmarks
from uvteam.bus import InMemoryBus
from uvteam.camera import CameraPose, PinholeCamera, project
from uvteam.config import LocalizerServiceConfig, UavConfig, UgvConfig, VehicleConfig
from uvteam.geo import LocalFrame
from uvteam.messages import Crowd, Crowds, Detections, Fix, Plan
from uvteam.nodes.localizer import LocalizerNode
from uvteam.nodes.uav import UavNode
from uvteam.nodes.ugv import UgvNode

TEAM = "t"
T0 = 1_700_000_000.0
FRAME = LocalFrame(31.4850, -111.5440)
CAM = PinholeCamera(1280, 720, 78.0)
POSE = CameraPose(0.0, 0.0, 50.0)
UGVS = {"ugv1": (12.0, 0.0), "ugv2": (0.0, 12.0), "ugv3": (-12.0, 1.0), "ugv4": (2.0, -12.0)}
CROWD = (2.0, 3.0)


class Clock:
    def __init__(self, t):
        self.t = t

    def __call__(self):
        return self.t


def fix(v, t, en, h_acc=0.3, fix_type=3):
    lat, lon = FRAME.ground_to_wgs84(*en)
    return Fix(v, t, float(lat), float(lon), 1300.0, 90.0, h_acc, 0.0, 0.0, fix_type)


def detections(t, ugvs=UGVS, crowd=CROWD, vehicle="uav1", n_noise=0):
    names = sorted(ugvs)
    lm = project(CAM, POSE, np.array([ugvs[u] for u in names]))
    c = project(CAM, POSE, np.array([crowd]))
    noise = np.random.default_rng(0).uniform([100, 100], [300, 300], (n_noise, 2))
    xy = np.vstack([lm, c, noise])
    areas = np.r_[np.full(len(names), 50.0), 400.0, np.full(n_noise, 5.0)]
    return Detections(vehicle, t, 1, 1280, 720, 50.0, CAM.focal_px, Landmarks(tuple(names), lm),
                      Blobs(xy, np.column_stack([xy - 10, xy + 10]), areas), 0.5, 1.0, 1.5)


@pytest.fixture
def loc():
    hub = InMemoryBus()
    clock = Clock(T0)
    cfg = VehicleConfig(TEAM, "loc1", "localizer", localizer=LocalizerServiceConfig(ugvs=tuple(UGVS), confirm_hits=1))
    node = LocalizerNode(cfg, InMemoryBus(hub), clock)
    node.start()
    out = []
    peer = InMemoryBus(hub)
    peer.subscribe(keys.key(TEAM, "loc1", "crowds"), Crowds, lambda k, m: out.append(m))
    return node, peer, clock, out


def feed_fixes(peer, t0, t1, ugvs=UGVS):
    for t in np.arange(t0, t1 + 1e-9, 0.1):
        for u, en in ugvs.items():
            peer.publish(keys.key(TEAM, u, "fix"), fix(u, T0 + t, en))


def test_localizer_node_puts_the_crowd_on_the_map(loc):
    node, peer, clock, out = loc
    clock.t = T0 + 1.0
    feed_fixes(peer, 0.0, 1.0)
    peer.publish(keys.key(TEAM, "uav1", "detections"), detections(T0 + 1.0))
    node.step(0.0)
    (msg,) = out
    assert msg.vehicle == "loc1" and msg.uav == "uav1" and msg.quality == "exact" and len(msg.crowds) == 1
    truth = FRAME.ground_to_wgs84(*CROWD)    # the node's own frame starts at the first fix; WGS84 is WGS84
    assert (msg.crowds[0].lat_deg, msg.crowds[0].lon_deg) == pytest.approx(truth, abs=1e-8)
    assert node.metrics()["crowds_published"] == 1


def test_a_spoofed_or_future_fix_changes_nothing(loc):
    node, peer, clock, out = loc
    clock.t = T0 + 1.0
    feed_fixes(peer, 0.0, 1.0)
    # under another vehicle's key: refused and counted
    peer.publish(keys.key(TEAM, "ugv9", "fix"), fix("ugv3", T0 + 1.05, (40.0, 40.0)))
    # under its own key but dated in the future: refused, and it does not pin the track
    peer.publish(keys.key(TEAM, "ugv3", "fix"), fix("ugv3", T0 + 45.0, (40.0, 40.0)))
    assert sum(peer.rejected.values()) == 0 and sum(node.bus.rejected.values()) == 2
    assert node.metrics()["fixes_refused_future"] == 1
    clock.t = T0 + 1.2
    peer.publish(keys.key(TEAM, "ugv3", "fix"), fix("ugv3", T0 + 1.1, UGVS["ugv3"]))
    assert node.fixes["ugv3"][-1].stamp_s == T0 + 1.1     # the genuine fix after it was taken


@pytest.mark.parametrize(
    "bad, reason",
    [
        (dict(fix_type=1), "no_3d_fix"),        # no GNSS fix
        (dict(h_acc=1000.0), "inaccurate"),     # 1000 m accuracy is no landmark
    ],
)
def test_fixes_without_a_usable_position_are_refused(loc, bad, reason):
    node, peer, clock, out = loc
    clock.t = T0 + 1.0
    feed_fixes(peer, 0.0, 0.5)
    f = fix("ugv1", T0 + 0.6, UGVS["ugv1"], **{k: v for k, v in bad.items() if k == "h_acc"},
            **{k: v for k, v in bad.items() if k == "fix_type"})
    peer.publish(keys.key(TEAM, "ugv1", "fix"), f)
    assert node.metrics()[f"fixes_refused_{reason}"] == 1 and node.fixes["ugv1"][-1].stamp_s == T0 + 0.5


def test_a_jump_is_refused_once_and_taken_when_it_stays(loc):
    node, peer, clock, out = loc
    clock.t = T0 + 2.0
    feed_fixes(peer, 0.0, 1.0)
    far = (200.0, 0.0)                                   # 190 m in 0.1 s: no UGV drives that
    peer.publish(keys.key(TEAM, "ugv1", "fix"), fix("ugv1", T0 + 1.1, far))
    assert node.fixes["ugv1"][-1].stamp_s == T0 + 1.0 and node.metrics()["fixes_refused_jump"] == 1
    for t in (1.2, 1.3):                                 # three in a row that agree: the UGV is there
        peer.publish(keys.key(TEAM, "ugv1", "fix"), fix("ugv1", T0 + t, far))
    assert [f.stamp_s for f in node.fixes["ugv1"]] == [T0 + 1.1, T0 + 1.2, T0 + 1.3]


def test_detections_only_from_its_uav_and_bounded(loc):
    node, peer, clock, out = loc
    clock.t = T0 + 1.0
    feed_fixes(peer, 0.0, 1.0)
    # a stranger's detections published under the UAV's key: refused
    peer.publish(keys.key(TEAM, "uav1", "detections"), detections(T0 + 1.0, vehicle="uav2"))
    node.step(0.0)
    assert out == [] and sum(node.bus.rejected.values()) == 1
    # 1000 small noise blobs beside the team: only the largest max_blobs (64) are looked at; the crowd stays
    peer.publish(keys.key(TEAM, "uav1", "detections"), detections(T0 + 1.0, n_noise=1000))
    node.step(0.0)
    assert node.metrics()["blobs_dropped"] == len(UGVS) + 1 + 1000 - 64
    assert any(np.hypot(*np.subtract(FRAME.wgs84_to_ground(c.lat_deg, c.lon_deg), CROWD)) < 1e-3 for c in out[-1].crowds)


def test_a_lost_ugv_is_no_landmark(loc):
    node, peer, clock, out = loc
    clock.t = T0 + 1.0
    feed_fixes(peer, 0.0, 1.0)
    peer.declare_alive(keys.alive(TEAM, "ugv4"))
    peer.drop_alive(keys.alive(TEAM, "ugv4"))
    peer.publish(keys.key(TEAM, "uav1", "detections"), detections(T0 + 1.0))
    node.step(0.0)
    # three landmarks left and no earlier transform: no crowd rather than a UGV's blob as one
    assert out[-1].landmarks_used == ("ugv1", "ugv2", "ugv3") and out[-1].quality == "failed" and out[-1].crowds == ()
    assert node.metrics()["ugvs_lost"] == 1


# --- the UGV --------------------------------------------------------------------------------------------

@pytest.fixture
def ugv():
    hub = InMemoryBus()
    clock = Clock(T0)
    ap = MemoryAutopilot()
    cfg = VehicleConfig(TEAM, "ugv1", "ugv", ugv=UgvConfig(uav="uav1", localizer="loc1", team_ugvs=tuple(UGVS),
                                                            station_radius_m=12.0))
    node = UgvNode(cfg, InMemoryBus(hub), ap, clock)
    node.start()
    peer = InMemoryBus(hub)
    got = {"fix": [], "plan": []}
    peer.subscribe(keys.key(TEAM, "ugv1", "fix"), Fix, lambda k, m: got["fix"].append(m))
    peer.subscribe(keys.key(TEAM, "ugv1", "plan"), Plan, lambda k, m: got["plan"].append(m))
    return node, peer, ap, clock, got


def state(t, en, **kw):
    lat, lon = FRAME.ground_to_wgs84(*en)
    base = dict(stamp_s=t, stamp_source="autopilot", lat_deg=float(lat), lon_deg=float(lon), alt_amsl_m=1300.0,
                alt_agl_m=0.0, heading_deg=90.0, v_east_m_s=0.0, v_north_m_s=0.0, h_acc_m=0.5, fix_type=3)
    return VehicleState(**{**base, **kw})


@pytest.mark.parametrize(
    "kw, published",
    [
        ({}, True),                              # a 3D fix, 0.5 m
        ({"fix_type": 1}, False),                # no fix
        ({"fix_type": None}, False),             # the autopilot does not say: not vouched for
        ({"h_acc_m": 1000.0}, False),            # far too inaccurate
        ({"heading_deg": None}, True),           # a position without a heading is still a position...
    ],
)
def test_ugv_publishes_only_usable_fixes(ugv, kw, published):
    node, peer, ap, clock, got = ugv
    ap.set_state(state(T0, UGVS["ugv1"], **kw))
    node.publish_fix()
    assert bool(got["fix"]) is published
    if published and "heading_deg" in kw:
        assert got["fix"][0].heading_deg is None         # ...and its heading stays unknown, never 0


def test_ugv_warns_of_an_unknown_fix_type_only_when_it_persists(ugv, caplog):
    """A position before the first GPS_RAW_INT is the stream starting: withheld, no warning. Still
    unknown 5 s of autopilot time later, or a known bad fix at once, is worth one."""
    node, peer, ap, clock, got = ugv
    caplog.set_level("DEBUG", logger="uvteam.ugv")
    for t in (T0, T0 + 1.0, T0 + 4.0):
        ap.set_state(state(t, UGVS["ugv1"], fix_type=None))
        node.publish_fix()
    assert not got["fix"] and node.counts["fixes_withheld"] == 3
    assert not [r for r in caplog.records if r.levelname == "WARNING"]
    ap.set_state(state(T0 + 6.0, UGVS["ugv1"], fix_type=None))
    node.publish_fix()
    assert [r.getMessage() for r in caplog.records if r.levelname == "WARNING"] == [
        "fix withheld: fix type None, accuracy 0.5 m"]


def test_ugv_warns_of_a_known_bad_fix_at_once(ugv, caplog):
    node, peer, ap, clock, got = ugv
    ap.set_state(state(T0, UGVS["ugv1"], fix_type=1))
    node.publish_fix()
    assert [r.getMessage() for r in caplog.records if r.levelname == "WARNING"] == [
        "fix withheld: fix type 1, accuracy 0.5 m"]


def crowds_msg(sender="loc1", uav="uav1", at=(2.0, 3.0), t=T0):
    lat, lon = FRAME.ground_to_wgs84(*at)
    c = Crowd(1, float(lat), float(lon), (), (), 0.0, 0.0, 1.0, "exact", 0)
    return Crowds(sender, uav, t, "exact", (), (), (c,))


def test_ugv_plans_around_the_localizers_crowd_and_uploads_its_mission(ugv):
    node, peer, ap, clock, got = ugv
    for u, en in UGVS.items():
        peer.publish(keys.key(TEAM, u, "fix"), fix(u, T0, en))
    ap.set_state(state(T0, UGVS["ugv1"]))
    node.publish_fix()
    peer.publish(keys.key(TEAM, "loc1", "crowds"), crowds_msg(at=(30.0, 30.0)))
    node.tick(T0)
    assert node.exchange_mission()
    assert ap.uploads == 1 and len(got["plan"]) == 1
    wps = got["plan"][0].waypoints
    e, n = FRAME.wgs84_to_ground(wps[-1].lat_deg, wps[-1].lon_deg)
    assert abs(math.hypot(e - 30.0, n - 30.0) - 12.0) < 0.5          # on the 12 m ring round the crowd
    assert node.metrics()["crowds_received"] == 1


def test_fake_crowds_from_a_stranger_never_reach_the_planner(ugv):
    node, peer, ap, clock, got = ugv
    ap.set_state(state(T0, UGVS["ugv1"]))
    node.publish_fix()
    for bad in (crowds_msg(sender="ugv3"),                            # another vehicle posing as the localizer
                crowds_msg(uav="uav9")):                              # the localizer's crowds of another UAV
        key = keys.key(TEAM, "loc1", "crowds")
        peer.publish(key, bad)
    peer.publish(keys.key(TEAM, "ugv3", "crowds"), crowds_msg(sender="ugv3"))   # under its own key: not subscribed
    assert node.crowd is None and sum(node.bus.rejected.values()) == 2
    assert node.metrics()["crowds_received"] == 0


def test_a_failed_mission_exchange_is_counted_and_publishes_no_plan(ugv):
    node, peer, ap, clock, got = ugv
    ap.set_state(state(T0, UGVS["ugv1"]))
    node.publish_fix()
    ap.fail_missions = True
    node.tick(T0)
    assert not node.exchange_mission() and got["plan"] == [] and node.metrics()["missions_failed"] == 1


def test_people_are_not_placed_without_a_heading(ugv):
    node, peer, ap, clock, got = ugv

    class Never:
        def detect(self, img):
            raise AssertionError("no detection without a heading")

    node.people_detector = Never()
    ap.set_state(state(T0, UGVS["ugv1"], heading_deg=None))
    node.publish_fix()
    assert node.people_frame(T0, np.zeros((480, 640, 3), np.uint8)) is None
    assert node.metrics()["people_no_heading"] == 1


# --- the UAV --------------------------------------------------------------------------------------------

def test_uav_relabels_the_sensor_model_by_ugv_id_and_drops_other_teams_colors():
    hub = InMemoryBus()
    cfg = VehicleConfig(TEAM, "uav1", "uav", uav=UavConfig(detector="sim-sensor", colors={"red": "ugv1", "blue": "ugv2"}))
    node = UavNode(cfg, InMemoryBus(hub), MemoryAutopilot(), Clock(T0))
    node.start()
    out = []
    peer = InMemoryBus(hub)
    peer.subscribe(keys.key(TEAM, "uav1", "detections"), Detections, lambda k, m: out.append(m))
    xy = np.array([[10.0, 10.0], [50.0, 50.0], [90.0, 90.0]])
    det = Detections("uav1", T0, 1, 1280, 720, 50.0, 800.0, Landmarks(("blue", "green", "red"), xy),
                     Blobs(xy, np.column_stack([xy - 5, xy + 5]), np.ones(3), ("red", "green", "")), 0.5, 1.0, 1.5)
    peer.publish(keys.key(TEAM, "uav1", "sensor"), det)
    (d,) = out
    assert d.landmarks.ugv == ("ugv2", "ugv1") and d.blobs.ugv == ("ugv1", "", "")
    assert d.sigma_crowd_blob_px == 1.5      # the detector's declared noise travels on


def test_uav_counts_the_frames_its_motion_detector_warms_up_in():
    """The pixel pipeline returns no crowd's blob until its motion detector's lagged test runs (frames
    0.3-0.4 s back): those frames are counted in the status, and only those."""
    ap = MemoryAutopilot()
    node = UavNode(VehicleConfig(TEAM, "uav1", "uav", uav=UavConfig()), InMemoryBus(InMemoryBus()), ap, Clock(T0))
    ground = cv2.GaussianBlur(np.random.default_rng(1).integers(0, 255, (380, 680)).astype(np.uint8), (0, 0), 1.5)
    for i in range(8):
        t = T0 + 0.1 * i
        ap.set_state(state(t, (0.0, 0.0), alt_agl_m=60.0))
        img = cv2.cvtColor(np.ascontiguousarray(ground[10:370, 10 + i:650 + i]), cv2.COLOR_GRAY2BGR)
        assert node.process_frame(t, i, img) is not None
    assert node.metrics()["processed"] == 8 and node.metrics()["motion_warming"] in (2, 3)


def test_uav_waits_for_the_autopilot_quietly_then_warns(caplog):
    """Frames before the autopilot's first state are refused and counted; a warning only when the
    state is still missing 5 s of frames later (a camera may start before the MAVLink streams)."""
    ap = MemoryAutopilot()
    node = UavNode(VehicleConfig(TEAM, "uav1", "uav", uav=UavConfig()), InMemoryBus(InMemoryBus()), ap, Clock(T0))
    img = np.zeros((72, 128, 3), np.uint8)
    for i, t in enumerate((T0, T0 + 2.0, T0 + 4.5)):
        assert node.process_frame(t, i, img) is None
    assert node.counts["no_altitude"] == 3
    assert not [r for r in caplog.records if r.levelname == "WARNING"]
    assert node.process_frame(T0 + 5.5, 3, img) is None
    assert [r.getMessage() for r in caplog.records if r.levelname == "WARNING"] == [
        "frame 3 not processed: no height above ground from the autopilot yet"]
