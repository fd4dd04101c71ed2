"""The localizer service shell: the zenoh bus around :class:`uvteam.nodes.localizer.LocalizerNode`."""

from __future__ import annotations

from uvteam.config import VehicleConfig
from uvteam.nodes.localizer import LocalizerNode
from uvteam.service import StopFlag, run_node


def run(cfg: VehicleConfig, stop: StopFlag) -> int:
    return run_node(cfg, stop, lambda bus: LocalizerNode(cfg, bus))
