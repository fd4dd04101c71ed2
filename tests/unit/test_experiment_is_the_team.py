"""`uvteam experiment` runs the deployed services' own classes: the same scenario seed through the
experiment and through the node classes wired by hand, as each service shell wires them, gives the
same crowds to the last bit."""

from dataclasses import replace

import pytest

from uvteam import keys
from uvteam.autopilot import MemoryAutopilot
from uvteam.bus import InMemoryBus
from uvteam.io.files import load_scenario
from uvteam.messages import Crowds, encode
from uvteam.nodes.localizer import LocalizerNode
from uvteam.nodes.uav import UavNode
from uvteam.nodes.ugv import UgvNode
from uvteam.team import TeamLayout, team_configs
from uvteam_ground.demo import DEFAULT_SCENARIO
from uvteam_sim.experiment import T0, SimClock, SimTeam
from uvteam_sim.simulation import Simulation


def by_hand(sc, seed, duration_s):
    """The team as its shells build it (one bus each, liveliness, start), driven tick by tick."""
    lay = TeamLayout.for_scenario(sc, "exp")
    cfgs = team_configs(sc, lay, detector="sim-sensor")
    sim, clock, hub = Simulation(sc, seed, T0), SimClock(T0), InMemoryBus()

    def bus(v):
        b = InMemoryBus(hub)
        b.declare_alive(keys.alive(lay.team, v))
        return b

    loc = LocalizerNode(cfgs[lay.localizer], bus(lay.localizer), clock)
    uav_ap = MemoryAutopilot()
    uav = UavNode(cfgs[lay.uav], bus(lay.uav), uav_ap, clock)
    aps = [MemoryAutopilot(on_mission=lambda items, i=i: sim.set_mission(i, items)) for i in range(len(lay.ugvs))]
    ugvs = [UgvNode(cfgs[u], bus(u), aps[i], clock) for i, u in enumerate(lay.ugvs)]
    for n in (loc, uav, *ugvs):
        n.start()
    got, out = [], InMemoryBus(hub)
    out.subscribe(keys.key(lay.team, lay.localizer, "crowds"), Crowds, lambda k, m: got.append(m))
    for tick in sim.ticks(duration_s):
        clock.t_s = T0 + tick.t_s
        assert not tick.lost
        for f in tick.fixes:
            aps[f.ugv_index].set_state(f.state)
        if tick.frame_seq is not None:
            pose = sim.world.camera_pose()
            uav_ap.set_state(sim.uav_state(pose, tick.t_s))
        for n in (*ugvs, uav):
            n.publish_fix()
        for n in ugvs:
            n.tick(clock.t_s)
            n.exchange_mission()
        if tick.frame_seq is not None:
            out.publish(keys.key(lay.team, lay.uav, "sensor"), sim.sensor_detections(pose, tick.t_s, tick.frame_seq, lay.uav))
            loc.step(0.0)
    return got


@pytest.mark.parametrize("seed", [1, 4])
def test_the_experiment_gives_the_crowds_the_service_classes_give(seed):
    sc = load_scenario(DEFAULT_SCENARIO)
    sc = replace(sc, run=replace(sc.run, duration_s=6.0))
    team = SimTeam(sc, seed, "sensor")
    through_experiment = []
    team.sim_bus.subscribe(keys.key("exp", "loc1", "crowds"), Crowds, lambda k, m: through_experiment.append(m))
    board = team.run()
    wired = by_hand(sc, seed, None)
    assert len(through_experiment) == 61 and sum(len(m.crowds) for m in through_experiment) > 40   # frames 0-6 s
    assert [encode(m) for m in through_experiment] == [encode(m) for m in wired]
    assert board.frames == 61 and board.detected_frames > 40
