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

"""The generated `steps` and `noise` terrains: determinism per seed, ranges, the flat pad, scene fields."""
import numpy as np
import pytest

from iguana_ros.errors import InputError
from iguana_ros.scene import parse_scene, SceneError, terrain_from_spec, TerrainSpec
from iguana_ros.terrain.heightfield import HeightField, STEPS_PAD_RADIUS


def _node_xy(hf: HeightField) -> np.ndarray:
    """World coordinates `(nx, ny, 2)` of the grid nodes."""
    nx, ny = hf.heights.shape
    gx, gy = np.meshgrid(hf.origin[0] + hf.spacing * np.arange(nx), hf.origin[1] + hf.spacing * np.arange(ny),
                         indexing='ij')
    return np.stack([gx, gy], axis=-1)


@pytest.mark.parametrize('make', [
    lambda seed: HeightField.steps(seed=seed, extent=2.0),
    lambda seed: HeightField.noise(0.05, 0.6, seed, extent=2.0),
])
def test_deterministic_per_seed(make):
    assert np.array_equal(make(4).heights, make(4).heights)
    assert not np.array_equal(make(4).heights, make(5).heights)


def test_steps_blocks_within_range_constant_per_block_and_flat_pad():
    hf = HeightField.steps(block_size=0.3, step_min=0.03, step_max=0.05, seed=2, extent=3.0, spacing=0.05)
    xy = _node_xy(hf)
    r = np.linalg.norm(xy, axis=-1)
    pad, blocks = hf.heights[r <= STEPS_PAD_RADIUS], hf.heights[r > STEPS_PAD_RADIUS]
    assert np.all(pad == 0.0) and pad.size > 150
    assert blocks.min() >= 0.03 and blocks.max() <= 0.05 and np.ptp(blocks) > 0.015
    # inside one block (away from its edges and the pad) the ground is level: bilinear of equal nodes
    inner = np.array([[1.21, 0.61], [1.44, 0.84], [1.25, 0.75]])   # block [1.2, 1.5) x [0.6, 0.9) less its
    # last grid cell on each axis, where the bilinear ramp to the next block lies
    h = hf.height(inner)
    assert np.ptp(h) == 0.0 and 0.03 <= h[0] <= 0.05
    np.testing.assert_array_equal(hf.gradient(inner), 0.0)
    # each block draws its own height, and an edge is a ramp over the one grid cell before it
    centres = (np.arange(-9, 9) + 0.5) * 0.3
    heights = hf.height(np.stack(np.meshgrid(centres, centres, indexing='ij'), axis=-1))
    assert len(np.unique(heights)) > 300
    edge = hf.height(np.array([[1.5 - 0.05, 0.75], [1.5, 0.75]]))
    assert edge[0] == h[0] and edge[1] != h[0]


def test_noise_amplitude_zero_mean_and_smooth():
    hf = HeightField.noise(amplitude=0.07, wavelength=0.8, seed=1, extent=3.0, spacing=0.05)
    assert np.max(np.abs(hf.heights)) == pytest.approx(0.07)
    assert abs(hf.heights.mean()) < 1e-12
    assert not hf.is_flat
    # smooth at the wavelength: neighbouring nodes are strongly correlated, far ones are not
    h = hf.heights
    near = np.corrcoef(h[:-1].ravel(), h[1:].ravel())[0, 1]
    far = np.corrcoef(h[:-16].ravel(), h[16:].ravel())[0, 1]   # 0.8 m apart
    assert near > 0.9 and abs(far) < 0.3


@pytest.mark.parametrize('make, words', [
    (lambda: HeightField.steps(step_min=0.05, step_max=0.03), 'step_min <= step_max'),
    (lambda: HeightField.steps(block_size=0.0), 'block_size'),
    (lambda: HeightField.noise(amplitude=-0.01), 'amplitude'),
    (lambda: HeightField.noise(wavelength=0.1, spacing=0.05), 'spacing of at most'),
])
def test_constructor_errors(make, words):
    with pytest.raises(InputError, match=words):
        make()


@pytest.mark.parametrize('terrain', [
    {'kind': 'steps', 'block_size': 0.25, 'step_min': 0.02, 'step_max': 0.04, 'seed': 3, 'extent': 4.0},
    {'kind': 'noise', 'amplitude': 0.06, 'wavelength': 0.7, 'seed': 3, 'extent': 4.0, 'spacing': 0.04},
])
def test_scene_yaml_parses_and_builds(terrain):
    import yaml

    text = f'name: t\nterrain: {yaml.safe_dump(terrain, default_flow_style=True)}goals: [{{x: 1.0, y: 0.0}}]\n'
    scene = parse_scene(yaml.safe_load(text), 't.yaml')
    assert scene.terrain == TerrainSpec(**terrain)
    hf = terrain_from_spec(scene.terrain)
    assert hf.extent[0] == pytest.approx(-2.0) and hf.extent[1] >= 2.0
    assert hf.spacing == pytest.approx(scene.terrain.spacing) and not hf.is_flat


@pytest.mark.parametrize('terrain, field, words', [
    ({'kind': 'steps', 'block_size': -0.3}, "'terrain.block_size'", 'positive'),
    ({'kind': 'steps', 'step_min': -0.01}, "'terrain.step_min'", '>= 0'),
    ({'kind': 'steps', 'step_min': 0.06}, "'terrain.step_max'", '>= step_min'),
    ({'kind': 'steps', 'block_size': 0.01}, "'terrain.block_size'", '>= spacing'),
    ({'kind': 'steps', 'step_max': 'high'}, "'terrain.step_max'", 'number'),
    ({'kind': 'noise', 'amplitude': -0.1}, "'terrain.amplitude'", '>= 0'),
    ({'kind': 'noise', 'wavelength': 0.1}, "'terrain.wavelength'", '4 x spacing'),
    ({'kind': 'noise', 'spacing': 0.0001}, "'terrain.spacing'", 'grid nodes'),
    ({'kind': 'noise', 'seed': 1.5}, "'terrain.seed'", 'integer'),
])
def test_bad_fields_are_one_line_naming_the_field(terrain, field, words):
    with pytest.raises(SceneError) as info:
        parse_scene({'terrain': terrain}, 'bad.yaml')
    message = str(info.value)
    assert message.startswith('bad.yaml: field ' + field) and words in message and '\n' not in message
