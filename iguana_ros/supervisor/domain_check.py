# Copyright 2026 iguana_ros developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Whether the ROS domain is free for a run.

The check looks at other runs' processes on this machine (from /proc) and, on the DDS graph, at nodes with the run's
node names or publishers of the topics the run's nodes publish.

A second run on a busy domain would mix its messages with the other run's (lockstep stalls, two simulators on
iguana_state, an old recorder recording both, goals acknowledged by the wrong planner), so `iguana run` refuses
it. Inputs from people are fine: publishers of goal_pose and push (`iguana goal`, RViz2), and any viewer or
plotter subscribed to the outputs.

DDS discovery of a busy peer can take a few seconds (Fast DDS re-announces a participant every 3 s), so the
graph is watched in two phases: before anything is started (`GRAPH_LISTEN_S`; nothing of ours may be there),
and again while the run's own nodes come up (then more than one node of a name, or more publishers of an output
topic than the run's own, is foreign).
"""
from __future__ import annotations

from dataclasses import dataclass, field
import os
import time

from iguana_ros.errors import IguanaError
from iguana_ros.supervisor.process import ProcessInfo, run_processes
from iguana_ros.topics import default_topics, shared_topic, topic_name

GRAPH_LISTEN_S = 0.5
"""Wall seconds the first phase listens to the DDS graph when it finds nothing."""

SETTLE_S = 0.5
"""Wall seconds a phase keeps listening after a first finding, to name what else is there."""

UNKNOWN_NODE_NAME = '_NODE_NAME_UNKNOWN_'
"""What rmw reports as the node of an endpoint whose node it has not discovered yet."""

UNNAMED = 'an unnamed node'
"""How a report names the node of an endpoint whose node is not known."""

WATCH_NODE_NAME = 'iguana_domain_check'
"""ROS node name of the watch itself."""


class DomainInUse(IguanaError):
    """The run's ROS domain already carries another run or publishers of the run's topics."""


@dataclass
class DomainReport:
    """What was found on a domain: other runs' processes, nodes named like the run's, foreign publishers."""

    domain_id: str
    processes: list[ProcessInfo] = field(default_factory=list)
    nodes: list[str] = field(default_factory=list)
    publishers: dict[str, list[str]] = field(default_factory=dict)
    namespace: str = ''

    @property
    def busy(self) -> bool:
        """Return True if anything was found."""
        return bool(self.processes or self.nodes or self.publishers)

    def findings(self) -> str:
        """
        Return what is on the domain as one line.

        For example 'processes of another iguana run: 4711 (bag record); nodes planner_node'.
        """
        parts = []
        if self.processes:
            parts.append('processes of another iguana run: ' + ', '.join(p.label() for p in self.processes))
        if self.nodes:
            parts.append('nodes ' + ', '.join(self.nodes))
        if self.publishers:
            parts.append('publishers of ' + ', '.join(
                f'{topic} ({", ".join(nodes)})' for topic, nodes in sorted(self.publishers.items())))
        return '; '.join(parts)

    def line(self) -> str:
        """One line naming the domain and what is on it."""
        pids = ' '.join(str(p.pid) for p in self.processes)
        stop = f'stop them (kill {pids})' if pids else 'stop them'
        if self.namespace:
            return (f'namespace {self.namespace} of ROS_DOMAIN_ID {self.domain_id} is in use: {self.findings()}; '
                    f'{stop} or run in another --namespace')
        return (f'ROS_DOMAIN_ID {self.domain_id} is in use: {self.findings()}; {stop} or run with another '
                'ROS_DOMAIN_ID or in a --namespace')


def current_domain_id() -> str:
    """Return the ROS_DOMAIN_ID of this process's environment ('0' when unset)."""
    return os.environ.get('ROS_DOMAIN_ID', '').strip() or '0'


def output_topics(node_names: tuple[str, ...], namespace: str = '') -> dict[str, int]:
    """
    Return {absolute name: how many of `node_names` publish it} for a run's topics in `namespace`.

    Only the topics of msg_configs/topics.yaml that one of `node_names` publishes, and not those every run shares
    (/tf, /diagnostics: many publishers are their purpose).
    """
    counts = {}
    for key, spec in default_topics().items():
        ours = sum(1 for pub in spec.publishers if pub.split()[0] in node_names)
        if ours and not shared_topic(key):
            counts[topic_name(key, namespace)] = ours
    return counts


def _known_names(names) -> list[str]:
    """Sorted node names without DDS's placeholder for a node not yet named ('an unnamed node' if none is left)."""
    known = sorted({name for name in names if name and name not in (UNKNOWN_NODE_NAME, UNNAMED)})
    return known or [UNNAMED]


def other_runs(domain_id: str, namespace: str = '') -> list[ProcessInfo]:
    """Live processes of other iguana runs on this machine in ROS_DOMAIN_ID `domain_id` and namespace `namespace`."""
    return [p for p in run_processes() if p.domain_id == domain_id and p.namespace == namespace]


class DomainWatch:
    """
    A DDS participant on this process's domain.

    It looks for nodes named `node_names` in `namespace` and publishers of the topics those nodes publish there
    (`iguana doctor` also lists every other node); `close()` leaves the graph.
    """

    def __init__(self, node_names: tuple[str, ...], watch_name: str = WATCH_NODE_NAME, namespace: str = '') -> None:
        """
        Join the graph as node `watch_name` (rclpy context of its own, no signal handlers).

        `CheckFailed` (the doctor's line) first if the ROS environment is broken: a domain id beyond what DDS maps to
        ports would end the process when the node is created.
        """
        import rclpy
        from rclpy.signals import SignalHandlerOptions

        from iguana_ros.doctor.checks import environment_checks, require

        require(environment_checks())

        self.node_names, self.namespace = tuple(node_names), namespace
        self.topics = output_topics(self.node_names, namespace)
        self.context = rclpy.Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node(watch_name, context=self.context)

    def other_nodes(self, own: tuple[str, ...] = ()) -> list[str]:
        """Full names ('/ns/name') of every node on the graph but this watch and the nodes named `own`."""
        skip = {self.node.get_name(), *own}
        return sorted({f'{ns.rstrip("/")}/{name}' for name, ns in self.node.get_node_names_and_namespaces()
                       if name not in skip})

    def foreign(self, ours_running: bool) -> tuple[list[str], dict[str, list[str]]]:
        """
        (node names, {topic: publishing nodes}) that are not the run's own.

        With `ours_running` one node of each name and the table's publishers of each topic are allowed, else none.
        """
        names = [name for name, ns in self.node.get_node_names_and_namespaces()
                 if name in self.node_names and ns.rstrip('/') == self.namespace]
        nodes = sorted({n for n in names if names.count(n) > (1 if ours_running else 0)})
        publishers = {}
        for topic, count in self.topics.items():
            infos = self.node.get_publishers_info_by_topic(topic)
            if len(infos) > (count if ours_running else 0):
                publishers[topic] = _known_names(info.node_name for info in infos)
        return nodes, publishers

    def listen(self, seconds: float, settle_s: float = SETTLE_S) -> tuple[list[str], dict[str, list[str]]]:
        """`foreign(False)` gathered for `seconds` (`settle_s` more after the first finding)."""
        nodes: set[str] = set()
        publishers: dict[str, set[str]] = {}
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            found_nodes, found_publishers = self.foreign(False)
            nodes.update(found_nodes)
            for topic, who in found_publishers.items():
                publishers.setdefault(topic, set()).update(who)
            if nodes or publishers:
                deadline = min(deadline, time.monotonic() + settle_s)
            time.sleep(0.05)
        return sorted(nodes), {topic: _known_names(who) for topic, who in publishers.items()}

    def close(self) -> None:
        """Leave the graph."""
        from iguana_ros.ros.endpoints import release_context
        try:
            self.node.destroy_node()
        finally:
            release_context(self.context)


def check_before_start(node_names: tuple[str, ...], listen_s: float = GRAPH_LISTEN_S,
                       keep_open: bool = True, namespace: str = '') -> DomainWatch | None:
    """
    Raise DomainInUse (one line) if other runs' processes or the run's node names or topics are on this domain.

    Only what is in the run's ROS `namespace` counts: runs in other namespaces share the domain.

    Processes are found from /proc, at once; nodes named `node_names` or publishers of their topics on the DDS graph,
    within `listen_s`. Returns the watch, still on the graph for `check_while_starting` (None when `listen_s` is 0 or
    not `keep_open`).
    """
    domain = current_domain_id()
    processes = other_runs(domain, namespace)
    if processes:
        raise DomainInUse(DomainReport(domain, processes=processes, namespace=namespace).line())
    if listen_s <= 0:
        return None
    watch = DomainWatch(node_names, namespace=namespace)
    try:
        nodes, publishers = watch.listen(listen_s)
    except BaseException:
        watch.close()
        raise
    if nodes or publishers or not keep_open:
        watch.close()
    if nodes or publishers:
        raise DomainInUse(DomainReport(domain, nodes=nodes, publishers=publishers, namespace=namespace).line())
    return watch if keep_open else None


def check_while_starting(watch: DomainWatch) -> None:
    """
    Raise DomainInUse if a peer discovered late shows on the graph.

    That is, if the graph now holds a second node of one of the run's names or more publishers of an output topic than
    the run's own nodes.
    """
    nodes, publishers = watch.foreign(True)
    if nodes or publishers:
        raise DomainInUse(DomainReport(current_domain_id(), nodes=nodes, publishers=publishers,
                                       namespace=watch.namespace).line())
