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
The stability and speed-accuracy benchmarks as sweep plans: one engine task per scenario or per gait run.

`iguana bench stability`, `iguana bench tradeoff` and `iguana sweep` of a stability or tradeoff spec run these
plans; the maths (scenarios, runs, comparisons) stays in iguana_lab.bench.stability and iguana_lab.bench.sim.
"""
from __future__ import annotations

from iguana_lab.bench.sim import gait_run, TRADEOFF_MESHES, tradeoff_rows, tradeoff_runs
from iguana_lab.bench.stability import SCENARIOS
from iguana_lab.sweep.engine import Plan, Task, task_key
from iguana_ros.errors import InputError

TRADEOFF_TIMING = ('realtime_factor', 'realtime_factor_cpu', 'ms_per_step')
"""Columns of the tradeoff table that measure the machine."""


def stability_run(mesh: str, scenario: str, seconds: float) -> dict:
    """Scenario `scenario` for `seconds` on the benchmark model of `mesh` (a worker task)."""
    from iguana_lab.bench.workload import bench_model
    from iguana_lab.bench.stability import run_scenario

    model, _ = bench_model(mesh)
    return run_scenario(model, scenario, seconds)


def stability_plan(mesh: str = 'coarse', seconds: float = 1.5, scenarios: tuple | None = None) -> Plan:
    """One task per scenario (default every one of SCENARIOS, in its order) on the `mesh` benchmark model."""
    names = tuple(SCENARIOS) if scenarios is None else tuple(scenarios)
    unknown = [n for n in names if n not in SCENARIOS]
    if unknown:
        raise InputError(f'unknown stability scenario {unknown[0]!r}; known: {", ".join(SCENARIOS)}')
    return Plan([Task(task_key('stability', mesh, name, float(seconds)), stability_run, (mesh, name, float(seconds)),
                      {'scenario': name}, name) for name in names])


def tradeoff_plan(mesh: str = 'medium', seconds: float = 2.0, meshes: tuple = TRADEOFF_MESHES,
                  groups: tuple | None = None) -> Plan:
    """
    One task per gait run of the speed-accuracy table (references first; the settings of `groups`, default all).

    Rows as the table's.
    """
    runs = tradeoff_runs(mesh, tuple(meshes), groups)
    tasks = [Task(task_key('tradeoff', run.mesh, float(seconds), run.settings), gait_run,
                  (run.mesh, float(seconds), run.settings),
                  {'group': run.group, 'label': run.label, 'mesh': run.mesh}, f'{run.label} ({run.mesh})')
             for run in runs]
    return Plan(tasks, lambda results: tradeoff_rows(runs, results), TRADEOFF_TIMING)
