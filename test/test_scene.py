"""Scene files: the shipped scenes load, defaults fill gaps, bad fields give errors naming file and field."""
import pytest

from iguana_ros.scene import Scene, SceneError, available_scenes, load_scene, parse_scene

REQUIRED = {'flat_walk', 'hills', 'hills_no_adaptation', 'push_normal', 'push_softer', 'goal_sequence'}


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
