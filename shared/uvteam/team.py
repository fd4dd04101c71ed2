"""A team's vehicle configs for a scenario, as an operator would write them: the shipped defaults
(:mod:`uvteam.config`) plus only what is particular to this team -- ids, roof colors, the UGV list, the
UAV camera's ground footprint, the station ring and speeds the scenario sets. Pure.

The demo writes these as TOML files and starts the services on them; the experiment hands the same
configs to the same node classes. So neither carries tuning a deployed team would not have.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .bus import BusConfig
from .camera import PinholeCamera
from .config import AutopilotConfig, LocalizerServiceConfig, UavConfig, UgvConfig, VehicleConfig
from .scenario import Scenario

__all__ = ["TeamLayout", "team_configs"]


@dataclass(frozen=True, slots=True)
class TeamLayout:
    """Who is who in a team of one UAV, its localizer and the scenario's UGVs."""

    team: str = "demo"
    uav: str = "uav1"
    localizer: str = "loc1"
    ugvs: tuple[str, ...] = ()
    autopilot_urls: dict[str, str] = field(default_factory=dict)   # vehicle -> MAVLink URL ("" for none)
    system_ids: dict[str, int] = field(default_factory=dict)

    @staticmethod
    def for_scenario(sc: Scenario, team: str = "demo") -> "TeamLayout":
        ugvs = tuple(f"ugv{i + 1}" for i in range(sc.ugvs.count))
        return TeamLayout(team, ugvs=ugvs, system_ids={"uav1": 1, **{u: 11 + i for i, u in enumerate(ugvs)}})


def team_configs(sc: Scenario, layout: TeamLayout, *, detector: str = "pixels", bus: BusConfig = BusConfig()
                 ) -> dict[str, VehicleConfig]:
    """Vehicle id -> its config: the localizer, the UAV and one per UGV."""
    cam = PinholeCamera(sc.camera.width_px, sc.camera.height_px, sc.camera.hfov_deg)
    fw, fh = cam.footprint_m(sc.uav.altitude_agl_m)

    def autopilot(v: str) -> AutopilotConfig:
        return AutopilotConfig(url=layout.autopilot_urls.get(v, "memory"), system_id=layout.system_ids.get(v, 1))

    out = {layout.localizer: VehicleConfig(
        layout.team, layout.localizer, "localizer", bus,
        localizer=LocalizerServiceConfig(uav=layout.uav, ugvs=layout.ugvs,
                                         image_coordinates=sc.landmarks.image_coordinates))}
    out[layout.uav] = VehicleConfig(
        layout.team, layout.uav, "uav", bus, autopilot(layout.uav),
        uav=UavConfig(detector=detector, camera="zenoh", hfov_deg=sc.camera.hfov_deg, label_side_m=sc.ugvs.label_side_m,
                      colors=dict(zip(sc.ugvs.colors, layout.ugvs)),
                      mount_roll_deg=sc.uav.tilt_roll_deg, mount_pitch_deg=sc.uav.tilt_pitch_deg))   # the gimbal's set tilt
    for u in layout.ugvs:
        out[u] = VehicleConfig(
            layout.team, u, "ugv", bus, autopilot(u),
            ugv=UgvConfig(uav=layout.uav, localizer=layout.localizer, team_ugvs=layout.ugvs,
                          station_radius_m=sc.ugvs.station_radius_m, max_speed_m_s=sc.ugvs.approach_speed_m_s,
                          view_half_width_m=round(fw / 2, 2), view_half_height_m=round(fh / 2, 2)))
    return out
