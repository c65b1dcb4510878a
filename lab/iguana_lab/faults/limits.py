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
Inputs at the limits: pushes and desired spring lengths drawn at random *within* what the nodes accept.

Each push trial stands the body on a terrain, pushes one region with a force drawn so that the push is accepted by
`validation.check_push` (its velocity changes up to MAX_PUSH_REGION_DELTA_V and MAX_PUSH_BODY_DELTA_V, any direction,
1 to 15 frames long) and simulates on until the body settles, leaves the terrain or falls. Each length trial sends 30
frames of desired lengths accepted by `validation.check_desired_lengths` in one of LENGTH_PATTERNS (stretched or
shrunk subsets at the per-spring limits, alternating every frame, RMS-limited noise, a whole leg) from the first frame
or from a settled body. Nothing accepted may diverge, and the body watch's outcome must agree with an independent
reading of the root trajectory (no run reported completed whose body left the terrain or fell).
"""
from __future__ import annotations

from collections import Counter
from dataclasses import asdict, dataclass
import math
from typing import Callable

import numpy as np

from iguana_ros.constants import (BODY_MASS, DESIRED_SHRINK_FACTOR, DESIRED_STRAIN_RMS, DESIRED_STRETCH_FACTOR,
                                  FALL_HOLD, FALL_TILT, FRAME_RATE, MAX_PUSH_BODY_DELTA_V, MAX_PUSH_REGION_DELTA_V,
                                  WORLD_MARGIN)
from iguana_ros.geometry import quat_rotate

RESOLUTIONS = (('coarse', 0.45), ('medium', 0.45), ('fine', 0.1))
"""Meshes drawn, with their probabilities."""

FIDELITIES = ('fast', 'balanced', 'accurate')
"""Fidelity presets drawn: all three on the coarse mesh, the first two on the others (`accurate` costs 2-3 s per
trial on medium, ~10 s on fine; its dt is half of balanced's, so it is the more stable one)."""

TERRAINS = ('flat', 'hills', 'slope')
"""Terrains drawn: flat ground, the hills scene's relief, a 15° plane in a random direction."""

PUSH_REGIONS = ('trunk_left', 'trunk_right', 'tail', 'head', 'feet', 'legs', 'all')
"""Regions a push may name."""

LENGTH_PATTERNS = ('stretch', 'shrink', 'mixed', 'alternate', 'shuffle', 'noise', 'leg')
"""How a length trial's frames strain the springs (see `length_frames`)."""

LIMIT_MARGIN = 0.999
"""Fraction of a limit the drawn inputs reach at most (so that rounding never takes them over it)."""

SETTLE_S = 0.3
"""Seconds the body stands before a push, or before a 'settled' length trial starts."""

AFTER_S = 1.5
"""Seconds simulated after a push ends (the body flies, lands and settles or is lost)."""


@dataclass(frozen=True)
class LimitTrial:
    """One trial: what is tried ('push' or 'lengths'), its seed, mesh, preset, terrain and what it sends."""

    kind: str
    index: int
    resolution: str
    fidelity: str
    terrain: str
    detail: dict


@dataclass
class TrialResult:
    """What a trial did: `diverged` (the message, '' when stable), the watch's and the trajectory's outcome."""

    trial: LimitTrial
    accepted: bool
    diverged: str
    watch_outcome: str
    trajectory_outcome: str
    simulated_s: float
    wall_s: float

    @property
    def ok(self) -> bool:
        """Return whether it was accepted, stable, and its outcome is what the trajectory shows."""
        return self.accepted and not self.diverged and self.watch_outcome == self.trajectory_outcome


def draw_trials(kind: str, n: int, seed: int) -> list[LimitTrial]:
    """Return `n` trials of `kind` ('push' or 'lengths'), each drawn from its own generator of (`seed`, index)."""
    draw = _push_detail if kind == 'push' else _length_detail
    trials = []
    for index in range(n):
        rng = np.random.default_rng([seed, index, 0 if kind == 'push' else 1])
        resolution = str(rng.choice([r for r, _ in RESOLUTIONS], p=[p for _, p in RESOLUTIONS]))
        fidelity = str(rng.choice(FIDELITIES if resolution == 'coarse' else FIDELITIES[:2]))
        trials.append(LimitTrial(kind, index, resolution, fidelity, str(rng.choice(TERRAINS)), draw(rng)))
    return trials


def _push_detail(rng: np.random.Generator) -> dict:
    """Return a push's region, direction (unit, any), whole frames, fraction of its limit (biased to it), heading."""
    direction = rng.normal(size=3)
    return {'region': str(rng.choice(PUSH_REGIONS)), 'direction': (direction / np.linalg.norm(direction)).tolist(),
            'frames': int(rng.integers(1, 16)), 'fraction': float(1.0 - rng.uniform(0.0, 0.5) ** 2),
            'slope_direction_deg': float(rng.uniform(0.0, 360.0))}


def _length_detail(rng: np.random.Generator) -> dict:
    """Return a length trial's pattern, start (the first frame or a settled body) and the seed of its frames."""
    return {'pattern': str(rng.choice(LENGTH_PATTERNS)), 'from_first_frame': bool(rng.random() < 0.5),
            'frames_seed': int(rng.integers(2 ** 31)), 'slope_direction_deg': float(rng.uniform(0.0, 360.0))}


def trial_terrain(trial: LimitTrial):
    """Return the HeightField of a trial (flat, the hills scene's, or a 15° plane)."""
    from iguana_ros.terrain.heightfield import HeightField
    if trial.terrain == 'hills':
        return HeightField.hills(0.05, 0.6, trial.index, extent=5.0)
    if trial.terrain == 'slope':
        angle = math.radians(trial.detail['slope_direction_deg'])
        return HeightField.tilted_plane(15.0, (math.cos(angle), math.sin(angle)), extent=5.0)
    return HeightField.flat(extent=5.0)


def push_spec(trial: LimitTrial, masses: dict):
    """Return the trial's PushSpec: the largest impulse both velocity limits allow, times its fraction."""
    from iguana_ros.scene import MAX_PUSH_FORCE, PushSpec
    d = trial.detail
    limit = min(masses[d['region']] * MAX_PUSH_REGION_DELTA_V, BODY_MASS * MAX_PUSH_BODY_DELTA_V)
    seconds = d['frames'] / FRAME_RATE
    magnitude = min(d['fraction'] * LIMIT_MARGIN * limit / seconds, MAX_PUSH_FORCE * LIMIT_MARGIN)
    return PushSpec(at=SETTLE_S, force=tuple(magnitude * np.asarray(d['direction'])), duration=seconds,
                    region=d['region'])


def length_frames(trial: LimitTrial, model, n_frames: int = 30) -> np.ndarray:
    """Desired lengths `(n_frames, n_springs)` m of a length trial: its pattern at LIMIT_MARGIN of every limit."""
    rng = np.random.default_rng(trial.detail['frames_seed'])
    rest = np.asarray(model.spring_rest_lengths, float)
    up, down = math.log(DESIRED_STRETCH_FACTOR) * LIMIT_MARGIN, -math.log(DESIRED_SHRINK_FACTOR) * LIMIT_MARGIN
    pattern = trial.detail['pattern']
    logs = np.zeros((n_frames, len(rest)))
    subset = rng.permutation(len(rest))
    for f in range(n_frames):
        if pattern == 'shuffle':
            subset = rng.permutation(len(rest))
        logs[f] = _pattern_logs(pattern, f, subset, up, down, rng, model)
    rms = np.sqrt(np.mean(logs ** 2, axis=1, keepdims=True))
    logs *= np.minimum(1.0, DESIRED_STRAIN_RMS * LIMIT_MARGIN / np.maximum(rms, 1e-300))
    return rest * np.exp(np.clip(logs, down, up))


def _pattern_logs(pattern: str, frame: int, subset: np.ndarray, up: float, down: float, rng, model) -> np.ndarray:
    """Log strains `(n_springs,)` of one frame of `pattern` before the RMS limit scales them."""
    n = len(subset)
    logs = np.zeros(n)
    if pattern == 'noise':
        return rng.normal(size=n)
    if pattern == 'leg':
        legs = np.asarray(model.node_tags['legs'], bool) | np.asarray(model.node_tags['feet'], bool)
        return np.where(legs[model.springs].all(axis=1), up, 0.0)
    sign = {'stretch': 1, 'shrink': -1, 'alternate': 1 - 2 * (frame % 2)}.get(pattern)
    if sign is None:                                       # mixed, shuffle: each spring of the subset either way
        values = np.where(rng.random(n) < 0.5, up, down)
    else:
        values = np.full(n, up if sign > 0 else down)
    count = max(1, int((DESIRED_STRAIN_RMS * LIMIT_MARGIN) ** 2 * n / np.mean(values ** 2)))
    logs[subset[:count]] = values[:count]
    return logs


def run_trial(trial: LimitTrial) -> TrialResult:
    """Simulate one trial (see the module docstring) and judge it."""
    import time

    from iguana_ros.errors import InputError
    from iguana_ros.physics.errors import SimulationDiverged

    start = time.perf_counter()
    stage, inputs = None, None
    try:
        stage, inputs = _trial_stage(trial)
    except InputError as exc:
        return TrialResult(trial, False, '', '', f'refused: {exc}', 0.0, time.perf_counter() - start)
    roots, quats, diverged = [], [], ''
    try:
        for lengths in inputs:
            stage.advance(lengths)
            root, quat = stage.root_pose()
            roots.append(root)
            quats.append(quat)
            if stage.lost is not None:
                break
    except SimulationDiverged as exc:
        diverged = str(exc)
    watch = 'completed' if stage.lost is None else stage.lost.cause
    seen = trajectory_outcome(np.array(roots).reshape(-1, 3), np.array(quats).reshape(-1, 4), stage.terrain)
    return TrialResult(trial, True, diverged, watch, seen, stage.time, time.perf_counter() - start)


def _trial_stage(trial: LimitTrial) -> tuple:
    """Return (SimulatorStage, desired lengths of each frame: arrays or None for rest); InputError if refused."""
    from iguana_ros.body.model import build_model
    from iguana_ros.physics.pushes import region_masses
    from iguana_ros.stages import SimulatorStage
    from iguana_ros.validation import check_desired_lengths

    model = build_model(trial.resolution)
    terrain = trial_terrain(trial)
    settle = int(round(SETTLE_S * FRAME_RATE))
    if trial.kind == 'push':
        push = push_spec(trial, region_masses(model.node_mass, model.node_tags))
        frames = settle + trial.detail['frames'] + int(round(AFTER_S * FRAME_RATE))
        return SimulatorStage(model, terrain, trial.fidelity, (push,)), [None] * frames
    lengths = [check_desired_lengths(row, model.spring_rest_lengths) for row in length_frames(trial, model)]
    before = [] if trial.detail['from_first_frame'] else [None] * settle
    return SimulatorStage(model, terrain, trial.fidelity), before + lengths + [None] * (settle + 15)


def trajectory_outcome(roots: np.ndarray, quats: np.ndarray, terrain) -> str:
    """
    Return what the root trajectory `(F, 3)`, `(F, 4)` shows, read apart from the body watch.

    'left_terrain' (off the extent or WORLD_MARGIN above the ground) or 'fell' (tilted beyond FALL_TILT over
    FALL_HOLD s), whichever comes first, else 'completed'.
    """
    x_min, x_max, y_min, y_max = terrain.extent
    off = ((roots[:, 0] < x_min) | (roots[:, 0] > x_max) | (roots[:, 1] < y_min) | (roots[:, 1] > y_max)
           | (roots[:, 2] > np.max(terrain.heights) + WORLD_MARGIN))
    up = quat_rotate(quats, np.broadcast_to([0.0, 0.0, 1.0], (len(quats), 3)))[:, 2] if len(quats) else np.zeros(0)
    tilted = up < math.cos(FALL_TILT)
    hold = int(round(FALL_HOLD * FRAME_RATE))
    run = np.zeros(len(tilted), int)
    for f, t in enumerate(tilted):
        run[f] = run[f - 1] + 1 if t and f > 0 else int(t)
    fallen = run > hold
    first_off = int(np.argmax(off)) if off.any() else len(off)
    first_fall = int(np.argmax(fallen)) if fallen.any() else len(fallen)
    if first_off == first_fall == len(off):
        return 'completed'
    return 'left_terrain' if first_off <= first_fall else 'fell'


def limits_suite(pushes: int, lengths: int, seed: int, workers: int = 2,
                 on_result: Callable[[TrialResult], None] | None = None) -> dict:
    """Run `pushes` push trials and `lengths` length trials on `workers` processes; the figures (see `summary`)."""
    from concurrent.futures import ProcessPoolExecutor

    trials = draw_trials('push', pushes, seed) + draw_trials('lengths', lengths, seed)
    results = []
    with ProcessPoolExecutor(max_workers=max(1, workers)) as pool:
        for result in pool.map(run_trial, trials, chunksize=4):
            results.append(result)
            if on_result is not None:
                on_result(result)
    return summary(results)


def summary(results: list[TrialResult]) -> dict:
    """Figures per kind: trials, accepted, diverged, outcomes, disagreements (watch vs trajectory), the failures."""
    out = {}
    for kind in ('push', 'lengths'):
        rows = [r for r in results if r.trial.kind == kind]
        out[kind] = {'trials': len(rows), 'accepted': sum(r.accepted for r in rows),
                     'diverged': sum(bool(r.diverged) for r in rows),
                     'outcomes': dict(Counter(r.watch_outcome for r in rows if r.accepted)),
                     'disagreements': sum(r.accepted and r.watch_outcome != r.trajectory_outcome for r in rows),
                     'simulated_s': round(sum(r.simulated_s for r in rows), 1),
                     'failures': [{**asdict(r.trial), 'diverged': r.diverged, 'watch': r.watch_outcome,
                                   'trajectory': r.trajectory_outcome} for r in rows if not r.ok]}
    out['ok'] = all(not v['failures'] for v in out.values() if isinstance(v, dict))
    return out


def trial_line(result: TrialResult) -> str:
    """One line per trial: kind, index, mesh, preset, terrain, what was sent, the outcome."""
    t = result.trial
    what = (f"{t.detail['region']} {t.detail['frames']} frames" if t.kind == 'push'
            else f"{t.detail['pattern']}{' from frame 0' if t.detail['from_first_frame'] else ''}")
    verdict = ('REFUSED ' + result.trajectory_outcome if not result.accepted else
               'DIVERGED ' + result.diverged if result.diverged else result.watch_outcome
               + ('' if result.watch_outcome == result.trajectory_outcome else
                  f' (trajectory says {result.trajectory_outcome})'))
    return f'{t.kind} {t.index:4d} {t.resolution:6s} {t.fidelity:8s} {t.terrain:5s} {what:24s} {verdict}'
