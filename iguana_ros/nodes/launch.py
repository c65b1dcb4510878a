"""`iguana run`: the four nodes as separate processes (or one), the scene's goals, a bag of every topic."""
from __future__ import annotations

import re
import sys
import time
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

import numpy as np

from iguana_ros.errors import IguanaError
from iguana_ros.nodes.process import NodeProcess
from iguana_ros.nodes.run_gait import RunGait
from iguana_ros.scene import Scene, load_scene, scene_path

NODE_KINDS = ('planner_node', 'terrain_adaptation_node', 'spring_length_node', 'simulator_node')
"""The four nodes of the design card, in start order."""

POLL_S = 0.1
"""Wall seconds between checks on the children."""

_FINISHED = re.compile(r'scene finished: ([0-9.]+) s simulated in ([0-9.]+) s wall')


@dataclass
class RunOptions:
    """What `iguana run` does: scene, mode, bag directory, process layout, wall-clock limit."""

    scene: str = 'hills'
    mode: str = 'lockstep'
    record: Path | None = None
    single_process: bool = False
    timeout: float | None = None
    bags_dir: Path = Path('bags')
    extra_params: dict = field(default_factory=dict)


@dataclass
class RunSummary:
    """What a finished run reports."""

    scene: str
    bag: Path
    logs: Path
    simulated_s: float
    wall_s: float
    reached_goal: bool
    time_to_goal: float
    final_goal_distance: float
    exit_code: int
    message: str = ''
    gait: RunGait | None = None

    @property
    def realtime_factor(self) -> float:
        """Simulated seconds per wall second of the simulation loop."""
        return self.simulated_s / self.wall_s if self.wall_s > 0 else 0.0

    def lines(self) -> list[str]:
        """Human-readable summary lines."""
        goal = (f'goal reached at t={self.time_to_goal:.2f} s' if self.reached_goal
                else f'goal not reached (final distance {self.final_goal_distance:.2f} m)')
        gait = self.gait.lines() if self.gait is not None else []
        return [f'scene {self.scene}: {goal}',
                f'simulated {self.simulated_s:.2f} s in {self.wall_s:.2f} s wall '
                f'(realtime factor {self.realtime_factor:.2f})',
                *gait, f'bag: {self.bag}', f'logs: {self.logs}']


def ros_args(params: dict) -> list[str]:
    """`--ros-args -p name:=value ...` for a parameter dict."""
    args = ['--ros-args']
    for name, value in params.items():
        text = str(value).lower() if isinstance(value, bool) else str(value)
        args += ['-p', f'{name}:={text}']
    return args


def node_commands(options: RunOptions, scene: Scene, scene_file: Path) -> dict[str, list[str]]:
    """Command line of every child node process, by name."""
    common = {'scene': str(scene_file), 'use_sim_time': True}
    goals = {'wait_for_goals': len(scene.goals)}  # planner and simulator both wait for the scene's goals
    sim = {**common, **goals, 'mode': options.mode, 'wait_for_recorder': True, **options.extra_params}
    params = {'planner_node': {**common, **goals}, 'simulator_node': sim}
    if options.single_process:
        return {'nodes': [sys.executable, '-m', 'iguana_ros.nodes.all_nodes', *ros_args(sim)]}
    return {kind: [sys.executable, '-m', f'iguana_ros.nodes.{kind}', *ros_args(params.get(kind, common))]
            for kind in NODE_KINDS}


def new_bag_dir(options: RunOptions, scene: Scene) -> Path:
    """The bag directory of this run (`bags/<scene>_<date>_<time>` unless --record names one)."""
    if options.record is not None:
        return Path(options.record)
    stamp = datetime.now().strftime('%Y%m%d_%H%M%S')
    return options.bags_dir / f'{scene.name}_{stamp}'


class SceneRun:
    """Starts and supervises the recorder and node processes of one run."""

    def __init__(self, options: RunOptions) -> None:
        """Validate the scene and choose bag and log folders (nothing is started yet)."""
        self.options = options
        self.scene = load_scene(options.scene)
        self.scene_file = scene_path(options.scene).resolve()
        self.bag = new_bag_dir(options, self.scene)
        if self.bag.exists():
            raise IguanaError(f'bag directory {self.bag} already exists; choose another with --record')
        self.logs = self.bag.with_name(self.bag.name + '_logs')
        self.children: dict[str, NodeProcess] = {}

    def start(self) -> None:
        """Recorder first (so it sees every topic), then the nodes."""
        recorder = [sys.executable, '-m', 'iguana_ros.cli', 'bag', 'record', '-o', str(self.bag)]
        self.children['recorder'] = NodeProcess(recorder, 'recorder', self.logs).start('recording to', 30.0)
        for name, command in node_commands(self.options, self.scene, self.scene_file).items():
            self.children[name] = NodeProcess(command, name, self.logs).start()

    def send_goals(self) -> None:
        """Publish the scene's goals (stamped with their times) once planner and simulator listen."""
        if not self.scene.goals:
            return
        from iguana_ros.nodes.goal_sender import goal_message, send_goals
        goals = [goal_message(g.x, g.y, g.yaw_deg, g.at) for g in self.scene.goals]
        # planner, simulator (goal marker) and recorder must all have them before frame 0
        send_goals(goals, min_subscribers=3, timeout=120.0, keep_going=self.alive_or_raise)

    def alive_or_raise(self) -> None:
        """IguanaError naming the first child that has exited early, with its last lines."""
        for name, child in self.children.items():
            if name != 'simulator_node' and name != 'nodes' and not child.running:
                raise IguanaError(f'{name} exited with status {child.proc.returncode}:\n{child.tail()}')

    def simulator(self) -> NodeProcess:
        """The process running the simulator node."""
        return self.children.get('simulator_node') or self.children['nodes']

    def wait(self) -> int:
        """Wait for the simulator to finish; raise if another child dies or the wall limit passes."""
        limit = self.options.timeout or (120.0 + 30.0 * self.scene.duration)
        deadline = time.monotonic() + limit
        sim = self.simulator()
        while sim.running:
            self.alive_or_raise()
            if time.monotonic() > deadline:
                raise IguanaError(f'run exceeded the wall-clock limit of {limit:.0f} s; logs in {self.logs}')
            time.sleep(POLL_S)
        return sim.proc.returncode

    def stop(self) -> None:
        """Stop every node, then the recorder (which finalises the bag)."""
        for name, child in self.children.items():
            if name != 'recorder' and child.proc is not None:
                child.stop(timeout=5.0)
        recorder = self.children.get('recorder')
        if recorder is not None and recorder.proc is not None:
            recorder.stop(timeout=20.0)

    def summary(self, code: int) -> RunSummary:
        """Read the run's outcome: wall time from the simulator log; goal and gait figures from the messages
        recorded in the bag (what a bag lacks is named in the gait lines, never raised)."""
        from iguana_ros.bag.trajectory import read_topics, root_trajectory
        from iguana_ros.nodes.run_gait import GAIT_TOPICS, run_gait

        found = _FINISHED.findall(self.simulator().output)
        simulated, wall = (float(found[-1][0]), float(found[-1][1])) if found else (0.0, 0.0)
        message = '' if code == 0 else self.simulator().tail()
        try:
            recorded = read_topics(self.bag, GAIT_TOPICS)
        except IguanaError as exc:
            return RunSummary(self.scene.name, self.bag, self.logs, simulated, wall, False, float('nan'),
                              float('nan'), code, message, RunGait(None, notes=[f'bag unreadable: {exc}']))
        times, positions, _ = root_trajectory(recorded.messages['iguana_state'])
        reached, when, final = goal_outcome_of(times, positions, self.scene)
        try:
            gait = run_gait(recorded, self.scene)
        except Exception as exc:  # noqa: BLE001 -- a summary after a long run must still print its other lines
            gait = RunGait(None, notes=[f'gait figures failed: {type(exc).__name__}: {exc}'])
        return RunSummary(self.scene.name, self.bag, self.logs, simulated, wall, reached, when, final, code,
                          message, gait)


def goal_outcome(bag: Path, scene: Scene) -> tuple[bool, float, float]:
    """(reached, time, final distance) of the last scene goal from the bag's iguana_state."""
    from iguana_ros.bag.trajectory import read_root_trajectory
    return goal_outcome_of(*read_root_trajectory(bag), scene)


def goal_outcome_of(times: np.ndarray, positions: np.ndarray, scene: Scene) -> tuple[bool, float, float]:
    """(reached, time, final distance) of the last scene goal from a recorded root trajectory: times `(n,)` s,
    positions `(n, 3)` m."""
    from iguana_ros.metrics import goal_arrival

    if not scene.goals or len(times) == 0:
        return False, float('nan'), float('nan')
    goal = scene.goals[-1]
    after = times >= goal.at
    if not after.any():  # the run ended before the goal was set
        return False, float('nan'), float(np.hypot(*(positions[-1, :2] - [goal.x, goal.y])))
    return goal_arrival(times[after], positions[after, :2], np.array([goal.x, goal.y]), scene.goal_radius)


def run_scene(options: RunOptions) -> RunSummary:
    """Run a scene end to end; stops every child on exit, Ctrl-C or a child's crash."""
    run = SceneRun(options)
    code = 1
    try:
        run.start()
        run.send_goals()
        code = run.wait()
    finally:
        run.stop()
    return run.summary(code)
