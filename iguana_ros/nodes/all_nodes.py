"""All four nodes in one process with one executor (`iguana run --single-process`)."""
from __future__ import annotations

import sys

from iguana_ros.nodes.base import run_nodes
from iguana_ros.nodes.planner_node import PlannerNode
from iguana_ros.nodes.simulator_node import SimulatorNode
from iguana_ros.nodes.spring_length_node import SpringLengthNode
from iguana_ros.nodes.terrain_adaptation_node import TerrainAdaptationNode


def main(args: list[str] | None = None) -> None:
    """Spin planner, terrain adaptation, spring-length and simulator nodes together."""
    sys.exit(run_nodes([PlannerNode, TerrainAdaptationNode, SpringLengthNode, SimulatorNode],
                       args if args is not None else sys.argv))


if __name__ == '__main__':
    main()
