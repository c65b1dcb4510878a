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
Sweep spec files (YAML, lab/iguana_lab/sweeps/): what a sweep runs, validated with one-line errors, and its tasks.

A spec names one of three kinds of sweep:

- scenes: base `scenes` (names or paths) and/or `random_terrains` (the locomotion benchmark's seeded generator),
  crossed with every combination of a `grid` ({override: [values]}) and each entry of `cases` ([{override:
  value}]). An override is any scene field ('duration', 'adaptation', 'fidelity', 'model.stiffness',
  'terrain.amplitude', 'goals', ...), a fidelity knob ('fidelity.dt', 'fidelity.cg_tol', ...) or 'friction' (a
  Coulomb coefficient, or {node tag: coefficient}); each task is one `pipeline.run` of its scene.
- stability: the extreme scenarios of iguana_lab.bench.stability ({mesh, seconds, scenarios}).
- tradeoff: the speed-accuracy table of iguana_lab.bench.sim ({mesh, seconds, meshes, groups}: the
  groups of settings to run, default all; meshes [] for no mesh rows).

`plots` lists {x, y, by} columns to plot from the results table. Every task is built and every scene validated
when the spec is read, before anything runs.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from fractions import Fraction
import itertools
import math
from pathlib import Path
import typing

from iguana_ros.errors import InputError
from iguana_ros.scene import NAME_PATTERN, parse_scene, read_yaml, RESOLUTIONS, Scene

MAX_TASKS = 100_000
"""Most tasks a spec may expand to."""
SECTIONS = ('scenes', 'random_terrains', 'stability', 'tradeoff')
"""Top-level fields that say what a sweep runs (scenes and random_terrains may be combined)."""
SCENE_OVERRIDES = ('duration', 'adaptation', 'fidelity', 'goal_radius', 'goals', 'pushes')
"""Top-level scene fields a sweep may override (nested ones: 'terrain.<field>', 'model.<field>', 'start.<field>')."""
NESTED_OVERRIDES = ('terrain', 'model', 'start')
SUMMARIES = ('locomotion',)
"""Summaries a scenes sweep can add to its results: the locomotion benchmark's (per mode and terrain kind)."""


class SweepError(InputError):
    """A sweep spec is unreadable or has a wrong field; the message names file, field and expectation."""


@dataclass(frozen=True)
class PlotSpec:
    """One plot of the results table: column `y` against column `x`, one line per value of column `by`."""

    x: str
    y: str
    by: str | None = None


@dataclass(frozen=True)
class SweepSpec:
    """
    A validated sweep.

    Its `name`, `kind` (scenes, stability, tradeoff), `plan` (the engine's tasks), the `summary` to add, the `plots` and
    the spec `source` file.
    """

    name: str
    kind: str
    plan: object
    summary: str | None = None
    plots: tuple = ()
    source: str = '<spec>'


def _fail(source: str, path: str, message: str) -> typing.NoReturn:
    """Raise a SweepError naming spec file and field."""
    raise SweepError(f'{source}: field {path!r}: {message}')


SWEEPS_DIR = Path(__file__).resolve().parent.parent / 'sweeps'
"""The sweeps the lab ships (iguana_lab/sweeps/*.yaml, package data)."""


def sweep_path(name_or_path: str) -> Path:
    """Return a spec file: an existing path, or the name of a sweep under iguana_lab/sweeps/."""
    path = Path(name_or_path)
    if path.suffix in ('.yaml', '.yml') or path.exists():
        return path
    return SWEEPS_DIR / f'{name_or_path}.yaml'


def available_sweeps() -> list[str]:
    """Names of the sweeps shipped under iguana_lab/sweeps/."""
    return sorted(p.stem for p in SWEEPS_DIR.glob('*.yaml'))


def load_sweep(name_or_path: str) -> SweepSpec:
    """Read, validate and expand a spec by name or path; SweepError/SceneError (one line) if anything is wrong."""
    path = sweep_path(name_or_path)
    if not path.is_file():
        raise SweepError(f'no sweep {name_or_path!r} ({path} does not exist); shipped sweeps: '
                         f'{", ".join(available_sweeps())}')
    return parse_sweep(read_yaml(path, 'sweep spec'), str(path), path.parent, path.stem)


def parse_sweep(raw, source: str = '<spec>', base_dir: Path = Path('.'), default_name: str = 'sweep') -> SweepSpec:
    """Validate a parsed YAML mapping into a SweepSpec with its tasks (scene paths relative to `base_dir`)."""
    if not isinstance(raw, dict):
        raise SweepError(f'{source}: a sweep spec is a YAML mapping (e.g. {SWEEPS_DIR / "locomotion.yaml"})')
    known = {'name', 'description', 'grid', 'cases', 'stop_after_goal', 'summary', 'plots', *SECTIONS}
    unknown = sorted(str(k) for k in set(raw) - known)
    if unknown:
        _fail(source, unknown[0], f'unknown field; known fields: {", ".join(sorted(known))}')
    if not isinstance(raw.get('description', ''), str):
        _fail(source, 'description', f"expected text, got {raw['description']!r}")
    name = raw.get('name', default_name)
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        _fail(source, 'name', f"expected 1-64 letters, digits, '_', '.' or '-' (it names the results folder), "
                              f'got {name!r}')
    sections = [s for s in SECTIONS if s in raw]
    kind = 'scenes' if set(sections) <= {'scenes', 'random_terrains'} and sections else None
    if kind is None and len(sections) == 1:
        kind = sections[0]
    if kind is None:
        raise SweepError(f'{source}: a sweep names what it runs: scenes and/or random_terrains, or stability, or '
                         f'tradeoff; got {", ".join(sections) or "none of them"}')
    if kind != 'scenes':
        for field in ('grid', 'cases', 'stop_after_goal', 'summary'):
            if field in raw:
                _fail(source, field, f'applies to scene sweeps only, not to {kind}')
    plan = {'scenes': _scene_plan, 'stability': _stability_plan, 'tradeoff': _tradeoff_plan}[kind](raw, source,
                                                                                                   base_dir)
    summary = raw.get('summary')
    if summary is not None and summary not in SUMMARIES:
        _fail(source, 'summary', f'expected one of {", ".join(SUMMARIES)}, got {summary!r}')
    return SweepSpec(name, kind, plan, summary, _plots(raw.get('plots', []), source), source)


# --------------------------------------------------------------------------------------- small field checks

def _mapping(value, source: str, path: str, fields: dict) -> dict:
    """`value` as a mapping whose keys are among `fields` (name -> default); defaults filled in."""
    if value is None:
        value = {}
    if not isinstance(value, dict):
        _fail(source, path, f'expected a mapping, got {value!r}')
    unknown = sorted(str(k) for k in set(value) - set(fields))
    if unknown:
        _fail(source, f'{path}.{unknown[0]}', f'unknown field; known fields here: {", ".join(fields)}')
    return {**fields, **value}


def _number(value, source: str, path: str, integer: bool = False, minimum: float = 0.0,
            strict: bool = True) -> float:
    """Return a finite number > `minimum` (>= with strict=False); an integer with `integer`."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        _fail(source, path, f'expected a finite number, got {value!r}')
    if integer and not float(value).is_integer():
        _fail(source, path, f'expected an integer, got {value!r}')
    if value < minimum or (strict and value == minimum):
        _fail(source, path, f'expected a number {">" if strict else ">="} {minimum:g}, got {value!r}')
    return int(value) if integer else float(value)


def _strings(value, source: str, path: str, choices: tuple | None = None) -> tuple:
    """Return a non-empty list of strings (each among `choices` if given)."""
    if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
        _fail(source, path, f'expected a non-empty list of names, got {value!r}')
    bad = [v for v in value if choices is not None and v not in choices]
    if bad:
        _fail(source, path, f'expected names among {", ".join(choices)}, got {bad[0]!r}')
    return tuple(value)


def _choice(value, source: str, path: str, choices: tuple) -> str:
    """One of `choices`."""
    if value not in choices:
        _fail(source, path, f'expected one of {", ".join(choices)}, got {value!r}')
    return value


def _plots(raw, source: str) -> tuple:
    """Return the `plots` list: mappings {x, y, by (optional)} of column names."""
    if not isinstance(raw, list):
        _fail(source, 'plots', f'expected a list of {{x, y, by}} mappings, got {raw!r}')
    plots = []
    for i, item in enumerate(raw):
        fields = _mapping(item, source, f'plots[{i}]', {'x': None, 'y': None, 'by': None})
        for key in ('x', 'y', 'by'):
            if (fields[key] is not None and not isinstance(fields[key], str)) or (key != 'by' and not fields[key]):
                _fail(source, f'plots[{i}].{key}', f'expected a column name, got {fields[key]!r}')
        plots.append(PlotSpec(**fields))
    return tuple(plots)


# ------------------------------------------------------------------------------------------ benchmark kinds

def _stability_plan(raw: dict, source: str, _base_dir: Path):
    """Return the stability benchmark's plan from the `stability` section."""
    from iguana_lab.bench.stability import SCENARIOS
    from iguana_lab.sweep.benchmarks import stability_plan

    fields = _mapping(raw['stability'], source, 'stability', {'mesh': 'coarse', 'seconds': 1.5, 'scenarios': None})
    scenarios = fields['scenarios']
    if scenarios is not None:
        scenarios = _strings(scenarios, source, 'stability.scenarios', tuple(SCENARIOS))
    return stability_plan(_choice(fields['mesh'], source, 'stability.mesh', RESOLUTIONS),
                          _number(fields['seconds'], source, 'stability.seconds'), scenarios)


def _tradeoff_plan(raw: dict, source: str, _base_dir: Path):
    """Return the speed-accuracy benchmark's plan from the `tradeoff` section."""
    from iguana_lab.bench.sim import TRADEOFF_GROUPS, TRADEOFF_MESHES
    from iguana_lab.sweep.benchmarks import tradeoff_plan

    fields = _mapping(raw['tradeoff'], source, 'tradeoff', {'mesh': 'medium', 'seconds': 2.0,
                                                            'meshes': list(TRADEOFF_MESHES), 'groups': None})
    meshes = () if fields['meshes'] == [] else _strings(fields['meshes'], source, 'tradeoff.meshes', RESOLUTIONS)
    groups = fields['groups']
    return tradeoff_plan(_choice(fields['mesh'], source, 'tradeoff.mesh', RESOLUTIONS),
                         _number(fields['seconds'], source, 'tradeoff.seconds'), meshes,
                         None if groups is None else _strings(groups, source, 'tradeoff.groups', TRADEOFF_GROUPS))


# ---------------------------------------------------------------------------------------------- scene kind

def _scene_plan(raw: dict, source: str, base_dir: Path):
    """Tasks of a scenes sweep: base scenes x cases x grid combinations, each scene validated."""
    from iguana_lab.random_scenes import random_scenes
    from iguana_lab.sweep.engine import Plan

    named = _strings(raw['scenes'], source, 'scenes') if 'scenes' in raw else ()
    generator = _random_terrains(raw['random_terrains'], source) if 'random_terrains' in raw else None
    grid = _grid(raw.get('grid', {}), source)
    cases = _cases(raw.get('cases', [{}]), source, grid)
    stop = raw.get('stop_after_goal')
    stop = None if stop is None else _number(stop, source, 'stop_after_goal')
    n_bases = len(named) + (generator['n_terrains'] if generator else 0)
    n_tasks = n_bases * len(cases) * math.prod(len(values) for _, values in grid)
    if n_tasks > MAX_TASKS:
        raise SweepError(f'{source}: the sweep expands to {n_tasks} tasks, at most {MAX_TASKS} allowed')
    bases = _named_scenes(named, base_dir) + (random_scenes(**generator) if generator else [])
    keys = [key for key, _ in grid]
    tasks = []
    for base in bases:
        for case_index, case in enumerate(cases):
            for combination in itertools.product(*(values for _, values in grid)):
                overrides = {**case, **dict(zip(keys, combination))}
                where = f'{source} (scene {base.name}' + ''.join(f', {k}={v!r}' for k, v in overrides.items()) + ')'
                tasks.append(scene_task(base, overrides, stop, where))
    from iguana_lab.sweep.scene_task import TIMING_COLUMNS

    return Plan(tasks, timing=TIMING_COLUMNS)


def _named_scenes(entries: tuple, base_dir: Path) -> list[Scene]:
    """
    Return the scenes named by the spec.

    A name is tried as a relative path from the spec's folder first, then as load_scene finds it.
    """
    from iguana_ros.scene import load_scene

    scenes = []
    for entry in entries:
        local = base_dir / entry
        scenes.append(load_scene(str(local) if local.suffix in ('.yaml', '.yml') and local.is_file() else entry))
    return scenes


def _random_terrains(raw, source: str) -> dict:
    """
    Return the arguments of the locomotion benchmark's generator (random_scenes).

    They are taken from {count, seed, kinds, duration, mesh}.
    """
    from iguana_lab.random_scenes import BENCH_KINDS

    fields = _mapping(raw, source, 'random_terrains', {'count': None, 'seed': 0, 'kinds': list(BENCH_KINDS),
                                                       'duration': 40.0, 'mesh': 'medium'})
    if fields['count'] is None:
        _fail(source, 'random_terrains.count', 'expected the number of terrains')
    return {'n_terrains': _number(fields['count'], source, 'random_terrains.count', integer=True, minimum=1,
                                  strict=False),
            'seed': _number(fields['seed'], source, 'random_terrains.seed', integer=True, strict=False),
            'duration': _number(fields['duration'], source, 'random_terrains.duration'),
            'resolution': _choice(fields['mesh'], source, 'random_terrains.mesh', RESOLUTIONS),
            'kinds': _strings(fields['kinds'], source, 'random_terrains.kinds', BENCH_KINDS)}


def _grid(raw, source: str) -> list[tuple[str, tuple]]:
    """Return the grid as (override, values) pairs in file order."""
    if not isinstance(raw, dict):
        _fail(source, 'grid', f'expected a mapping of override -> list of values, got {raw!r}')
    grid = []
    for key, values in raw.items():
        check_override_key(key, source, f'grid.{key}')
        if not isinstance(values, list) or not values:
            _fail(source, f'grid.{key}', f'expected a non-empty list of values, got {values!r}')
        grid.append((key, tuple(values)))
    return grid


def _cases(raw, source: str, grid: list) -> list[dict]:
    """Return the cases: override mappings, none naming a grid key."""
    if not isinstance(raw, list) or not raw:
        _fail(source, 'cases', f'expected a non-empty list of override mappings, got {raw!r}')
    in_grid = {key for key, _ in grid}
    for i, case in enumerate(raw):
        if not isinstance(case, dict):
            _fail(source, f'cases[{i}]', f'expected a mapping of override -> value, got {case!r}')
        for key in case:
            check_override_key(key, source, f'cases[{i}].{key}')
            if key in in_grid:
                _fail(source, f'cases[{i}].{key}', 'is also a grid key: give each override in one place')
    return list(raw)


def fidelity_knobs() -> dict:
    """{knob name: type} of the Fidelity fields a sweep may set ('fidelity.<knob>'; not the mesh resolution)."""
    from iguana_ros.physics.fidelity import Fidelity

    hints = typing.get_type_hints(Fidelity)
    return {f.name: hints[f.name] for f in dataclasses.fields(Fidelity) if f.name != 'resolution'}


def check_override_key(key, source: str, path: str) -> None:
    """`SweepError` unless `key` names something a task can override."""
    if not isinstance(key, str):
        _fail(source, path, f'expected an override name, got {key!r}')
    head, _, tail = key.partition('.')
    if key in SCENE_OVERRIDES or key == 'friction':
        return
    if head == 'fidelity' and tail in fidelity_knobs():
        return
    if head in NESTED_OVERRIDES and tail in {f.name for f in dataclasses.fields(_spec_type(head))}:
        return
    nested = ', '.join(f'{h}.<field>' for h in NESTED_OVERRIDES)
    _fail(source, path, f'unknown override; expected one of {", ".join(SCENE_OVERRIDES)}, {nested}, '
                        f'fidelity.<{"|".join(fidelity_knobs())}>, friction')


def _spec_type(head: str) -> type:
    """Return the dataclass of a nested scene field ('terrain' -> TerrainSpec)."""
    return typing.get_type_hints(Scene)[head]


def scene_task(base: Scene, overrides: dict, stop_after_goal: float | None, where: str):
    """Return the engine task of `base` with `overrides` (validated: SceneError/SweepError naming `where`)."""
    from iguana_lab.sweep.engine import Task, task_key
    from iguana_lab.sweep.scene_task import IDENTITY_ALIASES, RunOptions, run_scene, scene_identity

    raw = dataclasses.asdict(base)
    knobs, friction, shown = {}, None, dict(overrides)
    for key, value in overrides.items():
        head, _, tail = key.partition('.')
        if head == 'fidelity' and tail:
            knobs[tail] = shown[key] = _knob(tail, value, where)
        elif key == 'friction':
            friction = _friction(value, where)
        elif tail:
            raw[head] = {**raw[head], tail: value}
        else:
            raw[key] = value
    scene = parse_scene(raw, where)
    _check_knobs(scene.fidelity, knobs, where)
    simulator = tuple(sorted(knobs.items())) + ((('friction', friction),) if friction is not None else ())
    options = RunOptions(stop_after_goal=stop_after_goal, simulator=simulator)
    identity = scene_identity(scene)
    identity.update({k: v for k, v in shown.items() if IDENTITY_ALIASES.get(k, k) not in identity})
    label = scene.name + ''.join(f' {k}={v}' for k, v in overrides.items())
    return Task(task_key('scene', scene, options), run_scene, (scene, options, identity), identity, label)


def _knob(name: str, value, where: str):
    """Return a fidelity knob's value of its field type (a float may be given as a fraction such as '1/1200')."""
    kind = fidelity_knobs()[name]
    if kind is float and isinstance(value, str):
        try:
            value = float(Fraction(value))
        except (ValueError, ZeroDivisionError):
            raise SweepError(f'{where}: fidelity.{name}: expected a number or a fraction like 1/1200, '
                             f'got {value!r}') from None
    if kind is str:
        if not isinstance(value, str):
            raise SweepError(f'{where}: fidelity.{name}: expected a name, got {value!r}')
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SweepError(f'{where}: fidelity.{name}: expected a finite number, got {value!r}')
    if kind is int and not float(value).is_integer():
        raise SweepError(f'{where}: fidelity.{name}: expected an integer, got {value!r}')
    return int(value) if kind is int else float(value)


def _check_knobs(preset: str, knobs: dict, where: str) -> None:
    """Check: the scene's fidelity preset with `knobs` must be valid settings."""
    from iguana_ros.physics.fidelity import get_fidelity

    try:
        get_fidelity(preset, **knobs)
    except InputError as exc:
        raise SweepError(f'{where}: {exc}') from None


def _friction(value, where: str):
    """Return a Coulomb coefficient >= 0, or a mapping {node tag or 'default': coefficient}."""
    values = value.values() if isinstance(value, dict) else [value]
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
            raise SweepError(f'{where}: friction: expected a number >= 0 or a mapping of node tag -> number >= 0, '
                             f'got {value!r}')
    if isinstance(value, dict):
        if not all(isinstance(k, str) for k in value):
            raise SweepError(f'{where}: friction: node tags must be names, got {value!r}')
        return tuple(sorted((k, float(v)) for k, v in value.items()))
    return float(value)
