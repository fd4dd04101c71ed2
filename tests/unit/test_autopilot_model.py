"""What crosses the autopilot interface: GNSS fix quality, mission item frames and the current flag."""

import math

import numpy as np
import pytest

from uvteam.autopilot import (FRAME_GLOBAL_INT, FRAME_MISSION, MAV_CMD_DO_CHANGE_SPEED, MAV_CMD_NAV_WAYPOINT,
                              MissionItem, VehicleState, mavlink2)
from uvteam.geo import LocalFrame
from uvteam.mission import mission_to_plan, plan_to_mission
from uvteam.planning import plan_stations


def state(fix_type, h_acc_m):
    return VehicleState(1.0, "autopilot", 31.0, -111.0, 1300.0, 1.0, 0.0, 0.0, 0.0, h_acc_m, fix_type=fix_type)


@pytest.mark.parametrize("fix_type, h_acc_m, usable", [
    (3, 0.8, True),        # 3D fix, 0.8 m
    (6, 0.02, True),       # RTK fixed
    (3, 1000.0, False),    # 3D fix, but 1 km accuracy
    (3, 5.0, True),        # exactly the limit
    (2, 0.8, False),       # 2D fix
    (1, 0.8, False),       # no fix
    (0, None, False),      # no GPS
    (3, None, False),      # accuracy unknown (MAVLink 1, no h_acc)
    (None, 0.8, False),    # GPS_RAW_INT never seen
])
def test_usable_fix(fix_type, h_acc_m, usable):
    assert state(fix_type, h_acc_m).usable_fix(5.0) is usable


def test_vehicle_state_fix_type_defaults_to_unknown():
    st = VehicleState(1.0, "arrival", 31.0, -111.0, 1300.0, 1.0, None, 0.0, 0.0, None)
    assert st.fix_type is None and not st.usable_fix(100.0)


@pytest.mark.parametrize("command, frame", [
    (MAV_CMD_NAV_WAYPOINT, FRAME_GLOBAL_INT),                      # a position: global, altitude above home
    (MAV_CMD_DO_CHANGE_SPEED, FRAME_MISSION),                      # PX4 takes DO_* only in MAV_FRAME_MISSION
    (mavlink2.MAV_CMD_NAV_RETURN_TO_LAUNCH, FRAME_MISSION),        # no position
])
def test_mission_item_default_frame(command, frame):
    assert MissionItem(command).frame == frame
    assert MissionItem(command, frame=mavlink2.MAV_FRAME_GLOBAL).frame == mavlink2.MAV_FRAME_GLOBAL  # explicit wins


def test_mission_item_keeps_current_through_the_wire():
    it = MissionItem(MAV_CMD_NAV_WAYPOINT, 31.485, -111.544, 0.0, current=1)
    back = MissionItem.from_msg(it.to_msg(0, 7, 1))
    assert back == it and back.current == 1


def test_plan_to_mission_uses_frames_px4_and_ardupilot_accept():
    frame = LocalFrame(31.485, -111.544)
    plans = plan_stations([0, 0], [2.0, 0.0], {"a": np.array([-12.0, 0.0])}, 1000.0, radius_m=12.0)
    items = plan_to_mission(plans["a"], frame)
    assert {(it.command, it.frame) for it in items} == {(MAV_CMD_DO_CHANGE_SPEED, FRAME_MISSION),
                                                       (MAV_CMD_NAV_WAYPOINT, FRAME_GLOBAL_INT)}
    speed = [it for it in items if it.command == MAV_CMD_DO_CHANGE_SPEED]
    assert all(it.param1 == 1.0 and it.param3 == -1.0 and math.isfinite(it.param2) for it in speed)
    # the plan read back is the same whatever the items' frames and current flags
    plan = mission_to_plan("a", items, frame, [-12.0, 0.0], 1000.0, 4.0)
    flagged = [MissionItem(it.command, it.lat_deg, it.lon_deg, it.alt_m, it.param1, it.param2, it.param3,
                           it.param4, FRAME_GLOBAL_INT, it.autocontinue, int(k == 0)) for k, it in enumerate(items)]
    assert mission_to_plan("a", flagged, frame, [-12.0, 0.0], 1000.0, 4.0) == plan
