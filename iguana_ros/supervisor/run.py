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
`iguana run`: the four nodes as separate processes (or one), the scene's goals, a bag of every topic.

Supervision: the children share one process group and get SIGTERM when `iguana run` dies, however it dies
(process.py); SIGINT, SIGTERM and SIGHUP stop the run in order (nodes, then the recorder, which finalises the
bag) and the summary says so; a run refuses a ROS domain that another run (or its leftovers) is on
(domain_check.py); what the run reports is read from its bag and the supervisor's clock (run_summary.py).
"""
from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
import dataclasses
from dataclasses import dataclass, field
from datetime import datetime
import math
import os
from pathlib import Path
import signal
import sys
import threading
import time
import uuid

import numpy as np
import yaml

from iguana_ros.bag.storage import DISK_FULL_EXIT
from iguana_ros.config import params_file
from iguana_ros.constants import FRAME_RATE
from iguana_ros.errors import IguanaError, InputError
from iguana_ros.executables import NODE_EXECUTABLES, NODE_PACKAGE
from iguana_ros.physics.body_watch import BODY_LOST_EXIT_CODES
from iguana_ros.scene import check_one_character, load_scene, Scene, scene_path
from iguana_ros.supervisor.cpu import CpuWindow
from iguana_ros.supervisor.domain_check import GRAPH_LISTEN_S
from iguana_ros.supervisor.process import (describe_exit, NAMESPACE_ENV, NodeProcess, RUN_ID_ENV, run_processes,
                                           stop_all)
from iguana_ros.supervisor.run_gait import RunGait
from iguana_ros.supervisor.run_summary import (bag_progress, body_contact_figures, CharacterSummary, RunSummary,
                                               STATE_KEY)
from iguana_ros.topics import check_namespace, RUN_CLOCK, topic_name

__all__ = ['NODE_KINDS', 'RunOptions', 'RunSummary', 'RunInterrupted', 'SceneRun', 'run_scene', 'goal_outcome',
           'goal_outcome_of', 'node_commands', 'node_params', 'ros_args', 'stop_signals']

NODE_KINDS = NODE_EXECUTABLES
"""The four nodes of the design card, in start order (iguana_ros/executables.py)."""

POLL_S = 0.1
"""Wall seconds between checks on the children."""

CPU_SAMPLE_S = 0.05
"""Wall seconds between samples of the processes' CPU time (`cpu.CpuWindow`; the summary's CPU per frame)."""

NODE_STOP_S = 5.0
"""Wall seconds the nodes get for each step of SIGINT, SIGTERM, SIGKILL when the run stops."""

RECORDER_STOP_S = 20.0
"""Wall seconds the recorder gets for each step (it finalises the bag on SIGINT)."""

VIEWER_START_S = 60.0
"""Wall seconds the viewer of `iguana run --view` gets to print its address."""
"""Wall seconds the recorder gets for each step (it finalises the bag on SIGINT)."""

DOMAIN_WATCH_S = 5.0
"""Wall seconds after the domain check during which the graph is still watched for a foreign node discovered
late (at least until the scene's goals are sent)."""

WATCH_PERIOD_S = 0.25
"""Wall seconds between two looks at the graph while the run starts."""

STARTUP_SILENCE_S = 20.0
"""Wall seconds after the node processes were started without a message from any of them after which the run
asks the doctor's DDS loopback whether processes here can reach each other at all."""

SILENCE_LOOPBACK_S = 15.0
"""Wall seconds that loopback may take."""

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
"""Signals that stop a run in order, with a summary (unless the parent made `iguana run` ignore them)."""


@dataclass
class RunOptions:
    """
    What `iguana run` does.

    Scene, mode, bag directory, process layout, wall-clock limit, how long to listen for another run on the ROS domain
    before starting (0 = only look for other runs' processes).
    """

    scene: str = 'hills'
    mode: str = 'lockstep'
    record: Path | None = None
    single_process: bool = False
    timeout: float | None = None
    bags_dir: Path = Path('bags')
    extra_params: dict = field(default_factory=dict)
    domain_check_s: float = GRAPH_LISTEN_S
    view: list[str] | None = None
    """Arguments of an `iguana view` (live) started as a child of the run, e.g. ['--port', '8080']; None: none."""
    ros_args: tuple = ()
    """ROS arguments every node gets after the run's own (`iguana run ... --ros-args -r a:=b --log-level ...`)."""
    namespace: str = ''
    """ROS namespace of the run's nodes and topics ('/iguana1'; '' the root): its own clock `<ns>/clock`, TF frames
    under the prefix 'iguana1/', and a domain check that only looks in that namespace."""


class RunInterrupted(IguanaError):
    """A stop signal (SIGINT, SIGTERM, SIGHUP) arrived while the run was going on."""

    def __init__(self, signum: int) -> None:
        """Name the signal."""
        self.signum = signum
        super().__init__(f'stopped by {signal.Signals(signum).name}')


class ChildExited(IguanaError):
    """A child process exited while the run needed it; carries its name and last lines."""

    def __init__(self, name: str, code: int | None, tail: str) -> None:
        """One-line message; `tail` kept apart."""
        self.name, self.tail = name, tail
        if name == 'recorder' and code == DISK_FULL_EXIT:
            super().__init__('the recorder ran out of disk space (no space left on device); the bag keeps what was '
                             'written')
        else:
            super().__init__(f'{name} exited with {describe_exit(code)}')


@dataclass
class SignalState:
    """Stop signals received while `stop_signals` is active; `raising` is cleared once the run is stopping."""

    received: list[int] = field(default_factory=list)
    raising: bool = True


@contextmanager
def stop_signals(signals: tuple[int, ...] = STOP_SIGNALS) -> Iterator[SignalState]:
    """
    Catch the stop `signals` while inside: the first raises RunInterrupted, later ones are only noted.

    Later signals are only noted so that the orderly stop completes; a signal
    the parent made us ignore stays ignored; outside the main thread nothing is installed. The previous handlers come
    back on exit.
    """
    state = SignalState()
    if threading.current_thread() is not threading.main_thread():
        yield state
        return

    def handler(signum, _frame):
        state.received.append(signum)
        if state.raising:
            state.raising = False
            raise RunInterrupted(signum)

    previous = {}
    for sig in signals:
        if signal.getsignal(sig) is not signal.SIG_IGN:
            previous[sig] = signal.signal(sig, handler)
    try:
        yield state
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)


def ros_args(params_by_node: dict[str, dict], params_file: Path | None = None,
             run_file: Path | None = None) -> list[str]:
    """
    `--ros-args [--params-file FILE] -p node:name:=value ...`, or with `run_file` `--params-file FILE RUN_FILE`.

    Each value for its node by name, after the file (a value for every node, `-p name:=value`, loses to the file's
    section of that node). rcl matches a node-qualified `-p` only in the root namespace, so a run in a namespace gives
    its values in a params file of its own (`run_params_yaml`, written to `run_file`) after the standard one.
    """
    args = ['--ros-args'] + (['--params-file', str(params_file)] if params_file is not None else [])
    if run_file is not None:
        return args + ['--params-file', str(run_file)]
    for node, params in params_by_node.items():
        for name, value in params.items():
            text = str(value).lower() if isinstance(value, bool) else str(value)
            args += ['-p', f'{node}:{name}:={text}']
    return args


def run_params_yaml(params_by_node: dict[str, dict]) -> str:
    """Return a ROS 2 params file with the values of each node under `/**/<node>` (it matches in any namespace)."""
    return yaml.safe_dump({f'/**/{node}': {'ros__parameters': dict(params)} for node, params in params_by_node.items()},
                          sort_keys=False)


RUN_PARAMS_FILE = 'run_params.yaml'
"""The params file of a run in a namespace, in its logs folder (see `ros_args`)."""

RESERVED_REMAPS = ('__node', '__name', '__ns')
"""Remaps `iguana run` refuses: the run finds its nodes by name on the graph (a namespace: `--namespace`)."""


def check_user_ros_args(args: tuple, namespace: str = '') -> tuple:
    """
    Return the user's ROS arguments for every node, without a leading `--ros-args` or a closing `--`.

    InputError for a node-renaming remap (`-r __node:=...`, `__ns`), which would hide the nodes from the run, and in a
    `namespace` for a node-qualified `-p node:name:=value`, which rcl would ignore there.
    """
    items = list(args)
    items = items[1:] if items[:1] == ['--ros-args'] else items
    items = items[:-1] if items[-1:] == ['--'] else items
    for flag, value in zip(items, items[1:]):
        target = value.split(':=')[0].split(':')[-1]
        if flag in ('-r', '--remap') and target in RESERVED_REMAPS:
            raise InputError(f'--ros-args {flag} {value}: iguana run finds its nodes by name; renaming them is not '
                             'supported (remap topics instead; a namespace: iguana run --namespace NS)')
        if namespace and flag in ('-p', '--param') and ':' in value.split(':=')[0]:
            raise InputError(f'--ros-args {flag} {value}: rcl applies a node-qualified parameter only in the root '
                             f'namespace; in {namespace} give it as -p {value.split(":", 1)[1]} (every node)')
    return tuple(items)


def namespace_args(namespace: str) -> list[str]:
    """ROS arguments that put a node in `namespace` with the run's own clock (`<ns>/clock`); none for the root."""
    if not namespace:
        return []
    return ['-r', f'__ns:={namespace}', '-r', f'{RUN_CLOCK}:={topic_name("clock", namespace)}']


def node_params(options: RunOptions, scene: Scene, scene_file: Path) -> dict[str, dict]:
    """Return this run's parameter values of every node, by node name (over the standard params file)."""
    common = {'scene': str(scene_file)}       # (frame_prefix 'auto': each node takes its namespace's)
    goals = {'wait_for_goals': len(scene.goals) + bool(scene.route)}  # both wait for the scene's goals / route
    sim = {**common, **goals, 'mode': options.mode, 'wait_for_recorder': True, **options.extra_params}
    special = {'planner_node': {**common, **goals}, 'simulator_node': sim}
    return {kind: special.get(kind, common) for kind in NODE_KINDS}


def node_commands(options: RunOptions, scene: Scene, scene_file: Path,
                  run_file: Path | None = None) -> dict[str, list[str]]:
    """
    Command line of every child node process, by name.

    A run in a namespace gives its values in `run_file` (the caller writes `run_params_yaml` there; see `ros_args`).

    The standard params file (as the launch file gives it: use_sim_time and the declared defaults), this run's
    values, then the user's ROS arguments (`RunOptions.ros_args`, checked by `check_user_ros_args`).
    """
    params, standard = node_params(options, scene, scene_file), params_file()
    user = namespace_args(options.namespace) + list(options.ros_args)
    if options.single_process:
        return {'nodes': [sys.executable, '-m', 'iguana_ros.nodes.all_nodes', *ros_args(params, standard, run_file),
                          *user]}
    return {kind: [sys.executable, '-m', f'{NODE_PACKAGE}.{kind}', *ros_args({kind: params[kind]}, standard, run_file),
                   *user]
            for kind in NODE_KINDS}


CHARACTER_NODES = tuple(kind for kind in NODE_KINDS if kind != 'simulator_node')
"""The nodes of each character of a world, in one process per character under the character's namespace."""


def world_params_yaml(options: RunOptions, scene: Scene, scene_file: Path) -> str:
    """
    Return the params file of a world's run: the simulator's values, and each character's planner's.

    Every node reads the whole scene; the character nodes find theirs by namespace (`character: auto`); each planner
    waits for its own character's goals, the simulator for all of them.
    """
    params = node_params(options, scene, scene_file)
    params['simulator_node']['wait_for_goals'] = sum(len(c.goals) + bool(c.route) for c in scene.characters)
    sections = {f'/**/{kind}': params[kind] for kind in NODE_KINDS if kind != 'planner_node'}
    for c in scene.characters:
        sections[f'/{c.name}/planner_node'] = {**params['planner_node'], 'wait_for_goals': len(c.goals) + bool(c.route)}
    return yaml.safe_dump({name: {'ros__parameters': dict(values)} for name, values in sections.items()},
                          sort_keys=False)


def world_commands(options: RunOptions, scene: Scene, run_file: Path) -> dict[str, list[str]]:
    """
    Command lines of a world's run: the simulator of every body (root namespace), a process per character.

    Each character's planner, terrain adaptation and spring-length nodes run in one process under `/<name>`; all read
    the standard params file, then the run's (`world_params_yaml`, written to `run_file`), then the user's arguments.
    """
    args = ros_args({}, params_file(), run_file)
    user = list(options.ros_args)
    commands = {'simulator_node': [sys.executable, '-m', f'{NODE_PACKAGE}.simulator_node', *args, *user]}
    for c in scene.characters:
        commands[c.name] = [sys.executable, '-m', f'{NODE_PACKAGE}.all_nodes', *CHARACTER_NODES, *args,
                            '-r', f'__ns:=/{c.name}', *user]
    return commands


def world_topic_names(scene: Scene) -> list[str]:
    """Return the topics a world's recorder records: the world's (clock, /tf, scene markers) and every character's."""
    from iguana_ros.bag.record import default_topic_names
    names = default_topic_names('')
    for c in scene.characters:
        names += [name for name in default_topic_names(f'/{c.name}') if name not in names
                  and name != topic_name('clock', f'/{c.name}')]
    return names


def new_bag_dir(options: RunOptions, scene: Scene) -> Path:
    """Return the bag directory of this run (`bags/<scene>_<date>_<time>` unless --record names one)."""
    if options.record is not None:
        return Path(options.record)
    stamp = datetime.now().strftime('%Y%m%d_%H%M%S')
    return options.bags_dir / f'{scene.name}_{stamp}'


class SceneRun:
    """Starts and supervises the recorder and node processes of one run."""

    def __init__(self, options: RunOptions, display=None) -> None:
        """
        Validate the scene and choose bag and log folders (nothing is started yet).

        `display` (a progress.ProgressDisplay, optional) shows the start-up phases and the run's progress.
        """
        namespace = check_namespace(options.namespace)
        self.options = dataclasses.replace(options, ros_args=check_user_ros_args(options.ros_args, namespace),
                                           namespace=namespace)
        self.display = display
        self.monitor = None
        self.nodes_started = math.nan
        self.silence_checked = False
        from iguana_ros.stages import check_pushes_of     # the model: only for a scene with pushes
        self.scene = load_scene(options.scene)
        self.world = bool(self.scene.characters)
        """Whether the scene is a world of several characters (one simulator, a process per character)."""
        if self.world and (namespace or options.single_process):
            check_one_character(self.scene, 'iguana run --namespace' if namespace else 'iguana run --single-process')
        check_pushes_of(self.scene)           # the pushes against the body's masses: one line before any node starts
        self.scene_file = scene_path(options.scene).resolve()
        self.bag = new_bag_dir(options, self.scene)
        if self.bag.exists():
            raise IguanaError(f'bag directory {self.bag} already exists; choose another with --record')
        self.logs = self.bag.with_name(self.bag.name + '_logs')
        self.children: dict[str, NodeProcess] = {}
        self.run_id = f'{os.getpid()}-{uuid.uuid4().hex[:12]}'
        self.group: int | None = None
        self.started = time.monotonic()
        self.sim_code: int | None = None
        self.failure: IguanaError | None = None
        self.stopped_by: int | None = None
        self.leftovers: list = []
        self.watch = None
        self.watch_until = self._next_watch = 0.0
        self.cpu = CpuWindow()
        self._cpu_sampled = 0.0

    @property
    def planned_s(self) -> float:
        """Return simulated seconds the run is to last (the --duration override or the scene's)."""
        return float(self.options.extra_params.get('duration') or self.scene.duration)

    def check_domain(self) -> None:
        """
        `DomainInUse` (one line) if another run, its leftovers or publishers of our topics are on the domain.

        The DDS watch stays open for `watch_domain` while the run starts.
        """
        from iguana_ros.ros.endpoints import RECORDER_NODE_NAME
        from iguana_ros.supervisor.domain_check import check_before_start
        self.watch = check_before_start((*NODE_KINDS, RECORDER_NODE_NAME), self.options.domain_check_s,
                                        namespace=self.options.namespace)
        self.watch_until = time.monotonic() + DOMAIN_WATCH_S

    def watch_domain(self, may_close: bool = False, force: bool = False) -> None:
        """
        Watch the domain while the run starts (at most every WATCH_PERIOD_S unless `force`).

        DomainInUse is raised if a foreign node or publisher has been discovered late. With `may_close`, leave the graph
        once DOMAIN_WATCH_S have passed.
        """
        from iguana_ros.supervisor.domain_check import check_while_starting
        if self.watch is None:
            return
        now = time.monotonic()
        if force or now >= self._next_watch:
            self._next_watch = now + WATCH_PERIOD_S
            try:
                check_while_starting(self.watch)
            except IguanaError:
                self.close_watch()
                raise
        if may_close and now > self.watch_until:
            self.close_watch()

    def close_watch(self) -> None:
        """Leave the DDS graph (the watch of check_domain)."""
        if self.watch is not None:
            self.watch.close()
            self.watch = None

    def keep_going(self) -> None:
        """
        Raise if a child exited, the domain turned out to be shared or DDS does not connect processes here.

        Then take in the run's messages. Called while the run starts.
        """
        self.alive_or_raise(simulator_may_end=True)   # a short run may be simulated before the goals are confirmed
        self.watch_domain()
        self.listen()

    def start_monitor(self) -> None:
        """Join the graph as the progress monitor (the start-up phases and the progress come from its messages)."""
        from iguana_ros.jit import kernel_cache
        from iguana_ros.supervisor.progress_monitor import RunMonitor
        names = [f'/{c.name}' for c in self.scene.characters]
        self.monitor = RunMonitor(NODE_KINDS, self.planned_s, self.display,
                                  namespace=names[0] if self.world else self.options.namespace,
                                  event_namespaces=['', *names] if self.world else None)
        self.monitor.clock.details['compiling'] = f'kernel cache {kernel_cache().state}'

    def listen(self, timeout: float = 0.0) -> None:
        """
        Take in the monitor's messages (waiting up to `timeout` s).

        If no node has been heard STARTUP_SILENCE_S after they were started, the doctor's loopback decides: IguanaError
        with its line if DDS connects no processes here.
        """
        self.sample_cpu()
        if self.monitor is None:
            time.sleep(timeout)
            return
        self.monitor.poll(timeout)
        if (self.monitor.heard or self.silence_checked or math.isnan(self.nodes_started)
                or time.monotonic() - self.nodes_started < STARTUP_SILENCE_S):
            return
        self.silence_checked = True
        from iguana_ros.supervisor.loopback import check_loopback_now
        check = check_loopback_now(SILENCE_LOOPBACK_S)
        if not check.ok:
            raise IguanaError(f'no node of the run was heard within {STARTUP_SILENCE_S:g} s; {check.one_line()}')

    def _child(self, name: str, command: list[str]) -> NodeProcess:
        """Return a child of this run: in the run's process group (the first one leads it), marked with the run id."""
        marks = {RUN_ID_ENV: self.run_id, NAMESPACE_ENV: self.options.namespace}
        child = NodeProcess(command, name, self.logs, env=marks,
                            group=0 if self.group is None else self.group)
        self.children[name] = child
        return child

    def start(self) -> None:
        """Start the recorder first (so it sees every topic), then the nodes."""
        recorder = [sys.executable, '-m', 'iguana_ros.cli', 'bag', 'record', '--use-sim-time', '-o', str(self.bag),
                    *(['--namespace', self.options.namespace] if self.options.namespace else []),
                    *(world_topic_names(self.scene) if self.world else [])]
        recorder += ['--ros-args', *self.options.ros_args] if self.options.ros_args else []   # remaps recorded as is
        if self.monitor is not None:
            self.monitor.launched()
        child = self._child('recorder', recorder)
        child.start()
        self.group = child.pid
        if not child.wait_for_output('recording to', 30.0):
            self.alive_or_raise()
            raise IguanaError(f'the recorder did not start within 30 s; logs in {self.logs}')
        if self.options.view is not None:
            self.start_viewer()
        self.nodes_started = time.monotonic()
        run_file = None
        if self.options.namespace or self.world:
            run_file = self.logs / RUN_PARAMS_FILE
            run_file.write_text(world_params_yaml(self.options, self.scene, self.scene_file) if self.world
                                else run_params_yaml(node_params(self.options, self.scene, self.scene_file)))
        commands = world_commands(self.options, self.scene, run_file) if self.world else \
            node_commands(self.options, self.scene, self.scene_file, run_file)
        for name, command in commands.items():
            self.keep_going()
            self._child(name, command).start()

    def start_viewer(self) -> None:
        """`iguana view` (live) as a child of the run, like the nodes; prints the page's address once it serves."""
        from iguana_ros.executables import VIEW_URL_PREFIX as URL_PREFIX
        namespace = ['--namespace', self.options.namespace] if self.options.namespace else []
        child = self._child('viewer', [sys.executable, '-m', 'iguana_ros.cli', 'view', *namespace, *self.options.view])
        child.start()
        if not child.wait_for_output(URL_PREFIX, VIEWER_START_S):
            self.alive_or_raise()
            raise IguanaError(f'the viewer did not start within {VIEWER_START_S:g} s; logs in {self.logs}')
        lines = child.output.splitlines()
        url = next(k for k, line in enumerate(lines) if line.startswith(URL_PREFIX))
        for line in lines[:url + 1]:   # the address, and before it who can steer a page served beyond this machine
            if line.startswith((URL_PREFIX, 'iguana view: warning: ', 'iguana view: note: ')):
                print(line, flush=True)

    def goal_readers(self, key: str) -> frozenset:
        """Return the node names whose subscriptions to topic `key` must be listed before a scene goal goes out."""
        from iguana_ros.ros.endpoints import RECORDER_NODE_NAME
        from iguana_ros.topics import topic
        recorder = {RECORDER_NODE_NAME} if 'recorder' in self.children else set()
        return frozenset(topic(key).subscriber_nodes) | recorder

    def send_goals(self) -> None:
        """Publish each character's goals (stamped with their times) or route once its planner and simulator listen."""
        if self.world:
            for name, one in self.scene.character_scenes():
                self._send_goals_of(one, f'/{name}')
        else:
            self._send_goals_of(self.scene, self.options.namespace)
        self.watch_domain(may_close=True, force=True)

    def _send_goals_of(self, scene: Scene, namespace: str) -> None:
        """Publish the goals or route of `scene` (one character's) on the topics of `namespace`."""
        from iguana_ros.nodes.goal_sender import goal_message, route_message, send_goals
        # planner, simulator (goal marker) and recorder must all have them before frame 0: named, not counted (a
        # stranger's subscription, `ros2 topic echo goal_pose`, must not stand in for one of them)
        if scene.goals:
            goals = [goal_message(g.x, g.y, g.yaw_deg, g.at) for g in scene.goals]
            send_goals(goals, min_subscribers=3, timeout=120.0, keep_going=self.keep_going,
                       readers=self.goal_readers('goal_pose'), namespace=namespace)
        if scene.route:
            last = scene.route[-1].yaw_deg
            route = route_message([(w.x, w.y) for w in scene.route], last)
            send_goals([route], min_subscribers=3, timeout=120.0, keep_going=self.keep_going, topic_key='route',
                       readers=self.goal_readers('route'), namespace=namespace)

    def alive_or_raise(self, simulator_may_end: bool = False) -> None:
        """
        Raise `ChildExited` naming the first child that has exited early, with its last lines.

        Once the run is under way the simulator may end (`simulator_may_end`): with status 0, or with the body lost
        (BODY_LOST_EXIT_CODES).
        """
        for name, child in self.children.items():
            if child.proc is None or child.running:
                continue
            if simulator_may_end and name in ('simulator_node', 'nodes') and \
                    child.proc.returncode in (0, *BODY_LOST_EXIT_CODES.values()):
                continue
            raise ChildExited(name, child.proc.returncode, child.tail())

    def simulator(self) -> NodeProcess:
        """Return the process running the simulator node."""
        return self.children.get('simulator_node') or self.children['nodes']

    def wait(self) -> int:
        """Wait for the simulator to finish; raise if another child dies or the wall limit passes."""
        limit = self.options.timeout or (120.0 + 30.0 * self.planned_s)
        deadline = time.monotonic() + limit
        sim = self.simulator()
        while sim.running:
            self.alive_or_raise(simulator_may_end=True)
            self.watch_domain(may_close=True)
            if time.monotonic() > deadline:
                raise IguanaError(f'run exceeded the wall-clock limit of {limit:.0f} s; logs in {self.logs}')
            self.listen(POLL_S)
        self.sim_code = sim.proc.returncode
        return self.sim_code

    def sample_cpu(self) -> None:
        """Note the CPU of this process and of every child still running, every CPU_SAMPLE_S at most (`cpu.py`)."""
        now = time.time()
        if now - self._cpu_sampled < CPU_SAMPLE_S:
            return
        self._cpu_sampled = now
        pids = {name: child.pid for name, child in self.children.items() if child.running}
        self.cpu.sample({**pids, 'iguana run': os.getpid()}, now)

    def stop(self) -> None:
        """
        Stop every node (all at once), then the recorder (which finalises the bag).

        Kill anything of this run still alive after that (there should be none: it is named in the summary).
        """
        self.close_watch()
        self.close_monitor()
        stop_all([c for name, c in self.children.items() if name != 'recorder'], NODE_STOP_S)
        if 'recorder' in self.children:
            stop_all([self.children['recorder']], RECORDER_STOP_S)
        self.leftovers = run_processes(self.run_id)
        for proc in self.leftovers:
            try:
                os.kill(proc.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass

    def close_monitor(self) -> None:
        """Take in the last messages, finish the display and leave the graph (the phases stay for the summary)."""
        if self.monitor is not None and self.monitor.node is not None:
            try:
                self.monitor.poll()
            finally:
                self.monitor.close()

    def outcome(self, simulated: float) -> tuple[str, str, int]:
        """(outcome, reason, exit code) of the run, judged from what happened and how far it got."""
        if self.stopped_by is not None:
            return 'stopped', f'stopped by {signal.Signals(self.stopped_by).name}', 128 + self.stopped_by
        if self.failure is not None:
            return 'failed', str(self.failure), 1
        sim = self.children.get('simulator_node') or self.children.get('nodes')
        name = sim.name if sim is not None else 'the simulator'
        lost = body_lost_outcome(self.sim_code, self.monitor.body_lost if self.monitor is not None else '')
        if lost is not None:
            return lost
        if self.sim_code not in (None, 0):
            return 'failed', f'{name} exited with {describe_exit(self.sim_code)}', 1
        if simulated < self.planned_s - 0.5 / FRAME_RATE:
            how = f'exited with {describe_exit(self.sim_code)}' if self.sim_code is not None else 'stopped'
            return 'failed', f'{name} {how} before the end of the run', 1
        if self.leftovers:
            return 'failed', 'processes of the run were still alive after the stop: ' + ', '.join(
                p.label() for p in self.leftovers), 1
        return 'completed', '', 0

    def failed_node(self) -> tuple[str, str]:
        """(name, last lines) of the child whose failure ended the run: the one that exited, else the simulator."""
        if isinstance(self.failure, ChildExited):
            return self.failure.name, self.failure.tail
        sim = self.children.get('simulator_node') or self.children.get('nodes')
        return (sim.name, sim.tail()) if sim is not None and sim.proc is not None else ('', '')

    def summary(self, code: int | None = None) -> RunSummary:
        """
        Return the run's outcome from data.

        How far it got and the loop's wall time from the bag (last iguana_state stamp; send times of the first and
        last), the total from the supervisor's clock, goal and gait figures from the recorded messages (per character
        in a world: reached only when every character reached its goal).
        """
        if code is not None and self.sim_code is None:
            self.sim_code = code
        first = f'/{self.scene.characters[0].name}' if self.world else self.options.namespace
        progress = bag_progress(self.bag, self.options.namespace, topic_name(STATE_KEY, first))
        total = time.monotonic() - self.started
        if self.world:
            characters = {name: self.character_outcome(progress, one, f'/{name}')
                          for name, one in self.scene.character_scenes()}
            figures = list(characters.values())
            simulated = max(c.simulated_s for c in figures)
            reached = all(c.reached_goal for c in figures)
            when = max(c.time_to_goal for c in figures) if reached else math.nan      # when the last one arrived
            final = max((c.final_goal_distance for c in figures if not math.isnan(c.final_goal_distance)),
                        default=math.nan)                                           # the farthest from its goal
            gait = None
            contact = body_contact_figures(self.bag) if progress.exists else (0, 0.0)
        else:
            characters, contact = {}, (0, 0.0)
            one = self.character_outcome(progress, self.scene, self.options.namespace)
            simulated, reached, when, final, gait = (one.simulated_s, one.reached_goal, one.time_to_goal,
                                                     one.final_goal_distance, one.gait)
        outcome, reason, exit_code = self.outcome(simulated)
        node, tail = self.failed_node() if outcome == 'failed' else ('', '')
        return RunSummary(self.scene.name, self.bag, self.logs, simulated, progress.loop_wall_s, reached, when,
                          final, exit_code, tail, gait, planned_s=self.planned_s, outcome=outcome, reason=reason,
                          total_wall_s=total, bag_note=progress.note(), failed_node=node,
                          phases=self.monitor.clock.finished() if self.monitor is not None else (),
                          cpu_ms_per_frame=self.cpu.ms_per_frame(progress.state_first_ns / 1e9,
                                                                 progress.state_last_ns / 1e9,
                                                                 round(simulated * FRAME_RATE)),
                          paused_s=progress.paused_s, characters=characters, body_contact_frames=contact[0],
                          body_contact_max_depth=contact[1])

    def character_outcome(self, progress, scene: Scene, namespace: str) -> CharacterSummary:
        """
        Return how one character did, from its topics in `namespace` of the bag.

        How far it got, its goal or route end, its gait figures (what a bag lacks is named in the gait lines, never
        raised).
        """
        from iguana_ros.bag.trajectory import read_topics, root_trajectory
        from iguana_ros.supervisor.run_gait import GAIT_TOPICS, run_gait

        gait, times, positions, orientations = None, np.zeros(0), np.zeros((0, 3)), np.zeros((0, 4))
        if progress.exists:
            try:
                recorded = read_topics(self.bag, GAIT_TOPICS, namespace if self.world else None)
                times, positions, orientations = root_trajectory(recorded.messages['iguana_state'])
                try:
                    gait = run_gait(recorded, scene)
                except Exception as exc:  # noqa: BLE001 -- a summary after a long run must still print its lines
                    gait = RunGait(None, notes=[f'gait figures failed: {type(exc).__name__}: {exc}'])
            except IguanaError as exc:
                gait = RunGait(None, notes=[f'bag unreadable: {exc}'])
        else:
            gait = RunGait(None, notes=['no bag'])
        reached, when, final = goal_outcome_of(times, positions, scene, orientations)
        return CharacterSummary(float(times[-1]) if len(times) else 0.0, reached, when, final, gait)


def body_lost_outcome(sim_code: int | None, detail: str) -> tuple[str, str, int] | None:
    """
    Return (outcome, reason, exit code) of a run whose simulator ended it with the body lost, else None.

    The simulator's exit status names the cause (BODY_LOST_EXIT_CODES); `detail` is its body_lost event ('cause:
    what happened', '' when not heard).
    """
    causes = {code: cause for cause, code in BODY_LOST_EXIT_CODES.items()}
    if sim_code not in causes:
        return None
    reason = detail.split(': ', 1)[1] if ': ' in detail else f'the body was lost ({causes[sim_code]})'
    return causes[sim_code], reason, sim_code


def goal_outcome(bag: Path, scene: Scene) -> tuple[bool, float, float]:
    """(reached, time, final distance) of the last scene goal from the bag's iguana_state."""
    from iguana_ros.bag.trajectory import read_topics, root_trajectory
    return goal_outcome_of(*root_trajectory(read_topics(bag, ['iguana_state']).messages['iguana_state']), scene)


def goal_outcome_of(times: np.ndarray, positions: np.ndarray, scene: Scene,
                    orientations: np.ndarray | None = None) -> tuple[bool, float, float]:
    """
    Return (reached, time, final distance) of the scene's last goal or route end from a recorded root trajectory.

    A route's waypoints must be passed in order first. The trajectory is times `(n,)` s, positions `(n, 3)` m and
    orientations `(n, 4)` xyzw (needed for a goal's heading, which then counts within the scene's yaw tolerance, as in
    the library run's metrics).
    """
    from iguana_ros.geometry import yaw_of
    from iguana_ros.metrics import route_arrival

    goal = scene.destination
    if goal is None or len(times) == 0:
        return False, float('nan'), float('nan')
    after = times >= goal.at
    if not after.any():  # the run ended before the goal was set
        return False, float('nan'), float(np.hypot(*(positions[-1, :2] - [goal.x, goal.y])))
    heading = None if goal.yaw_deg is None or orientations is None else np.radians(goal.yaw_deg)
    yaw = None if heading is None else yaw_of(orientations[after])
    route = np.array([[w.x, w.y] for w in scene.route] if scene.route else [[goal.x, goal.y]])
    return route_arrival(times[after], positions[after, :2], route, scene.goal_radius, yaw, heading,
                         np.radians(scene.goal_yaw_tolerance_deg))


def run_scene(options: RunOptions, display=None) -> RunSummary:
    """
    Run a scene end to end and return its summary, whatever ends it.

    The scene's end, a child's crash, the wall-clock limit, or SIGINT / SIGTERM / SIGHUP (every child is stopped and the
    bag finalised first). Raises (before anything is started) for a bad scene, an existing bag directory or a busy ROS
    domain. `display` (a progress.ProgressDisplay) shows the start-up phases and the progress as they happen.
    """
    run = SceneRun(options, display)
    with stop_signals() as signals:
        try:
            run.check_domain()
            run.start_monitor()
            run.start()
            run.send_goals()
            run.wait()
        except RunInterrupted as exc:
            if not run.children:  # nothing was started: nothing to report but the signal
                raise
            run.stopped_by = exc.signum
        except IguanaError as exc:
            if not run.children:  # a busy domain: refused before anything was started
                raise
            run.failure = exc
        finally:
            signals.raising = False
            run.stop()
        return run.summary()
