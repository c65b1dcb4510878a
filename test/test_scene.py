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

"""Scene files: the shipped scenes load, defaults fill gaps, bad fields give errors naming file and field."""
import pytest

from iguana_ros.scene import (available_scenes, load_scene, MAX_DURATION, MAX_EXTENT, MAX_GOALS, MAX_NESTING,
                              MAX_PUSH_FORCE, MAX_PUSHES, MAX_RELIEF, MAX_SCENE_BYTES, MAX_YAML_NODES, parse_scene,
                              Scene, SceneError)
from iguana_ros.terrain.heightfield import MAX_GRID_NODES

REQUIRED = {'flat_walk', 'hills', 'hills_no_adaptation', 'push_normal', 'push_softer', 'goal_sequence', 'route_square'}


def test_shipped_scenes_load():
    assert REQUIRED <= set(available_scenes())
    for name in available_scenes():
        scene = load_scene(name)
        assert scene.name == name
        assert scene.duration > 0


def test_defaults_and_what_is_built():
    scene = parse_scene({})
    assert scene == Scene()
    assert not scene.needs_adaptation and not scene.needs_pushes
    assert load_scene('hills').needs_adaptation
    assert not load_scene('hills_no_adaptation').needs_adaptation
    assert not load_scene('flat_walk').needs_adaptation  # nothing to adapt to on flat ground
    softer = load_scene('push_softer')
    assert softer.needs_pushes and softer.model.stiffness == 'softer'
    assert softer.pushes[0].force == (0.0, -40.0, 0.0)


@pytest.mark.parametrize('raw, field, words', [
    ({'terain': {}}, "'terain'", 'unknown field'),
    ({'terrain': {'kind': 'lava'}}, "'terrain.kind'", 'flat, tilted, hills, heightmap'),
    ({'duration': -1}, "'duration'", 'positive'),
    ({'duration': float('nan')}, "'duration'", 'finite'),
    ({'duration': 'long'}, "'duration'", 'number'),
    ({'goals': [{'x': 1, 'y': 'a'}]}, "'goals[0].y'", 'number'),
    ({'goals': [{'x': 100.0}]}, "'goals[0]'", 'off the terrain'),
    ({'route': [{'x': 1.0}, {'x': 100.0}]}, "'route[1]'", 'waypoint (100, 0) is off the terrain'),
    ({'route': [{'x': 1.0}], 'goals': [{'x': 1.0}]}, "'route'", 'either goals or a route'),
    ({'goal_yaw_tolerance_deg': 0}, "'goal_yaw_tolerance_deg'", 'positive'),
    ({'goal_yaw_tolerance_deg': float('nan')}, "'goal_yaw_tolerance_deg'", 'finite'),
    ({'goals': [{'x': 1.0, 'yaw_deg': 400}]}, "'goals[0].yaw_deg'", 'within [-360, 360]'),
    ({'pushes': [{'force': [1, 2]}]}, "'pushes[0].force'", '3 numbers'),
    ({'pushes': [{'region': 'wing'}]}, "'pushes[0].region'", 'trunk_left'),
    ({'adaptation': 'yes'}, "'adaptation'", 'true or false'),
    ({'model': {'resolution': 'ultra'}}, "'model.resolution'", 'coarse, medium, fine'),
    ({'terrain': {'kind': 'heightmap'}}, "'terrain.file'", 'needs a file'),
    ([1, 2], "'<top level>'", 'mapping'),
])
def test_bad_fields_are_named(raw, field, words):
    with pytest.raises(SceneError) as info:
        parse_scene(raw, 'my.yaml')
    message = str(info.value)
    assert message.startswith('my.yaml: field ' + field) and words in message


def test_broken_and_missing_files(tmp_path):
    broken = tmp_path / 'broken.yaml'
    broken.write_text('terrain: {kind: flat\nduration: [')
    with pytest.raises(SceneError, match='broken.yaml: not a readable YAML scene'):
        load_scene(str(broken))
    with pytest.raises(SceneError, match='shipped scenes: .*hills'):
        load_scene('no_such_scene')
    binary = tmp_path / 'bin.yaml'
    binary.write_bytes(b'\xff\xfe\x00\x01')
    with pytest.raises(SceneError, match='bin.yaml'):
        load_scene(str(binary))


# --- issue 12 item 5: resource limits and hostile YAML; item 6: empty files -----------------------------------

def _load_text(tmp_path, text, name='s.yaml'):
    path = tmp_path / name
    path.write_text(text) if isinstance(text, str) else path.write_bytes(text)
    return load_scene(str(path))


def _one_line_error(tmp_path, text, name='s.yaml') -> str:
    """Return the SceneError message of loading `text`; asserts it is one bounded line naming the file."""
    with pytest.raises(SceneError) as info:
        _load_text(tmp_path, text, name)
    message = str(info.value)
    assert '\n' not in message and len(message) < 400, message
    assert name in message
    return message


def test_deep_nesting_is_one_line_not_a_recursion_error(tmp_path):
    message = _one_line_error(tmp_path, 'terrain: ' + '[' * 5000 + ']' * 5000 + '\n')
    assert 'nest' in message   # libyaml's own flow-depth limit or MAX_NESTING
    message = _one_line_error(tmp_path, 'a:\n' + ''.join(' ' * (2 * i) + f'  k{i}:\n' for i in range(200)))
    assert 'nested deeper than' in message and str(MAX_NESTING) in message


@pytest.mark.parametrize('terrain, field', [
    ({'kind': 'hills', 'extent': 1.0e7, 'spacing': 0.001}, "'terrain.extent'"),   # 284 PiB before the fix
    ({'kind': 'hills', 'extent': 900.0, 'wavelength': 0.01}, "'terrain.wavelength'"),  # hills sample wavelength/16
    ({'kind': 'noise', 'extent': 100.0, 'spacing': 0.001, 'wavelength': 1.0}, "'terrain.spacing'"),
    ({'kind': 'hills', 'wavelength': 5e-324}, "'terrain.wavelength'"),       # spacing 0: ZeroDivisionError before
    ({'kind': 'hills', 'wavelength': 1e-300}, "'terrain.wavelength'"),       # an 800-digit node count before
    ({'kind': 'steps', 'extent': 1000.0, 'spacing': 1e-306, 'block_size': 1.0}, "'terrain.spacing'"),  # inf cells
])
def test_terrain_grid_size_is_bounded_by_the_schema(terrain, field):
    with pytest.raises(SceneError) as info:
        parse_scene({'terrain': terrain}, 'big.yaml')
    message = str(info.value)
    assert message.startswith('big.yaml: field ' + field) and 'at most' in message and len(message) < 300


@pytest.mark.parametrize('raw, field, limit', [
    ({'duration': 1.0e9}, "'duration'", f'{MAX_DURATION:g}'),
    ({'goals': [{'x': 1.0}] * (MAX_GOALS + 1)}, "'goals'", str(MAX_GOALS)),
    ({'pushes': [{'at': 1.0}] * (MAX_PUSHES + 1)}, "'pushes'", str(MAX_PUSHES)),
    ({'goals': [{'x': 1.0, 'at': 1.0e12}]}, "'goals[0].at'", f'{MAX_DURATION:g}'),
    ({'pushes': [{'duration': 1.0e12}]}, "'pushes[0].duration'", f'{MAX_DURATION:g}'),
    ({'pushes': [{'force': [0.0, 1.0e6, 0.0]}]}, "'pushes[0].force'", f'{MAX_PUSH_FORCE:g}'),
    ({'terrain': {'extent': 1.0e6}}, "'terrain.extent'", f'{MAX_EXTENT:g}'),
    ({'terrain': {'kind': 'hills', 'amplitude': 1.0e300}}, "'terrain.amplitude'", f'{MAX_RELIEF:g}'),
    ({'terrain': {'kind': 'hills', 'seed': -1}}, "'terrain.seed'", '>= 0'),
    ({'terrain': {'kind': 'hills', 'seed': 10 ** 400}}, "'terrain.seed'", 'at most'),
    ({'duration': 10 ** 400}, "'duration'", 'at most'),
    ({'start': {'x': 1.0e300}}, "'start'", 'off the terrain'),
    ({'start': {'yaw_deg': 1.0e300}}, "'start.yaw_deg'", '360'),
    ({'record': {'mesh_every_n_frames': 10 ** 12}}, "'record.mesh_every_n_frames'", 'at most'),
    ({'record': {'topics': ['all', 'no_such_topic']}}, "'record.topics[1]'", 'topics.yaml (e.g. iguana_state'),
    ({'name': '../../escape'}, "'name'", 'letters'),
    ({'pushes': [{'at': 1.0, 'force': [600.0, 0.0, 0.0]}, {'at': 1.05, 'force': [0.0, 600.0, 0.0]}]},
     "'pushes[1].force'", f'{MAX_PUSH_FORCE:g} N'),                                         # 1200 N acting at once
])
def test_limits_are_named_with_the_field_and_the_limit(raw, field, limit):
    with pytest.raises(SceneError) as info:
        parse_scene(raw, 'my.yaml')
    message = str(info.value)
    assert message.startswith('my.yaml: field ' + field) and limit in message, message
    assert len(message) < 400


def test_billion_laughs_is_refused_quickly(tmp_path, monkeypatch):
    """
    A file of 10**10 nodes through its aliases is refused from the parser's events of its text, none composed.

    The work done is bounded by the text (at most its ~200 events read), not by the expansion: no wall-clock bound.
    """
    import yaml
    lines = ['a0: &a0 [x, x, x, x, x, x, x, x, x, x]']
    lines += [f'a{i}: &a{i} [' + ', '.join([f'*a{i - 1}'] * 10) + ']' for i in range(1, 10)]
    text = '\n'.join(lines) + '\nduration: *a9\n'
    in_text = sum(1 for _ in yaml.parse(text))
    read, composed = [], []
    parse = yaml.parse

    def counted_parse(*args, **kwargs):
        for event in parse(*args, **kwargs):
            read.append(event)
            yield event
    monkeypatch.setattr(yaml, 'parse', counted_parse)
    monkeypatch.setattr(yaml, 'load', lambda *args, **kwargs: composed.append(args))
    message = _one_line_error(tmp_path, text)
    assert f'expands to more than {MAX_YAML_NODES} YAML nodes' in message, message
    assert 0 < len(read) <= in_text < 300 and not composed, (len(read), in_text)


def test_an_alias_to_a_bad_value_gives_a_short_message(tmp_path):
    lines = ['x0: &x0 [1, 2, 3, 4, 5, 6, 7, 8]'] + [f'x{i}: &x{i} [*x{i - 1}, *x{i - 1}]' for i in range(1, 6)]
    message = _one_line_error(tmp_path, '\n'.join(lines) + '\n')
    assert "field 'x0'" in message and 'unknown field' in message


def test_duplicate_keys_are_named(tmp_path):
    message = _one_line_error(tmp_path, 'duration: 5.0\nterrain: {kind: flat}\nduration: 7.0\n')
    assert "field 'duration'" in message and 'duplicate' in message and 'line 3' in message
    message = _one_line_error(tmp_path, 'goals:\n  - {x: 1.0, y: 0.0, x: 2.0}\n')
    assert "field 'goals[0].x'" in message and 'duplicate' in message
    merged = _load_text(tmp_path, 'goals:\n  - &g {x: 1.0, y: 0.5, at: 0.0}\n  - {<<: *g, at: 3.0}\n')
    assert merged.goals[1].x == 1.0 and merged.goals[1].at == 3.0   # a merge key overridden is no duplicate


@pytest.mark.parametrize('text', ['', '\n\n   \n', '# only a comment\n', '~\n', b'\xef\xbb\xbf'])
def test_an_empty_scene_file_is_an_error(tmp_path, text):
    message = _one_line_error(tmp_path, text, 'empty.yaml')
    assert 'empty' in message


def test_a_huge_scene_file_is_refused_before_parsing(tmp_path):
    message = _one_line_error(tmp_path, '# ' + 'x' * (MAX_SCENE_BYTES + 10) + '\n', 'huge.yaml')
    assert str(MAX_SCENE_BYTES) in message


@pytest.mark.parametrize('data', [b'duration: \xff\xfe\n', b'name: a\x00b\n', b'\x00\x01\x02\x03' * 64,
                                  'duration: 10.0\n'.encode('utf-16')])
def test_wrong_encodings_are_one_line(tmp_path, data):
    try:
        scene = _load_text(tmp_path, data, 'enc.yaml')
    except SceneError as exc:
        assert '\n' not in str(exc) and 'enc.yaml' in str(exc)
    else:
        assert scene.duration == 10.0  # UTF-16 with a BOM is valid YAML


def test_mixed_type_keys_and_odd_yaml_values_are_one_line(tmp_path):
    assert 'unknown field' in _one_line_error(tmp_path, '1: 2\nfoo: 3\n')
    assert "'duration'" in _one_line_error(tmp_path, 'duration: 2001-01-01\n')
    assert "'duration'" in _one_line_error(tmp_path, 'duration: ' + '9' * 5000 + '\n')  # > int-string limit
    assert "'terrain'" in _one_line_error(tmp_path, 'terrain: !!binary aGVsbG8=\n')
    assert 'YAML' in _one_line_error(tmp_path, 'a: !!python/object:os.system [ls]\n')
    long_value = _one_line_error(tmp_path, 'description: [' + ', '.join(['1'] * 5000) + ']\n')
    assert "'description'" in long_value
    assert _load_text(tmp_path, 'description: ' + 'abcdef' * 300 + '\n').description == 'abcdef' * 300


def test_heightmap_file_is_checked_before_loading(tmp_path):
    import numpy as np
    big = tmp_path / 'big.npy'
    side = int(MAX_GRID_NODES ** 0.5) + 10
    with open(big, 'wb') as f:   # a header promising side x side float64 values; the data is never read
        np.lib.format.write_array_header_1_0(f, {'descr': '<f8', 'fortran_order': False, 'shape': (side, side)})
    with pytest.raises(SceneError) as info:
        parse_scene({'terrain': {'kind': 'heightmap', 'file': str(big)}}, 'hm.yaml')
    assert str(info.value).startswith("hm.yaml: field 'terrain.file'") and 'at most' in str(info.value)
    with pytest.raises(SceneError, match="hm.yaml: field 'terrain.file': .*does not exist"):
        parse_scene({'terrain': {'kind': 'heightmap', 'file': str(tmp_path / 'none.npy')}}, 'hm.yaml')
    small = tmp_path / 'small.npy'
    np.save(small, np.zeros((30, 20)))
    assert parse_scene({'terrain': {'kind': 'heightmap', 'file': str(small)}}).terrain.file == str(small)


def test_heightfield_refuses_huge_grids_and_files_itself(tmp_path):
    import numpy as np

    from iguana_ros.errors import InputError
    from iguana_ros.terrain.heightfield import HeightField
    with pytest.raises(InputError, match='at most'):
        HeightField.hills(extent=5.0e6, wavelength=0.01)
    big = tmp_path / 'big.npy'
    with open(big, 'wb') as f:
        np.lib.format.write_array_header_1_0(f, {'descr': '<f8', 'fortran_order': False, 'shape': (10 ** 5, 10 ** 5)})
    with pytest.raises(InputError, match='at most'):
        HeightField.from_file(big)


def test_goal_headings_routes_and_an_infinite_yaw_tolerance():
    scene = parse_scene({'goals': [{'x': 1.0, 'yaw_deg': 90}, {'x': 2.0, 'yaw_deg': None}, {'x': 3.0}],
                         'goal_yaw_tolerance_deg': float('inf')}, 'test')
    assert [g.yaw_deg for g in scene.goals] == [90.0, None, None] and scene.goal_yaw_tolerance_deg == float('inf')
    assert scene.destination == scene.goals[-1]
    route = parse_scene({'route': [{'x': 1.0, 'y': 0.5}, {'x': 2.0, 'y': -1.0, 'yaw_deg': -45}]}, 'test')
    assert route.destination.x == 2.0 and route.destination.yaw_deg == -45.0 and route.route[0].yaw_deg is None
    assert parse_scene({}, 'test').destination is None


def test_a_node_serves_the_character_its_namespace_or_parameter_names_and_a_simulator_the_whole_world():
    from iguana_ros.scene import served_characters
    world = load_scene('crossing')
    assert [n for n, _ in served_characters(world, 'auto', '/north', world=False)] == ['north']
    assert [n for n, _ in served_characters(world, 'auto', '/runs/north', world=False)] == ['north']
    assert [n for n, _ in served_characters(world, 'west', '/', world=False)] == ['west']
    one = served_characters(world, 'auto', '/east', world=True)[0][1]
    assert one.characters == () and one.start.x == 1.2 and one.goals[0].x == -1.2
    assert [n for n, _ in served_characters(world, 'auto', '/', world=True)] == ['east', 'north', 'west', 'south']
    with pytest.raises(SceneError, match=r'4 characters \(east, north, west, south\).*-r __ns:=/NAME'):
        served_characters(world, 'auto', '/', world=False)
    with pytest.raises(SceneError, match="character 'nobody' is not in scene crossing"):
        served_characters(world, 'nobody', '/', world=True)
    lone = load_scene('hills')
    assert served_characters(lone, 'auto', '/iguana1', world=False) == [('iguana', lone)]
