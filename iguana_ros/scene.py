"""Scene files (YAML under msg_configs/scenes/): schema, defaults and validation with clear errors.

A scene says what a run contains — terrain, model, start, goals, pushes, duration, fidelity, what to
record — and only what it names is built (DESIGN.md, "model only what a scene requires").
"""
from __future__ import annotations

import dataclasses
import math
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from iguana_ros.config import config_path
from iguana_ros.constants import PUSH_DURATION
from iguana_ros.errors import InputError

TERRAIN_KINDS = ('flat', 'tilted', 'hills', 'heightmap', 'steps', 'noise')
RESOLUTIONS = ('coarse', 'medium', 'fine')
STIFFNESS_PRESETS = ('normal', 'softer')
FIDELITY_PRESETS = ('fast', 'balanced', 'accurate')


class SceneError(InputError):
    """A scene file is unreadable or has a wrong field; the message names file, field and expectation."""


@dataclass(frozen=True)
class TerrainSpec:
    """Terrain of a scene: flat ground, a tilted plane, procedural hills, steps or noise, or a height-map file.

    Fields by kind (lengths in m): tilted `slope_deg`, `direction_deg`; hills `amplitude`, `wavelength`, `seed`;
    steps `block_size`, `step_min`, `step_max`, `seed`, `spacing` (flat pad of radius 0.4 m at height 0 around
    the origin); noise `amplitude`, `wavelength`, `seed`, `spacing`; heightmap `file`, `scale`, `spacing`.
    Every kind is a square of side `extent` centred on the origin (a height map: its own size).
    """

    kind: str = 'flat'
    slope_deg: float = 10.0
    direction_deg: float = 0.0
    amplitude: float = 0.04
    wavelength: float = 0.8
    seed: int = 1
    extent: float = 10.0
    spacing: float = 0.05
    file: str = ''
    scale: float = 1.0
    block_size: float = 0.3
    step_min: float = 0.03
    step_max: float = 0.05


@dataclass(frozen=True)
class ModelSpec:
    """Which soft-body iguana to build: mesh resolution and stiffness preset."""

    resolution: str = 'medium'
    stiffness: str = 'normal'


@dataclass(frozen=True)
class StartSpec:
    """Initial root position on the ground plane (m) and heading (deg)."""

    x: float = 0.0
    y: float = 0.0
    yaw_deg: float = 0.0


@dataclass(frozen=True)
class GoalSpec:
    """A goal position (m) sent at simulated time `at` (s), optionally with a heading (deg)."""

    x: float = 0.0
    y: float = 0.0
    at: float = 0.0
    yaw_deg: float = 0.0


@dataclass(frozen=True)
class PushSpec:
    """An external push: force (N, world frame) on a tagged node group from `at` for `duration` s."""

    at: float = 0.0
    force: tuple = (0.0, 40.0, 0.0)
    duration: float = PUSH_DURATION
    region: str = 'trunk_left'


@dataclass(frozen=True)
class RecordSpec:
    """What a run records: topic keys of msg_configs/topics.yaml ('all' = every one)."""

    topics: tuple = ('all',)
    mesh_every_n_frames: int = 1


@dataclass(frozen=True)
class Scene:
    """A whole scene; every field has a default."""

    name: str = 'unnamed'
    description: str = ''
    terrain: TerrainSpec = field(default_factory=TerrainSpec)
    model: ModelSpec = field(default_factory=ModelSpec)
    start: StartSpec = field(default_factory=StartSpec)
    goals: tuple = ()
    goal_radius: float = 0.15
    pushes: tuple = ()
    duration: float = 10.0
    fidelity: str = 'balanced'
    adaptation: bool = True
    record: RecordSpec = field(default_factory=RecordSpec)

    @property
    def needs_adaptation(self) -> bool:
        """Terrain adaptation runs only where it can change anything: adaptation on and terrain not flat."""
        return self.adaptation and self.terrain.kind != 'flat'

    @property
    def needs_pushes(self) -> bool:
        """Push handling is built only when the scene has pushes."""
        return bool(self.pushes)


_ITEM_TYPES = {'goals': GoalSpec, 'pushes': PushSpec}
_CHOICES = {
    'terrain.kind': TERRAIN_KINDS, 'model.resolution': RESOLUTIONS,
    'model.stiffness': STIFFNESS_PRESETS, 'fidelity': FIDELITY_PRESETS,
    'pushes.region': ('trunk_left', 'trunk_right', 'tail', 'head', 'feet', 'legs', 'all'),
}
_POSITIVE = {'duration', 'goal_radius', 'terrain.wavelength', 'terrain.extent', 'terrain.spacing',
             'terrain.scale', 'terrain.block_size', 'pushes.duration', 'record.mesh_every_n_frames'}
_NON_NEGATIVE = {'goals.at', 'pushes.at', 'terrain.amplitude', 'terrain.step_min', 'terrain.step_max'}
MAX_GRID_NODES = 4000 ** 2
"""Largest grid (nodes) a generated steps or noise terrain may have: `(extent / spacing + 1)²`."""


def _fail(source: str, path: str, message: str) -> typing.NoReturn:
    """Raise a SceneError naming file and field."""
    raise SceneError(f'{source}: field {path!r}: {message}')


def _check_number(value, source: str, path: str, expected: type):
    """Validate a finite number (ints accepted for floats)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        _fail(source, path, f'expected a number, got {value!r}')
    if not math.isfinite(value):
        _fail(source, path, f'expected a finite number, got {value!r}')
    if expected is int and not float(value).is_integer():
        _fail(source, path, f'expected an integer, got {value!r}')
    key = _generic(path)
    if key in _POSITIVE and value <= 0:
        _fail(source, path, f'expected a positive number, got {value!r}')
    if key in _NON_NEGATIVE and value < 0:
        _fail(source, path, f'expected a number >= 0, got {value!r}')
    return expected(value)


def _generic(path: str) -> str:
    """'pushes[1].at' -> 'pushes.at' (the key used by the value rules)."""
    return '.'.join(part.split('[')[0] for part in path.split('.'))


def _check_value(value, annotation, source: str, path: str):
    """Validate and convert one scalar, tuple or nested spec against its annotation."""
    if dataclasses.is_dataclass(annotation):
        return _build(annotation, value, source, path)
    if annotation is bool:
        if not isinstance(value, bool):
            _fail(source, path, f'expected true or false, got {value!r}')
        return value
    if annotation in (int, float):
        return _check_number(value, source, path, annotation)
    if annotation is str:
        if not isinstance(value, str):
            _fail(source, path, f'expected a string, got {value!r}')
        choices = _CHOICES.get(_generic(path))
        if choices and value not in choices:
            _fail(source, path, f'expected one of {", ".join(choices)}, got {value!r}')
        return value
    return _check_tuple(value, source, path)


def _check_tuple(value, source: str, path: str) -> tuple:
    """Validate a list field: goals/pushes of specs, force vectors, topic lists."""
    if isinstance(value, str) and path == 'record.topics':
        value = [value]
    if not isinstance(value, (list, tuple)):
        _fail(source, path, f'expected a list, got {value!r}')
    item_type = _ITEM_TYPES.get(path.split('.')[-1])
    if item_type is not None:
        return tuple(_build(item_type, item, source, f'{path}[{i}]') for i, item in enumerate(value))
    if path.endswith('force'):
        if len(value) != 3:
            _fail(source, path, f'expected 3 numbers [fx, fy, fz] in N, got {value!r}')
        return tuple(_check_number(v, source, f'{path}[{i}]', float) for i, v in enumerate(value))
    if not all(isinstance(v, str) for v in value):
        _fail(source, path, f'expected a list of strings, got {value!r}')
    return tuple(value)


def _build(cls: type, raw, source: str, prefix: str = ''):
    """Build dataclass `cls` from a mapping, rejecting unknown fields."""
    if raw is None:
        raw = {}
    if not isinstance(raw, dict):
        _fail(source, prefix or '<top level>', f'expected a mapping, got {raw!r}')
    hints = typing.get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(raw) - names)
    if unknown:
        where = f'{prefix}.{unknown[0]}' if prefix else unknown[0]
        _fail(source, where, f'unknown field; known fields here: {", ".join(sorted(names))}')
    values = {}
    for name, value in raw.items():
        path = f'{prefix}.{name}' if prefix else name
        values[name] = _check_value(value, _annotation(hints[name]), source, path)
    return cls(**values)


def _annotation(hint):
    """Strip Optional/union wrappers to the concrete type."""
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        return next(a for a in typing.get_args(hint) if a is not type(None))
    return hint


def _cross_checks(scene: Scene, source: str) -> None:
    """Rules that span fields."""
    if scene.terrain.kind == 'heightmap' and not scene.terrain.file:
        _fail(source, 'terrain.file', 'a heightmap terrain needs a file (.npy or 16-bit .png)')
    if abs(scene.terrain.slope_deg) >= 60.0:
        _fail(source, 'terrain.slope_deg', f'expected |slope| < 60 deg, got {scene.terrain.slope_deg}')
    if scene.terrain.kind in ('steps', 'noise'):
        _check_generated_terrain(scene.terrain, source)
    half = scene.terrain.extent / 2.0
    for i, goal in enumerate(scene.goals):
        if max(abs(goal.x), abs(goal.y)) > half:
            _fail(source, f'goals[{i}]', f'goal ({goal.x}, {goal.y}) is off the terrain (|x|, |y| <= {half})')


def _check_generated_terrain(terrain: TerrainSpec, source: str) -> None:
    """Rules of the `steps` and `noise` grids: block and step ranges, samples per wavelength, grid size."""
    from iguana_ros.terrain.heightfield import NOISE_MIN_SAMPLES

    nodes = (math.ceil(terrain.extent / terrain.spacing) + 1) ** 2
    if nodes > MAX_GRID_NODES:
        _fail(source, 'terrain.spacing', f'a {terrain.extent:g} m terrain at spacing {terrain.spacing:g} m has '
              f'{nodes} grid nodes, at most {MAX_GRID_NODES} allowed; use a larger spacing')
    if terrain.kind == 'steps':
        if terrain.step_max < terrain.step_min:
            _fail(source, 'terrain.step_max', f'expected >= step_min ({terrain.step_min}), got {terrain.step_max}')
        if terrain.block_size < terrain.spacing:
            _fail(source, 'terrain.block_size', f'expected >= spacing ({terrain.spacing}), got {terrain.block_size}')
    elif terrain.wavelength < NOISE_MIN_SAMPLES * terrain.spacing:
        _fail(source, 'terrain.wavelength', f'expected >= {NOISE_MIN_SAMPLES} x spacing '
              f'({NOISE_MIN_SAMPLES * terrain.spacing:g} m), got {terrain.wavelength}')


def parse_scene(raw, source: str = '<scene>') -> Scene:
    """Validate a parsed YAML mapping into a Scene; SceneError names the field."""
    scene = _build(Scene, raw, source)
    _cross_checks(scene, source)
    return scene


def scene_path(name_or_path: str) -> Path:
    """A scene file: an existing path, or the name of a scene under msg_configs/scenes/."""
    path = Path(name_or_path)
    if path.suffix in ('.yaml', '.yml') or path.exists():
        return path
    return config_path('scenes', f'{name_or_path}.yaml')


def available_scenes() -> list[str]:
    """Names of the scenes shipped under msg_configs/scenes/."""
    return sorted(p.stem for p in config_path('scenes').glob('*.yaml'))


def load_scene(name_or_path: str) -> Scene:
    """Read and validate a scene by name or path; SceneError (one line) if missing or invalid."""
    path = scene_path(name_or_path)
    if not path.is_file():
        raise SceneError(f'no scene {name_or_path!r} ({path} does not exist); '
                         f'shipped scenes: {", ".join(available_scenes())}')
    try:
        raw = yaml.safe_load(path.read_text())
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        reason = str(exc).replace('\n', ' ')
        raise SceneError(f'{path}: not a readable YAML scene: {reason}') from exc
    scene = parse_scene(raw, str(path))
    if scene.name == 'unnamed':
        scene = dataclasses.replace(scene, name=path.stem)
    return scene
