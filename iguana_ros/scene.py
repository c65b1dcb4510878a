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
Scene files (YAML under msg_configs/scenes/): schema, defaults and validation with clear errors.

A scene says what a run contains — terrain, model, start, goals, pushes, duration, fidelity, what to
record — and only what it names is built ("model only what a scene requires"; docs/ARCHITECTURE.md).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
import math
from pathlib import Path
import re
import reprlib
import types
import typing


from iguana_ros.config import config_path
from iguana_ros.constants import FRAME_RATE, PUSH_DURATION
from iguana_ros.errors import InputError
from iguana_ros.yaml_files import field_error, read_yaml_file
from iguana_ros.yaml_files import MAX_NESTING, MAX_SCENE_BYTES, MAX_YAML_NODES  # noqa: F401 - limits of a scene file

if typing.TYPE_CHECKING:
    from iguana_ros.terrain.heightfield import HeightField

TERRAIN_KINDS = ('flat', 'tilted', 'hills', 'heightmap', 'steps', 'noise')
RESOLUTIONS = ('coarse', 'medium', 'fine')
STIFFNESS_PRESETS = ('normal', 'softer')
FIDELITY_PRESETS = ('fast', 'balanced', 'accurate')


class SceneError(InputError):
    """A scene file is unreadable or has a wrong field; the message names file, field and expectation."""


@dataclass(frozen=True)
class TerrainSpec:
    """
    Terrain of a scene: flat ground, a tilted plane, procedural hills, steps or noise, or a height-map file.

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
    """A goal position (m) sent at simulated time `at` (s), optionally with a heading (deg; none: any heading)."""

    x: float = 0.0
    y: float = 0.0
    at: float = 0.0
    yaw_deg: float | None = None


@dataclass(frozen=True)
class WaypointSpec:
    """A waypoint of a route (m); a heading (deg) counts for the last one only."""

    x: float = 0.0
    y: float = 0.0
    yaw_deg: float | None = None


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
class CharacterSpec:
    """One of several iguanas in a scene: its name (its ROS namespace), body, start, goals or route, adaptation."""

    name: str = 'iguana'
    model: ModelSpec | None = None
    start: StartSpec = field(default_factory=StartSpec)
    goals: tuple = ()
    route: tuple = ()
    adaptation: bool = True
    avoid_others: bool = True
    """Whether its planner keeps clear of the other characters (false: it walks as if alone, and bumps into them)."""


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
    goal_yaw_tolerance_deg: float = 30.0
    route: tuple = ()
    pushes: tuple = ()
    duration: float = 10.0
    fidelity: str = 'balanced'
    adaptation: bool = True
    record: RecordSpec = field(default_factory=RecordSpec)
    characters: tuple = ()

    @property
    def needs_adaptation(self) -> bool:
        """Terrain adaptation runs only where it can change anything: adaptation on and terrain not flat."""
        return self.adaptation and self.terrain.kind != 'flat'

    @property
    def needs_pushes(self) -> bool:
        """Push handling is built only when the scene has pushes."""
        return bool(self.pushes)

    def character_scenes(self) -> list[tuple[str, Scene]]:
        """
        Return (name, scene of that character alone) per character: the `characters` list, else the scene itself.

        A character's scene is this scene with the character's model (the scene's if none), start, goals, route and
        adaptation; the terrain, duration, fidelity and goal tolerances are the world's.
        """
        if not self.characters:
            return [(DEFAULT_CHARACTER, self)]
        return [(c.name, dataclasses.replace(self, model=c.model or self.model, start=c.start, goals=c.goals,
                                             route=c.route, adaptation=c.adaptation, characters=()))
                for c in self.characters]

    @property
    def destination(self) -> GoalSpec | None:
        """Return the last place the scene sends the iguana: its last goal or route end (None: neither)."""
        if self.route:
            last = self.route[-1]
            return GoalSpec(x=last.x, y=last.y, yaw_deg=last.yaw_deg)
        return self.goals[-1] if self.goals else None


_ITEM_TYPES = {'goals': GoalSpec, 'pushes': PushSpec, 'route': WaypointSpec, 'characters': CharacterSpec}
_CHOICES = {
    'terrain.kind': TERRAIN_KINDS, 'model.resolution': RESOLUTIONS,
    'model.stiffness': STIFFNESS_PRESETS, 'fidelity': FIDELITY_PRESETS,
    'pushes.region': ('trunk_left', 'trunk_right', 'tail', 'head', 'feet', 'legs', 'all'),
}
_POSITIVE = {'duration', 'goal_radius', 'goal_yaw_tolerance_deg', 'terrain.wavelength', 'terrain.extent',
             'terrain.spacing',
             'terrain.scale', 'terrain.block_size', 'pushes.duration', 'record.mesh_every_n_frames'}
_NON_NEGATIVE = {'goals.at', 'pushes.at', 'terrain.amplitude', 'terrain.step_min', 'terrain.step_max', 'terrain.seed'}

# --- resource limits: everything a run allocates or loops over in proportion to a scene value is bounded here
MAX_DURATION = 600.0
"""Longest run a scene may ask for, s (the trajectories of a fine-mesh run take ~30 kB per frame)."""
MAX_GOALS = 100
"""Most goals in a scene."""
MAX_PUSHES = 100
"""Most pushes in a scene."""
MAX_WAYPOINTS = 100
"""Most waypoints in a scene's route."""
MAX_CHARACTERS = 16
"""Most characters in one scene's world."""
DEFAULT_CHARACTER = 'iguana'
"""Name of the one character of a scene without a `characters` list."""
CHARACTER_NAME = re.compile(r'[A-Za-z_][A-Za-z0-9_]{0,63}')
"""A character's name: it is its ROS namespace (`/<name>/iguana_state`) and TF prefix, so a ROS name token."""
MAX_EXTENT = 1000.0
"""Largest terrain side and length of any terrain feature, m."""
MAX_RELIEF = 100.0
"""Largest terrain height figure (amplitude, step heights, height-map scale), m."""
MAX_PUSH_FORCE = 1000.0
"""Largest push force magnitude, N (25 x the paper's 40 N push), alone or summed over the pushes acting at once: of
a scene's pushes here, of the push topic in iguana_ros.validation (velocity changes: constants.MAX_PUSH_*_DELTA_V)."""
MAX_ANGLE_DEG = 360.0
"""Largest |angle| of a heading or terrain direction, deg."""
MAX_SEED = 2 ** 63 - 1
"""Largest terrain seed."""
MAX_TEXT = 4096
"""Longest string field (description, height-map path), characters."""
NAME_PATTERN = re.compile(r'[A-Za-z0-9][A-Za-z0-9_.-]{0,63}')
"""A scene name: it names the bag folder of a run, so 1-64 letters, digits, '_', '.', '-', no leading '.'."""

_AT_MOST = {
    'duration': (MAX_DURATION, 's'), 'goals.at': (MAX_DURATION, 's'), 'pushes.at': (MAX_DURATION, 's'),
    'pushes.duration': (MAX_DURATION, 's'), 'terrain.extent': (MAX_EXTENT, 'm'), 'terrain.spacing': (MAX_EXTENT, 'm'),
    'terrain.wavelength': (MAX_EXTENT, 'm'), 'terrain.block_size': (MAX_EXTENT, 'm'), 'goal_radius': (MAX_EXTENT, 'm'),
    'terrain.amplitude': (MAX_RELIEF, 'm'), 'terrain.step_min': (MAX_RELIEF, 'm'),
    'terrain.step_max': (MAX_RELIEF, 'm'), 'terrain.scale': (MAX_RELIEF, 'm'), 'terrain.seed': (MAX_SEED, ''),
    'record.mesh_every_n_frames': (int(MAX_DURATION * FRAME_RATE), 'frames'),
}
_WITHIN = {'start.yaw_deg': (MAX_ANGLE_DEG, 'deg'), 'goals.yaw_deg': (MAX_ANGLE_DEG, 'deg'),
           'route.yaw_deg': (MAX_ANGLE_DEG, 'deg'),
           'terrain.direction_deg': (MAX_ANGLE_DEG, 'deg')}
_MAX_ITEMS = {'goals': MAX_GOALS, 'pushes': MAX_PUSHES, 'route': MAX_WAYPOINTS, 'characters': MAX_CHARACTERS}
MAY_BE_INFINITE = {'goal_yaw_tolerance_deg'}
"""Number fields that accept .inf: a yaw tolerance of inf ignores a goal's heading."""


def _fail(source: str, path: str, message: str) -> typing.NoReturn:
    """Raise a SceneError naming file and field (a long field name shortened, so the message stays one line)."""
    field_error(SceneError, source, path, message)


def _show(value) -> str:
    """Return a short one-line repr of a (possibly huge or deeply shared) YAML value for an error message."""
    short = reprlib.Repr()
    short.maxstring = short.maxother = short.maxlong = 60
    short.maxlist = short.maxtuple = short.maxdict = short.maxset = 6
    short.maxlevel = 3
    return short.repr(value).replace('\n', ' ')


def _limit(value: float) -> str:
    """Return a limit for a message: integers in full, other numbers in %g."""
    return str(int(value)) if float(value).is_integer() else f'{value:g}'


def _check_number(value, source: str, path: str, expected: type):
    """Validate a finite number within the field's range (ints accepted for floats) and convert it."""
    problem = _number_problem(value, _generic(path), expected)
    if problem:
        _fail(source, path, problem)
    return expected(value)


def _number_problem(value, key: str, expected: type) -> str:
    """Return what is wrong with `value` as number field `key` ('goals.at'; ranges in _POSITIVE ... _WITHIN), or ''."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return f'expected a number, got {_show(value)}'
    if isinstance(value, float) and math.isinf(value) and value > 0 and key in MAY_BE_INFINITE:
        return ''
    if isinstance(value, float) and not math.isfinite(value):
        return f'expected a finite number, got {value!r}'
    if expected is int and isinstance(value, float) and not value.is_integer():
        return f'expected an integer, got {value!r}'
    if key in _POSITIVE and value <= 0:
        return f'expected a positive number, got {_show(value)}'
    if key in _NON_NEGATIVE and value < 0:
        return f'expected a number >= 0, got {_show(value)}'
    if key in _AT_MOST and value > _AT_MOST[key][0]:
        limit, unit = _AT_MOST[key]
        return f'expected at most {_limit(limit)}{" " + unit if unit else ""}, got {_show(value)}'
    if key in _WITHIN and abs(value) > _WITHIN[key][0]:
        limit, unit = _WITHIN[key]
        return f'expected a number within [-{_limit(limit)}, {_limit(limit)}] {unit}, got {_show(value)}'
    if abs(value) > 1e308:
        return f'expected a number of magnitude below 1e308, got {_show(value)}'
    return ''


def accepts_infinity(path: str) -> bool:
    """Whether number field `path` (e.g. 'goal_yaw_tolerance_deg') accepts +inf (MAY_BE_INFINITE)."""
    return _generic(path) in MAY_BE_INFINITE


def _generic(path: str) -> str:
    """'pushes[1].at' -> 'pushes.at', 'characters[0].model.resolution' -> 'model.resolution' (the rules' keys)."""
    generic = '.'.join(part.split('[')[0] for part in path.split('.'))
    return generic.removeprefix('characters.')


def _check_value(value, annotation, source: str, path: str):
    """Validate and convert one scalar, tuple or nested spec against its annotation."""
    if dataclasses.is_dataclass(annotation):
        return _build(annotation, value, source, path)
    if annotation is bool:
        if not isinstance(value, bool):
            _fail(source, path, f'expected true or false, got {_show(value)}')
        return value
    if annotation in (int, float):
        return _check_number(value, source, path, annotation)
    if annotation is str:
        return _check_string(value, source, path)
    return _check_tuple(value, source, path)


def _check_string(value, source: str, path: str) -> str:
    """Validate a string field: one of its choices, a scene name, or text of at most MAX_TEXT characters."""
    if not isinstance(value, str):
        _fail(source, path, f'expected a string, got {_show(value)}')
    choices = _CHOICES.get(_generic(path))
    if choices and value not in choices:
        _fail(source, path, f'expected one of {", ".join(choices)}, got {_show(value)}')
    if path == 'name' and not NAME_PATTERN.fullmatch(value):
        _fail(source, path, f"expected 1-64 letters, digits, '_', '.' or '-' (it names the run's bag folder), "
                            f'got {_show(value)}')
    if len(value) > MAX_TEXT:
        _fail(source, path, f'expected at most {MAX_TEXT} characters, got {len(value)}')
    return value


def _check_tuple(value, source: str, path: str) -> tuple:
    """Validate a list field: goals/pushes of specs, force vectors, topic lists."""
    if isinstance(value, str) and path == 'record.topics':
        value = [value]
    if not isinstance(value, (list, tuple)):
        _fail(source, path, f'expected a list, got {_show(value)}')
    name = path.split('.')[-1]
    item_type = _ITEM_TYPES.get(name)
    if item_type is not None:
        if len(value) > _MAX_ITEMS[name]:
            _fail(source, path, f'expected at most {_MAX_ITEMS[name]} {name}, got {len(value)}')
        return tuple(_build(item_type, item, source, f'{path}[{i}]') for i, item in enumerate(value))
    if path.endswith('force'):
        if len(value) != 3:
            _fail(source, path, f'expected 3 numbers [fx, fy, fz] in N, got {_show(value)}')
        force = tuple(_check_number(v, source, f'{path}[{i}]', float) for i, v in enumerate(value))
        if math.hypot(*force) > MAX_PUSH_FORCE:
            _fail(source, path, f'expected a force of at most {_limit(MAX_PUSH_FORCE)} N, got |f| = '
                                f'{math.hypot(*force):g} N')
        return force
    if path == 'record.topics':
        return _check_topics(value, source, path)
    if not all(isinstance(v, str) for v in value):
        _fail(source, path, f'expected a list of strings, got {_show(value)}')
    return tuple(value)


def _check_topics(value: list, source: str, path: str) -> tuple:
    """Validate record.topics: 'all' or topic keys of msg_configs/topics.yaml."""
    from iguana_ros.topics import default_topics

    import difflib

    known = default_topics()
    for i, key in enumerate(value):
        if not isinstance(key, str) or (key != 'all' and key not in known):
            close = difflib.get_close_matches(str(key), list(known), n=3) if isinstance(key, str) else []
            hint = f'; close: {", ".join(close)}' if close else ''
            _fail(source, f'{path}[{i}]', f'expected all or a topic key of msg_configs/topics.yaml (e.g. '
                                          f'iguana_state, mesh_marker, clock, tf){hint}, got {_show(key)}')
    return tuple(value)


def _build(cls: type, raw, source: str, prefix: str = ''):
    """Build dataclass `cls` from a mapping, rejecting unknown fields."""
    if raw is None:
        raw = {}
    if not isinstance(raw, dict):
        _fail(source, prefix or '<top level>', f'expected a mapping, got {_show(raw)}')
    hints = typing.get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted((str(key) for key in set(raw) - names))
    if unknown:
        where = f'{prefix}.{unknown[0]}' if prefix else unknown[0]
        _fail(source, where, f'unknown field; known fields here: {", ".join(sorted(names))}')
    values = {}
    for name, value in raw.items():
        path = f'{prefix}.{name}' if prefix else name
        if value is None and _optional(hints[name]):
            values[name] = None                  # e.g. a goal's yaw_deg: null, no heading
            continue
        values[name] = _check_value(value, _annotation(hints[name]), source, path)
    return cls(**values)


def _optional(hint) -> bool:
    """Whether a field's type hint admits None (`float | None`)."""
    return (isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union) \
        and type(None) in typing.get_args(hint)


def _annotation(hint):
    """Strip Optional/union wrappers to the concrete type."""
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        return next(a for a in typing.get_args(hint) if a is not type(None))
    return hint


def _cross_checks(scene: Scene, source: str) -> None:
    """Rules that span fields: terrain grid and height-map size, slope, start and goals on the terrain."""
    from iguana_ros.terrain.heightfield import HILLS_SAMPLES   # the terrain floor, imported when needed (numba)

    terrain = scene.terrain
    if terrain.kind == 'heightmap':
        _check_heightmap(terrain, source)
    if abs(terrain.slope_deg) >= 60.0:
        _fail(source, 'terrain.slope_deg', f'expected |slope| < 60 deg, got {terrain.slope_deg}')
    if terrain.kind == 'hills':
        _check_grid(terrain.extent, terrain.wavelength / HILLS_SAMPLES, 'terrain.wavelength',
                    f'wavelength {terrain.wavelength:g} m (hills sample it {HILLS_SAMPLES} times)', source)
    if terrain.kind in ('steps', 'noise'):
        _check_grid(terrain.extent, terrain.spacing, 'terrain.spacing', f'spacing {terrain.spacing:g} m', source)
        _check_generated_terrain(terrain, source)
    _check_pushes(scene.pushes, source)
    if scene.characters:
        _check_characters(scene, source)
    for i, (_, one) in enumerate(scene.character_scenes()):
        _check_places(one, source, f'characters[{i}].' if scene.characters else '')


def _check_places(scene: Scene, source: str, prefix: str) -> None:
    """Start, goals and waypoints of one character on the terrain; goals or a route, not both."""
    half = scene.terrain.extent / 2.0
    if max(abs(scene.start.x), abs(scene.start.y)) > half:
        _fail(source, f'{prefix}start', f'start ({scene.start.x:g}, {scene.start.y:g}) is off the terrain '
                                        f'(|x|, |y| <= {half:g})')
    for key, what, items in (('goals', 'goal', scene.goals), ('route', 'waypoint', scene.route)):
        for i, goal in enumerate(items):
            if max(abs(goal.x), abs(goal.y)) > half:
                _fail(source, f'{prefix}{key}[{i}]', f'{what} ({goal.x:g}, {goal.y:g}) is off the terrain '
                                                     f'(|x|, |y| <= {half:g})')
    if scene.goals and scene.route:
        _fail(source, f'{prefix}route', 'a scene sends either goals or a route, not both')


def _check_characters(scene: Scene, source: str) -> None:
    """Names that are ROS name tokens, each once; no single-iguana start, goals or route beside the list."""
    for field_name in ('goals', 'route', 'pushes'):
        if getattr(scene, field_name):
            _fail(source, field_name, f'a scene with characters gives each its own {field_name} (under '
                                      f'characters[i]), not one list for all')
    if scene.start != StartSpec():
        _fail(source, 'start', 'a scene with characters gives each its own start (characters[i].start)')
    seen = set()
    for i, character in enumerate(scene.characters):
        if not CHARACTER_NAME.fullmatch(character.name):
            _fail(source, f'characters[{i}].name', 'expected letters, digits and underscores, not starting with a '
                                                   f'digit (it is the ROS namespace), got {_show(character.name)}')
        if character.name in seen:
            _fail(source, f'characters[{i}].name', f'{character.name!r} names two characters')
        seen.add(character.name)


def _check_pushes(pushes: tuple, source: str) -> None:
    """
    Check that the pushes acting when one starts are within MAX_PUSH_FORCE in all (the rule of the push topic).

    The velocity change each push gives its region and the body needs the model's masses:
    iguana_ros.validation.check_scene_pushes checks it where the model is built.
    """
    for i, push in enumerate(pushes):
        acting = sum(math.hypot(*q.force) for q in pushes if q.at <= push.at < q.at + q.duration)
        if acting > MAX_PUSH_FORCE:
            _fail(source, f'pushes[{i}].force', f'the pushes acting at {push.at:g} s total {acting:g} N, at most '
                                                f'{_limit(MAX_PUSH_FORCE)} N')


def _check_grid(extent: float, spacing: float, field_path: str, what: str, source: str) -> None:
    """Check that a generated terrain of side `extent` m sampled every `spacing` m has at most MAX_GRID_NODES nodes."""
    from iguana_ros.terrain.heightfield import MAX_GRID_NODES, grid_nodes, node_count

    nodes = grid_nodes(extent / 2.0, spacing)
    if nodes > MAX_GRID_NODES:
        _fail(source, field_path, f'a {extent:g} m terrain at {what} has {node_count(nodes)} grid nodes, at most '
                                  f'{MAX_GRID_NODES} allowed; use a smaller extent or a larger spacing')


def _check_heightmap(terrain: TerrainSpec, source: str) -> None:
    """
    Check that a heightmap terrain names a file that exists.

    The file's header must promise at most MAX_GRID_NODES values.
    """
    from iguana_ros.terrain.heightfield import heightmap_shape

    if not terrain.file:
        _fail(source, 'terrain.file', 'a heightmap terrain needs a file (.npy or 16-bit .png)')
    try:
        heightmap_shape(terrain.file)
    except InputError as exc:
        _fail(source, 'terrain.file', str(exc).removeprefix('height field: '))


def _check_generated_terrain(terrain: TerrainSpec, source: str) -> None:
    """Rules of the `steps` and `noise` grids: block and step ranges, samples per wavelength."""
    from iguana_ros.terrain.heightfield import NOISE_MIN_SAMPLES

    if terrain.kind == 'steps':
        if terrain.step_max < terrain.step_min:
            _fail(source, 'terrain.step_max', f'expected >= step_min ({terrain.step_min}), got {terrain.step_max}')
        if terrain.block_size < terrain.spacing:
            _fail(source, 'terrain.block_size', f'expected >= spacing ({terrain.spacing}), got {terrain.block_size}')
    elif terrain.wavelength < NOISE_MIN_SAMPLES * terrain.spacing:
        _fail(source, 'terrain.wavelength', f'expected >= {NOISE_MIN_SAMPLES} x spacing '
              f'({NOISE_MIN_SAMPLES * terrain.spacing:g} m), got {terrain.wavelength}')


def parse_scene(raw, source: str = '<scene>') -> Scene:
    """Validate a parsed YAML mapping into a Scene; SceneError names the field (None, an empty file: SceneError)."""
    if raw is None:
        raise SceneError(f'{source}: empty scene: a scene is a YAML mapping of fields '
                         f'(e.g. {config_path("scenes", "flat_walk.yaml")})')
    scene = _build(Scene, raw, source)
    _cross_checks(scene, source)
    return scene


def check_one_character(scene: Scene, what: str) -> Scene:
    """Return `scene` if it has one iguana; SceneError naming `what` (e.g. 'iguana run --namespace') for several."""
    if scene.characters:
        raise SceneError(f'{what}: scene {scene.name} has {len(scene.characters)} characters; a world runs in '
                         'the root namespace, a process per character: `iguana run` without that option, or '
                         '`iguana simulate`')
    return scene


CHARACTER_AUTO = 'auto'
"""The nodes' `character` default: the character named by the last name of the node's namespace."""


def served_characters(scene: Scene, character: str, namespace: str, world: bool) -> list[tuple[str, Scene]]:
    """
    Return (name, scene alone) of the characters a node serves: the one `character` names, else every one.

    `character` 'auto' names the last name of `namespace` ('/crossing/iguana_b': iguana_b) when the scene has such a
    character. A node that serves one character (not `world`) gets SceneError when none is named; a scene without a
    `characters` list is its own one character, whatever the name.
    """
    if not scene.characters:
        return scene.character_scenes()
    names = [c.name for c in scene.characters]
    wanted = named_character(scene, character, namespace)
    if wanted is not None:
        return [pair for pair in scene.character_scenes() if pair[0] == wanted]
    if not world:
        raise SceneError(f'scene {scene.name} has {len(names)} characters ({", ".join(names)}): run this node in a '
                         "character's namespace (-r __ns:=/NAME) or give -p character:=NAME")
    return scene.character_scenes()


def named_character(scene: Scene, character: str, namespace: str) -> str | None:
    """
    Return the character of `scene` that `character` (or, when 'auto', the last name of `namespace`) names, else None.

    SceneError for an explicit name the scene does not have.
    """
    names = [c.name for c in scene.characters]
    wanted = namespace.rstrip('/').rsplit('/', 1)[-1] if character == CHARACTER_AUTO else character
    if wanted in names:
        return wanted
    if character != CHARACTER_AUTO and scene.characters:
        raise SceneError(f'character {character!r} is not in scene {scene.name} (its characters: {", ".join(names)})')
    return None


def scene_path(name_or_path: str) -> Path:
    """Return a scene file: an existing path, or the name of a scene under msg_configs/scenes/."""
    path = Path(name_or_path)
    if path.suffix in ('.yaml', '.yml') or path.exists():
        return path
    return config_path('scenes', f'{name_or_path}.yaml')


def available_scenes() -> list[str]:
    """Names of the scenes shipped under msg_configs/scenes/."""
    return sorted(p.stem for p in config_path('scenes').glob('*.yaml'))


def with_duration(scene: Scene, seconds: float, option: str = '--duration') -> Scene:
    """
    `scene` run for `seconds` instead (a command-line `option`), within the limits of a scene's own duration.

    InputError naming the option otherwise.
    """
    problem = _number_problem(seconds, 'duration', float)
    if problem:
        raise InputError(f'{option}: {problem}')
    return dataclasses.replace(scene, duration=float(seconds))


def terrain_from_spec(spec: TerrainSpec) -> HeightField:
    """Return the HeightField of a scene's terrain; `spec.extent` is the side of the square (m), centred on 0."""
    import numpy as np

    from iguana_ros.terrain.heightfield import HeightField   # the terrain floor, imported when needed (numba)

    half = spec.extent / 2.0
    if spec.kind == 'flat':
        return HeightField.flat(extent=half)
    if spec.kind == 'tilted':
        d = np.radians(spec.direction_deg)
        return HeightField.tilted_plane(spec.slope_deg, (np.cos(d), np.sin(d)), extent=half)
    if spec.kind == 'hills':
        return HeightField.hills(spec.amplitude, spec.wavelength, spec.seed, extent=half)
    if spec.kind == 'steps':
        return HeightField.steps(spec.block_size, spec.step_min, spec.step_max, spec.seed, extent=half,
                                 spacing=spec.spacing)
    if spec.kind == 'noise':
        return HeightField.noise(spec.amplitude, spec.wavelength, spec.seed, extent=half, spacing=spec.spacing)
    return HeightField.from_file(spec.file, scale=spec.scale, spacing=spec.spacing)


def load_scene(name_or_path: str) -> Scene:
    """
    Read and validate a scene by name or path.

    SceneError (one line naming file and field) if missing or invalid. The file's size is bounded before it is parsed,
    its YAML structure (nesting, alias expansion, duplicate keys) before anything is built from it.
    """
    path = scene_path(name_or_path)
    if not path.is_file():
        raise SceneError(f'no scene {name_or_path!r} ({path} does not exist); '
                         f'shipped scenes: {", ".join(available_scenes())}')
    scene = parse_scene(read_yaml(path), str(path))
    if scene.name == 'unnamed':
        scene = dataclasses.replace(scene, name=path.stem if NAME_PATTERN.fullmatch(path.stem) else 'unnamed')
    return scene


def read_yaml(path: Path, what: str = 'scene'):
    """Return the parsed YAML of a `what` file read with the bounds of yaml_files.py; SceneError if unreadable."""
    return read_yaml_file(path, what, SceneError)
