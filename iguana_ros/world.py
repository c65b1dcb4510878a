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
Several iguanas in one world: one pipeline per character, their bodies stepped together with body-body contact.

Each character (a scene's `characters` entry) has its own planner, adaptation and spring lengths (`pipeline.Pipeline`)
and its own soft body; `World.step` computes every character's reference for the frame, then advances the bodies
(`BodyWorld`: the bodies and their contact alone, as a simulator of several bodies needs them).
A body whose bounding box stays apart from every other by more than they can move in a frame is advanced as a lone
body is, in one call (bit for bit the single-character loop), whatever the others do; such groups are stepped side by
side on the process's cores (threads: the step kernels release the GIL; a fixed partition by node count). Bodies
that may touch (a group, joined transitively) are advanced together in blocks of `BodyContactParams.coupling_steps`
steps, the contact forces of `physics.body_contact` held over each block, their desired lengths ramped across the
blocks as one frame ramps them.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
import time
from typing import Callable

import numpy as np

from iguana_ros.constants import FRAME_RATE
from iguana_ros.physics.body_contact import (BodyContactParams, bounding_boxes, contact_forces, ContactBody,
                                             load_kernels as load_contact_kernels, near, PairContact,
                                             penetration_depths)
from iguana_ros.physics.side_by_side import default_workers, SideBySide
from iguana_ros.pipeline import allocate_rows, build_pipeline, Pipeline, RunResult, store_frame
from iguana_ros.scene import Scene
from iguana_ros.stages import OtherBodies, SimulatorStage

CONTACT_SLACK_M = 0.01
"""Metres added to the distance two bodies may close in a frame before they are stepped in contact blocks."""


@dataclass
class Character:
    """One iguana of the world: its name (ROS namespace), its scene alone and its pipeline."""

    name: str
    scene: Scene
    pipe: Pipeline
    avoid_others: bool = True


@dataclass
class FrameContact:
    """The body-body contact of one frame: its number and the deepest and busiest block of each touching pair."""

    frame: int
    pairs: list[PairContact] = field(default_factory=list)


class BodyWorld:
    """
    Soft bodies stepped together with body-body contact (module docstring); `contacts` lists the frames with contact.

    The part of a world a simulator needs (no planners): the library's `World` and a simulator of several bodies.
    """

    def __init__(self, stages: list[SimulatorStage], params: BodyContactParams | None = None,
                 workers: int | None = None) -> None:
        """
        Take the bodies' simulator stages; contact data of each body from its model.

        `workers` threads (default: the process's cores, `physics.side_by_side`) step the groups of bodies that cannot
        touch each other side by side; a body's result is the same whichever thread steps it.
        """
        self.stages = stages
        self.params = params or BodyContactParams()
        self.bodies = [ContactBody.of_model(stage.model) for stage in stages]
        self.contacts: list[FrameContact] = []
        self.frame = 0
        self.threads = SideBySide(min(default_workers() if workers is None else max(1, int(workers)), len(stages)))

    def advance(self, lengths: list) -> None:
        """Advance every body one frame with its desired lengths `(n_springs_i,)` (None: rest), in contact if near."""
        groups = self._groups(self.stages)
        pairs = self.threads.run([lambda group=group: self._advance_group(group, lengths) for group in groups],
                                 [sum(self.stages[i].model.n_nodes for i in group) for group in groups])
        record = FrameContact(self.frame, [p for group_pairs in pairs for p in group_pairs])
        if record.pairs:
            self.contacts.append(record)
        self.frame += 1

    def _advance_group(self, group: list[int], lengths: list) -> list[PairContact]:
        """Advance one group of bodies (a lone one as alone); return the pairs in contact (the group's record)."""
        if len(group) == 1:
            self.stages[group[0]].advance(lengths[group[0]])
            return []
        kept = FrameContact(self.frame)
        self._advance_in_contact(group, self.stages, lengths, kept)
        return kept.pairs

    def close(self) -> None:
        """Stop the helper threads and the bodies' factor threads."""
        self.threads.close()
        for stage in self.stages:
            stage.close()

    def _groups(self, stages: list[SimulatorStage]) -> list[list[int]]:
        """
        Return the bodies that may touch in this frame, grouped (transitively), each group in order.

        Two bodies may touch when their boxes come within what their fastest nodes can close in a frame (and the
        slack); a body alone in its group advances as a lone body, whatever the others do.
        """
        group = list(range(len(stages)))
        if len(stages) > 1:
            boxes = bounding_boxes([s.sim.positions for s in stages])
            speeds = [float(np.sqrt((s.sim.velocities ** 2).sum(axis=1).max())) for s in stages]
            for a in range(len(stages)):
                for b in range(a + 1, len(stages)):
                    if near(boxes, a, b, (speeds[a] + speeds[b]) / FRAME_RATE + CONTACT_SLACK_M):
                        low, high = sorted((_root(group, a), _root(group, b)))
                        group[high] = low
        members: dict[int, list[int]] = {}
        for i in range(len(stages)):
            members.setdefault(_root(group, i), []).append(i)
        return list(members.values())

    def _advance_in_contact(self, group: list[int], stages: list[SimulatorStage], lengths: list,
                            record: FrameContact) -> None:
        """
        Advance the bodies of `group` (indices) in blocks of held contact forces.

        Their desired lengths ramp across the blocks as over one frame; the block of most force of each touching
        pair goes to `record`.
        """
        sims = [stages[i].sim for i in group]
        bodies = [self.bodies[i] for i in group]
        k = self.params.coupling_steps(sims[0].fidelity.dt)
        steps = sims[0].steps_per_frame
        blocks = max(1, steps // k)
        targets = [s.desired_lengths_rest if lengths[i] is None else np.asarray(lengths[i], dtype=np.float64)
                   for s, i in zip(sims, group)]
        starts = [s.held_lengths.copy() for s in sims]
        pushes = [stages[i].frame_forces() for i in group]
        for j in range(blocks):
            n = k if j < blocks - 1 else steps - k * (blocks - 1)
            forces, pairs = contact_forces(bodies, [s.positions for s in sims], [s.velocities for s in sims],
                                           self.params, n * sims[0].fidelity.dt, CONTACT_SLACK_M)
            self._keep(record, [dataclasses.replace(p, a=group[p.a], b=group[p.b]) for p in pairs])
            share = (j + 1) / blocks
            for m, sim in enumerate(sims):
                ld = targets[m] if sim.length_hold == 'zero' or j == blocks - 1 else \
                    starts[m] + (targets[m] - starts[m]) * share
                external = forces[m] if pushes[m] is None else forces[m] + pushes[m]
                sim.advance_frame(ld, external, n)
        for i in group:
            stages[i].end_frame()

    def deepest_penetration(self) -> float:
        """Return how deep m the deepest node of any body lies inside another body's volume now (0: none)."""
        stages = self.stages
        boxes = bounding_boxes([s.sim.positions for s in stages])
        return max((float(penetration_depths(self.bodies[b], stages[a].sim.positions, stages[b].sim.positions).max())
                    for a in range(len(stages)) for b in range(len(stages))
                    if a != b and near(boxes, a, b, 0.0)), default=0.0)

    @staticmethod
    def _keep(record: FrameContact, pairs: list[PairContact]) -> None:
        """Keep, per ordered pair, the block of the frame with the most force."""
        for pair in pairs:
            kept = next((p for p in record.pairs if (p.a, p.b) == (pair.a, pair.b)), None)
            if kept is None:
                record.pairs.append(pair)
            elif pair.normal_force > kept.normal_force:
                record.pairs[record.pairs.index(kept)] = pair

    def load_kernels(self) -> None:
        """Compile or load the contact kernels (no state changes), so the first contact costs no compilation."""
        if len(self.bodies) > 1:
            load_contact_kernels(self.bodies[0], self.stages[0].sim.positions)


class World:
    """Characters stepped together (see the module docstring): their planners, then their bodies (`BodyWorld`)."""

    def __init__(self, characters: list[Character], params: BodyContactParams | None = None,
                 workers: int | None = None) -> None:
        """Take the characters' pipelines; their bodies make the world's `BodyWorld` (stepped by `workers` threads)."""
        self.characters = characters
        self.body_world = BodyWorld([c.pipe.simulator for c in characters], params, workers)
        window = characters[0].pipe.planner.planner.params.obstacle_velocity_window if characters else 0.0
        self.tracks = OtherBodies([c.name for c in characters], round(window * FRAME_RATE))
        """Every body's root by frame: the planners' moving obstacles (as a planner node hears the others)."""

    @property
    def stages(self) -> list[SimulatorStage]:
        """Return the characters' simulator stages, in order."""
        return self.body_world.stages

    @property
    def bodies(self) -> list[ContactBody]:
        """Return the characters' contact bodies, in order."""
        return self.body_world.bodies

    @property
    def contacts(self) -> list[FrameContact]:
        """Return the frames with body-body contact so far."""
        return self.body_world.contacts

    @property
    def frame(self) -> int:
        """Return the frames stepped so far."""
        return self.body_world.frame

    def step(self) -> list[tuple]:
        """One frame of every character; returns each one's (root, orientation, reference joints, rotations)."""
        self.show_others()
        frames = [c.pipe.reference() for c in self.characters]
        self.body_world.advance([reference.lengths for _, _, reference in frames])
        for c in self.characters:
            c.pipe.frame += 1
        return [(root, quat, ref.joints, ref.rotations) for root, quat, ref in frames]

    def show_others(self) -> None:
        """Give each character's planner the others' roots and velocities now, as moving obstacles."""
        if len(self.characters) < 2:
            return
        for c, stage in zip(self.characters, self.stages):
            self.tracks.add(c.name, self.frame, stage.root_pose()[0][:2], stage.root_twist()[0][:2])
        for c in self.characters:
            if c.avoid_others:
                others = [o.name for o in self.characters if o is not c]
                c.pipe.planner.obstacles = self.tracks.obstacles(self.frame, others)

    def deepest_penetration(self) -> float:
        """Return how deep m the deepest node of any body lies inside another body's volume now (0: none)."""
        return self.body_world.deepest_penetration()

    def load_kernels(self) -> None:
        """Compile or load the contact kernels (no state changes), so the first contact costs no compilation."""
        self.body_world.load_kernels()

    def close(self) -> None:
        """Stop every character's lookahead thread and the world's helper threads."""
        for c in self.characters:
            c.pipe.close()
        self.body_world.close()


def _root(parent: list[int], i: int) -> int:
    """Return the representative of `i` in the union-find forest `parent`."""
    while parent[i] != i:
        i = parent[i]
    return i


def build_world(scene: Scene, adaptation: bool | None = None, library: dict | None = None,
                simulator_options: dict | None = None, lookahead: bool = True, workers: int | None = None) -> World:
    """Return the world of `scene`: a pipeline per character (`Scene.character_scenes`), its bodies in contact."""
    avoid = {c.name: c.avoid_others for c in scene.characters}
    characters = [Character(name, one, build_pipeline(one, adaptation, library, simulator_options=simulator_options,
                                                      lookahead=lookahead), avoid.get(name, True))
                  for name, one in scene.character_scenes()]
    world = World(characters, workers=workers)
    world.load_kernels()
    return world


@dataclass
class WorldResult:
    """Trajectories of each character (`RunResult`, by name) and the frames with body-body contact."""

    characters: dict[str, RunResult]
    contacts: list[FrameContact]
    wall_seconds: float

    @property
    def outcome(self) -> str:
        """'completed', or the first lost character's cause."""
        lost = [r for r in self.characters.values() if r.lost is not None]
        return lost[0].outcome if lost else 'completed'


def run_world(scene: Scene, adaptation: bool | None = None, n_frames: int | None = None,
              progress: Callable[[int, int], None] | None = None, simulator_options: dict | None = None,
              on_frame: Callable[[World], None] | None = None, workers: int | None = None) -> WorldResult:
    """
    Run every character of `scene` for its duration (or `n_frames`) in one world; `on_frame(world)` after each frame.

    The run ends early when a character's body is lost (left the terrain or fell).
    """
    world = build_world(scene, adaptation, simulator_options=simulator_options, workers=workers)
    total = int(round(scene.duration * FRAME_RATE)) if n_frames is None else int(n_frames)
    rows = [allocate_rows(total, c.pipe.simulator.model.n_nodes, c.pipe.simulator.model.skeleton.n_bones)
            for c in world.characters]
    done = 0
    start = time.perf_counter()
    try:
        for f in range(total):
            for c, row, (_, _, joints, rotations) in zip(world.characters, rows, world.step()):
                root, quat = c.pipe.simulator.root_pose()
                store_frame(row, f, root, quat, c.pipe.simulator.sim, (joints, rotations),
                            c.pipe.planner.reference_contacts(f))
            done = f + 1
            if on_frame is not None:
                on_frame(world)
            if progress is not None:
                progress(done, total)
            if any(s.lost is not None for s in world.stages):
                break
    finally:
        world.close()
    wall = time.perf_counter() - start
    results = {}
    for c, row in zip(world.characters, rows):
        kept = {k: v[:done] for k, v in row.items()}
        results[c.name] = RunResult(times=(np.arange(done) + 1) / FRAME_RATE, clip_history=list(c.pipe.planner.history),
                                    goals=[(g.at, g.x, g.y) for g in c.scene.goals], wall_seconds=wall,
                                    events=list(c.pipe.planner.events), plan_seconds=list(c.pipe.planner.plan_seconds),
                                    lost=c.pipe.simulator.lost, **kept)
    return WorldResult(results, world.contacts, wall)
