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
Randomized locomotion benchmarks: the steering suite, and seeded terrains with and without terrain adaptation.

`steering_scenes` draws the steering suite (near and far goals in every direction, ahead/behind pairs, slopes, steps,
headings, routes; both fidelity and stiffness presets), `steering_tasks` runs each with adaptation and
`summarize_steering` reduces the rows per category: reach rate, time, path length over the straight way, headings
within tolerance, routes completed in order, strides circling or stuck, and the behind/ahead time ratio.

`random_scenes` (iguana_lab.random_scenes) draws the scenes (hills, tilted planes, steps, smooth noise; a goal 3 m from
the start in a random direction, also behind the iguana, which starts facing +x), `run_benchmark` runs every (scene,
adaptation) pair on the sweep engine (iguana_lab.sweep, Dask) and returns one plain row per run, `summarize` reduces the
rows per mode and terrain kind and compares the modes. ROS-free; `iguana bench locomotion` is the command over it, and
`iguana sweep locomotion` (lab/iguana_lab/sweeps/locomotion.yaml) the same sweep from a spec file.
"""
from __future__ import annotations

import math
import statistics
import time
from typing import Callable

import numpy as np

from iguana_lab.random_scenes import (BENCH_KINDS, GOAL_DISTANCE, GOAL_RADIUS, random_scenes,  # noqa: F401
                                      scene_category, STEERING_CATEGORIES, steering_scenes, TERRAIN_EXTENT)
from iguana_lab.sweep.engine import error_row, run_local, Task, task_key
from iguana_lab.sweep.scene_task import MODE_NAMES, run_scene, RunOptions, scene_identity
from iguana_ros.scene import Scene

STOP_AFTER_GOAL = 2.0
"""A run ends this many simulated seconds after the root first reaches the goal (s)."""
IDENTITY_KEYS = ('scene', 'kind', 'terrain', 'goal', 'resolution', 'duration', 'adaptation', 'mode', 'error',
                 'error_type')
"""Row keys that say what ran, not how it went (not summarised as metrics)."""


# --------------------------------------------------------------------------------------------- the runs

def run_task(scene: Scene, adaptation: bool) -> dict:
    """
    Run one (scene, adaptation) pair to its duration or 2 s past the goal; one plain row for JSON.

    The row holds what ran (`scene_identity`), `wall_s` (build, run and metrics), `simulated_s`, `realtime_factor`
    (simulated over the frame loop's wall time) and every field of the run's LocomotionMetrics. Any exception
    (e.g. SimulationDiverged) gives a row with `error` set instead, so one bad run never ends a benchmark.
    """
    identity = scene_identity(scene, adaptation)
    start = time.perf_counter()
    try:
        return run_scene(scene, RunOptions(adaptation=bool(adaptation), stop_after_goal=STOP_AFTER_GOAL), identity)
    except Exception as exc:                      # noqa: BLE001 - the row records the failure
        return error_row(identity, exc, time.perf_counter() - start)


def benchmark_tasks(scenes: list[Scene], modes: tuple = (True, False)) -> list[Task]:
    """Return the sweep tasks of every (scene, mode) pair: scene order, modes in the given order within a scene."""
    return [Task(task_key('locomotion', scene, bool(mode), STOP_AFTER_GOAL), run_task, (scene, bool(mode)),
                 scene_identity(scene, bool(mode)), f'{scene.name} {MODE_NAMES[bool(mode)]}')
            for scene in scenes for mode in modes]


def run_benchmark(scenes: list[Scene], modes: tuple = (True, False), workers: int | None = None,
                  progress: Callable[[dict, int, int], None] | None = None) -> list[dict]:
    """
    Rows of every (scene, mode) pair, run by the sweep engine on `workers` local processes (default: one per core).

    The rows come in scene order, modes in the given order within a scene, whatever the number of workers;
    `progress(row, n_done, n_total)` is called as each run finishes (in finishing order). A worker that dies gives
    an error row, not an exception.
    """
    return run_local(benchmark_tasks(scenes, modes), workers, progress)


# ------------------------------------------------------------------------------------------ the summary

def _median(values: list) -> float | None:
    """Median of the numbers in `values`, None when there are none."""
    return float(statistics.median(values)) if values else None


def _is_number(value) -> bool:
    """Return a finite int or float that is not a bool (the rows' scalar metrics)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _values(rows: list[dict], key: str) -> list:
    """Return the numeric values of `key` over `rows` (missing, None and non-numbers left out)."""
    return [r[key] for r in rows if _is_number(r.get(key))]


def _ratio(numerator: float | None, denominator: float | None) -> float | None:
    """`numerator` / denominator, None when either is missing or the denominator is 0."""
    if numerator is None or not denominator:
        return None
    return numerator / denominator


def _group_summary(rows: list[dict], speed_key: str) -> dict:
    """Figures of one group of rows (one mode, one or all terrain kinds); see `summarize`."""
    finished = [r for r in rows if not r.get('error')]
    reached = [r for r in finished if r.get('reached_goal') is True]
    slips = _values(finished, 'foot_slip_per_stride')
    numeric = sorted({k for r in finished for k, v in r.items() if k not in IDENTITY_KEYS and _is_number(v)})
    return {
        'n': len(rows), 'reached': len(reached), 'reach_rate': len(reached) / len(rows) if rows else None,
        'time_to_goal_median': _median(_values(reached, 'time_to_goal')),
        'foot_slip_per_stride_median': _median(slips),
        'foot_slip_per_stride_mean': float(np.mean(slips)) if slips else None,
        'speed_median': _median(_values(finished, speed_key)),
        'fell': sum(r.get('fell') is True for r in finished),
        'stuck': sum(r.get('stuck') is True and r.get('reached_goal') is not True for r in finished),
        'errors': len(rows) - len(finished),
        'medians': {k: _median(_values(finished, k)) for k in numeric},
    }


def summarize(rows: list[dict]) -> dict:
    """
    Per mode ('adapt', 'no_adapt') and per terrain kind (and 'all'): the figures, and the modes compared.

    A group's figures: `n` runs (errors included), `reached`, `reach_rate` (reached / n: a run that raised counts
    as not reached), `time_to_goal_median` (over reached runs), `foot_slip_per_stride_median` and `_mean`,
    `speed_median` of `speed_key` (`speed_fraction` when any row has it, else `mean_forward_speed`), `fell`,
    `stuck` (stuck and not reached), `errors`, and `medians`: the median of every numeric scalar key of the
    finished rows (lists and other non-scalars are left out). `ratios[kind]` (both modes present):
    `reach_rate_with_over_without`, `slip_without_over_with` (of the medians), `time_without_over_with` (of the
    median times over the `both_reached` scenes that both modes reached, so the two medians cover the same
    terrains); None on a zero or missing denominator.
    """
    speed_key = 'speed_fraction' if any('speed_fraction' in r for r in rows) else 'mean_forward_speed'
    kinds = [k for k in BENCH_KINDS if any(r.get('kind') == k for r in rows)]
    kinds += sorted({r.get('kind') for r in rows} - set(kinds) - {None})
    modes = {}
    for flag, mode in MODE_NAMES.items():
        of_mode = [r for r in rows if r.get('adaptation') is flag]
        if of_mode:
            modes[mode] = {group: _group_summary([r for r in of_mode if group == 'all' or r.get('kind') == group],
                                                 speed_key) for group in ['all'] + kinds}
    ratios = {}
    if len(modes) == 2:
        for group in ['all'] + kinds:
            w, wo = modes['adapt'][group], modes['no_adapt'][group]
            times = _paired_times([r for r in rows if group == 'all' or r.get('kind') == group])
            ratios[group] = {
                'reach_rate_with_over_without': _ratio(w['reach_rate'], wo['reach_rate']),
                'slip_without_over_with': _ratio(wo['foot_slip_per_stride_median'], w['foot_slip_per_stride_median']),
                'time_without_over_with': _ratio(_median(times[False]), _median(times[True])),
                'both_reached': len(times[True]),
            }
    return {'speed_key': speed_key, 'kinds': kinds, 'modes': modes, 'ratios': ratios}


def _paired_times(rows: list[dict]) -> dict:
    """Return {True: times to goal with adaptation, False: without}, over the scenes that both modes reached."""
    times = {flag: {r['scene']: r['time_to_goal'] for r in rows if r.get('adaptation') is flag
                    and not r.get('error') and r.get('reached_goal') is True and _is_number(r.get('time_to_goal'))}
             for flag in MODE_NAMES}
    both = sorted(set(times[True]) & set(times[False]))
    return {flag: [times[flag][name] for name in both] for flag in MODE_NAMES}


# ------------------------------------------------------------------------------------------- steering suite

STRAIGHT_FOR_PATH = 2.0
"""Scenes whose straight way is at least this long (m) give the path-ratio figure (near goals are all turning)."""


def steering_identity(scene: Scene) -> dict:
    """Return the row fields that say what a steering scene is: category, presets, straight way, heading asked."""
    goal = scene.destination
    return {**scene_identity(scene, True), 'category': scene_category(scene), 'fidelity': scene.fidelity,
            'stiffness': scene.model.stiffness, 'heading': goal is not None and goal.yaw_deg is not None,
            'route_waypoints': len(scene.route)}


def run_steering_task(scene: Scene) -> dict:
    """Run one steering scene with adaptation until 2 s past its goal; one plain row (an error row if it raised)."""
    identity = steering_identity(scene)
    start = time.perf_counter()
    try:
        return run_scene(scene, RunOptions(adaptation=True, stop_after_goal=STOP_AFTER_GOAL), identity)
    except Exception as exc:                      # noqa: BLE001 - the row records the failure
        return error_row(identity, exc, time.perf_counter() - start)


def steering_tasks(scenes: list[Scene]) -> list[Task]:
    """Return the sweep tasks of the steering scenes, in order."""
    return [Task(task_key('steering', scene, STOP_AFTER_GOAL), run_steering_task, (scene,), steering_identity(scene),
                 scene.name) for scene in scenes]


def run_steering(scenes: list[Scene], workers: int | None = None,
                 progress: Callable[[dict, int, int], None] | None = None) -> list[dict]:
    """Rows of every steering scene, in scene order, run by the sweep engine on `workers` local processes."""
    return run_local(steering_tasks(scenes), workers, progress)


def _fraction(numerator: int, denominator: int) -> float | None:
    """`numerator / denominator`, None for no denominator."""
    return numerator / denominator if denominator else None


def _steering_group(rows: list[dict]) -> dict:
    """Return the figures of one group of steering rows (see `summarize_steering`)."""
    finished = [r for r in rows if not r.get('error')]
    reached = [r for r in finished if r.get('reached_goal') is True]
    headed = [r for r in finished if r.get('heading')]
    routes = [r for r in finished if r.get('route_waypoints')]
    far = [r for r in finished
           if _is_number(r.get('straight_distance')) and r['straight_distance'] >= STRAIGHT_FOR_PATH]
    return {
        'n': len(rows), 'reached': len(reached), 'reach_rate': _fraction(len(reached), len(rows)),
        'time_to_goal_median': _median(_values(reached, 'time_to_goal')),
        'path_ratio_median': _median(_values(far, 'path_ratio')),
        'heading_goals': len(headed),
        'heading_within_tolerance': sum(r.get('reached_goal') is True for r in headed),
        'heading_error_at_arrival_median_deg': _median(_values(headed, 'heading_error_at_arrival_deg')),
        'final_heading_error_median_deg': _median(_values(headed, 'final_heading_error_deg')),
        'routes': len(routes), 'routes_completed': sum(r.get('route_completed') is True for r in routes),
        'circling_runs': sum((r.get('circling_strides') or 0) > 0 for r in finished),
        'circling_strides': sum(r.get('circling_strides') or 0 for r in finished),
        'stuck_strides': sum(r.get('stuck_strides') or 0 for r in finished),
        'fell': sum(r.get('fell') is True for r in finished), 'errors': len(rows) - len(finished),
        'realtime_factor_median': _median(_values(finished, 'realtime_factor')),
        'plan_ms_median': _median(_values(finished, 'plan_ms_median')),
        'plan_ms_max': max(_values(finished, 'plan_ms_max'), default=None),
    }


def summarize_steering(rows: list[dict]) -> dict:
    """
    Per category (and 'all', and per fidelity and stiffness preset): `_steering_group`'s figures.

    Also `behind_over_ahead`: the median, over the ahead/behind pairs both reached, of the behind scene's time to goal
    over its ahead partner's (the pair shares terrain and presets), with the pair count; `near_goals` (straight way
    <= 1.2 m), `slope_scenes` (12-20 deg) and `fast_scenes` counts.
    """
    groups = {'all': rows}
    groups.update({c: [r for r in rows if r.get('category') == c] for c in dict.fromkeys(STEERING_CATEGORIES)})
    groups.update({f'fidelity {v}': [r for r in rows if r.get('fidelity') == v] for v in ('balanced', 'fast')})
    groups.update({f'stiffness {v}': [r for r in rows if r.get('stiffness') == v] for v in ('normal', 'softer')})
    summary = {name: _steering_group(group) for name, group in groups.items() if group}
    pairs = _behind_ahead_pairs(rows)
    return {'groups': summary, 'behind_over_ahead': _median([b / a for a, b in pairs]), 'pairs': len(pairs),
            'near_goals': sum(_is_number(r.get('straight_distance')) and r['straight_distance'] <= 1.2 for r in rows),
            'slope_scenes': sum(r.get('kind') == 'tilted' and 12.0 <= r['terrain'].get('slope_deg', 0) <= 20.0
                                for r in rows),
            'fast_scenes': sum(r.get('fidelity') == 'fast' for r in rows)}


def _behind_ahead_pairs(rows: list[dict]) -> list[tuple]:
    """(ahead time, behind time) of each behind scene and the ahead scene just before it, both reached."""
    by_index = {int(r['scene'].rsplit('_', 1)[1]): r for r in rows if r.get('category') in ('ahead', 'behind')}
    pairs = []
    for index, row in sorted(by_index.items()):
        partner = by_index.get(index - 1)
        if row['category'] == 'behind' and partner is not None and partner['category'] == 'ahead' \
                and all(r.get('reached_goal') is True and _is_number(r.get('time_to_goal')) for r in (row, partner)):
            pairs.append((partner['time_to_goal'], row['time_to_goal']))
    return pairs
