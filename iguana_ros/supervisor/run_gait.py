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
Gait figures of a node run from the messages its bag recorded: the `gait` part of `iguana run`'s summary.

Rows as in `pipeline.run`: row f holds the body after frame f (iguana_state, foot_state, foot_positions stamped
f + 1) and the reference of frame f (reference_stance, reference_pose stamped f); a stride is one motion_clip
message. The figures are `run_metrics.tracks_gait_metrics` over the walk, as `iguana simulate --json` computes
them, but for the shape error (it needs every node's position, which the bag does not hold).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from iguana_ros.body.feet import FootProbe
from iguana_ros.constants import FRAME_RATE
from iguana_ros.errors import IguanaError
from iguana_ros.metrics import GaitMetrics, SWING_CLEARANCE
from iguana_ros.run_metrics import GAIT_NEEDS, GaitTracks, scene_goal, tracks_gait_metrics, walk_frames

GAIT_TOPICS = ('iguana_state', 'foot_state', 'foot_positions', 'reference_stance', 'reference_pose', 'motion_clip')
"""Topic-table keys the gait figures are read from."""

TRACK_TOPICS = {'foot_contact': 'foot_state', 'foot_heights': 'foot_state', 'foot_xy': 'foot_positions',
                'reference_contacts': 'reference_stance', 'reference_heights': 'reference_pose',
                'strides': 'motion_clip', 'shape_errors': None}
"""The topic each GaitTracks track comes from (None: not from a node run)."""

FIGURE_LABELS = {'stance_fraction': 'stance fraction',
                 'swing_clearance': 'mid-swing clearance', 'slip_per_foot_per_stride': 'slip per foot per stride',
                 'speed_fraction': 'speed', 'foot_height_error': 'foot height error'}
"""Summary names of the figures a node run can have."""


@dataclass
class RunGait:
    """Gait figures of a recorded run's walk (NaN where a topic is missing) and notes on what was missing."""

    metrics: GaitMetrics | None
    frames: int = 0
    strides: int = 0
    walk_end_s: float = float('nan')
    reached: bool = False
    missing_topics: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def lines(self) -> list[str]:
        """Summary lines: one per figure, then what is missing."""
        if self.metrics is None:
            return ['gait: no figures (' + '; '.join(self.notes or ['nothing recorded']) + ')']
        g = self.metrics
        walk = f'until the goal at t={self.walk_end_s:.2f} s' if self.reached else 'the whole run, goal not reached'
        out = [f'gait over the walk ({walk}: {self.frames} frames, {self.strides} strides), from the bag:']
        needs = self._needs

        stance = needs('stance_fraction') or f'stance fraction {_feet(g.stance_fraction, 1.0, "{:.2f}")}'
        clip = _needs_text(self._missing_for('reference_stance_fraction'), 'clip') or \
            f'clip {_feet(g.reference_stance_fraction, 1.0, "{:.2f}", False)}'
        out.append(f'  {stance} ({clip})')
        out.append('  ' + (needs('swing_clearance') or (
            f'mid-swing clearance {_feet(g.swing_clearance, 100.0, "{:.1f}")} cm '
            f'(≥ {SWING_CLEARANCE * 100:g} cm in {_percent(g.swings_clear_fraction)} of {g.swings} swings)')))
        out.append('  ' + (needs('slip_per_foot_per_stride') or (
            f'slip per foot per stride {_feet(g.slip_per_foot_per_stride, 100.0, "{:.1f}")} cm '
            f'(sum {np.sum(g.slip_per_foot_per_stride) * 100:.1f} cm)')))
        out.append('  ' + (needs('foot_height_error') or (
            f'foot height error (RMS vs the reference) {_feet(g.foot_height_error, 100.0, "{:.1f}")} cm')))
        out.append('  ' + (needs('speed_fraction') or f"speed: {_percent(g.speed_fraction)} of the clips'"))
        out.append("  shape error: not from a node run (it needs every node's position; "
                   '`iguana simulate --json` has it)')
        if self.missing_topics:
            out.append(f'  not in the bag: {", ".join(self.missing_topics)} (a bag recorded before these topics '
                       'existed, or a run that stopped early)')
        return out + [f'  {note}' for note in self.notes]

    def _missing_for(self, figure: str) -> list[str]:
        """Return the missing topics `figure` is computed from."""
        return sorted({TRACK_TOPICS[t] for t in GAIT_NEEDS[figure] if TRACK_TOPICS[t] in self.missing_topics})

    def _needs(self, figure: str) -> str:
        """'' if `figure` was computed, else '<label>: n/a, needs <topics>'."""
        return _needs_text(self._missing_for(figure), FIGURE_LABELS[figure])


def _needs_text(topics: list[str], label: str) -> str:
    """'<label>: n/a, needs <topics>' ('' when no topic is missing)."""
    return f'{label}: n/a, needs {", ".join(topics)}' if topics else ''


def _feet(values, scale: float, fmt: str, labelled: bool = True) -> str:
    """'fl 0.70 fr 0.69 hl 0.64 hr 0.64' (or the bare numbers); NaN as 'n/a'."""
    text = ['n/a' if not np.isfinite(v) else fmt.format(v * scale) for v in values]
    if not labelled:
        return ' '.join(text)
    return ' '.join(f'{foot} {t}' for foot, t in zip(('fl', 'fr', 'hl', 'hr'), text))


def _percent(fraction: float) -> str:
    """'93 %' (NaN as 'n/a')."""
    return f'{fraction * 100:.0f} %' if np.isfinite(fraction) else 'n/a'


def run_gait(recorded, scene, model=None, terrain=None) -> RunGait:
    """
    Return the `RunGait` of a run of `scene` from its RecordedTopics (`bag.trajectory.read_topics(bag, GAIT_TOPICS)`).

    `model` and `terrain` default to the scene's.
    """
    from iguana_ros.ros import messages as m

    notes: list[str] = []
    if recorded.truncated:
        notes.append(f'the bag ends early ({recorded.problem}); figures over the frames recovered')
    states = _frames(recorded, 'iguana_state', m.state_from_cdr, notes)
    if not states:
        return RunGait(None, notes=notes + ['iguana_state is not in the bag'])
    n = max(states)
    if n < 1:
        return RunGait(None, notes=notes + ['the bag has no iguana_state after the start'])
    after = range(1, n + 1)          # row f: the body after frame f (stamped f + 1)
    of_frame = range(0, n)           # row f: the reference of frame f (stamped f)
    root = _table(states, after, 'iguana_state', notes)
    tracks = GaitTracks(times=(np.arange(n) + 1) / FRAME_RATE, root_positions=np.stack([r[1] for r in root]),
                        root_orientations=np.stack([r[2] for r in root]))
    feet = _table(_frames(recorded, 'foot_state', m.foot_state_from_cdr, notes), after, 'foot_state', notes)
    if feet is not None:
        tracks.foot_heights = np.stack([r[1] for r in feet])
        tracks.foot_contact = np.stack([r[2] for r in feet])
    soles = _table(_frames(recorded, 'foot_positions', m.foot_positions_from_cdr, notes), after, 'foot_positions',
                   notes)
    if soles is not None:
        tracks.foot_xy = np.stack([r[1] for r in soles])[..., :2]
    stance = _table(_frames(recorded, 'reference_stance', m.reference_stance_from_cdr, notes), of_frame,
                    'reference_stance', notes)
    if stance is not None:
        tracks.reference_contacts = np.stack([r[1] for r in stance])
    if model is None:
        from iguana_ros.body.model import build_model
        model = build_model(scene.model.resolution, scene.model.stiffness)
    poses = _table(_frames(recorded, 'reference_pose', lambda data: m.reference_pose_from_cdr(
        data, model.skeleton.n_bones), notes), of_frame, 'reference_pose', notes)
    if terrain is None:
        from iguana_ros.scene import terrain_from_spec
        terrain = terrain_from_spec(scene.terrain)
    if poses is not None:
        tracks.reference_heights = FootProbe(model, terrain).reference_heights(
            np.stack([r[1] for r in poses]), np.stack([r[2] for r in poses]))
    clips = _frames(recorded, 'motion_clip', m.stride_from_cdr, notes)
    if clips:
        tracks.strides = [clips[start][1] for start in sorted(clips) if start < n]
    until, reached = walk_frames(tracks.times, tracks.root_positions, scene_goal(scene), scene.goal_radius)
    missing = sorted({TRACK_TOPICS[t] for t in tracks.missing()})
    return RunGait(tracks_gait_metrics(tracks, until), frames=until,
                   strides=sum(1 for s in tracks.strides or [] if s.start < until), walk_end_s=until / FRAME_RATE,
                   reached=reached, missing_topics=missing, notes=notes)


def _frames(recorded, key: str, decode, notes: list[str]) -> dict[int, tuple]:
    """
    Return {frame: decoded message} of topic `key`'s serialized messages (a re-sent frame counts once, its last one).

    `decode` is the nodes' `*_from_cdr` of the topic; messages that do not decode are counted in a note.
    """
    out, bad = {}, 0
    for data in recorded.messages.get(key, []):
        try:
            row = decode(data)
        except IguanaError:
            bad += 1
            continue
        out[row[0]] = row
    if bad:
        notes.append(f'{key}: {bad} message(s) unreadable, skipped')
    return out


def _table(rows: dict[int, tuple], frames: range, key: str, notes: list[str]) -> list | None:
    """
    Return the rows of `frames` in order (None if the topic has none of them).

    A missing frame takes the nearest earlier frame's row (the first one's if none), with a note.
    """
    if not any(f in rows for f in frames):
        return None
    out, last, missing = [], None, 0
    first = next(rows[f] for f in frames if f in rows)
    for f in frames:
        if f in rows:
            last = rows[f]
        else:
            missing += 1
        out.append(last if last is not None else first)
    if missing:
        notes.append(f'{key}: {missing} of {len(frames)} frames missing (filled from the frame before)')
    return out
