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
Randomized locomotion benchmark: many seeded terrains, one goal each, with and without terrain adaptation.

`random_scenes` (iguana_ros.random_scenes) draws the scenes (hills, tilted planes, steps, smooth noise; a goal 3 m from
the start in a random direction, also behind the iguana, which starts facing +x), `run_benchmark` runs every (scene,
adaptation) pair on the sweep engine (iguana_ros.sweep, Dask) and returns one plain row per run, `summarize` reduces the
rows per mode and terrain kind and compares the modes. ROS-free; `iguana bench locomotion` is the command over it, and
`iguana sweep locomotion` (msg_configs/sweeps/locomotion.yaml) the same sweep from a spec file.
"""
from __future__ import annotations

import math
import statistics
import time
from typing import Callable

import numpy as np

from iguana_ros.random_scenes import (BENCH_KINDS, GOAL_DISTANCE, GOAL_RADIUS, random_scenes,  # noqa: F401
                                      TERRAIN_EXTENT)
from iguana_ros.scene import Scene
from iguana_ros.sweep.engine import error_row, run_local, Task, task_key
from iguana_ros.sweep.scene_task import MODE_NAMES, run_scene, RunOptions, scene_identity

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
