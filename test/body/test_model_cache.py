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

"""The on-disk model cache: location, keys, reuse, and recovery from a corrupt file."""
import numpy as np
import pytest

from iguana_ros.body import model as model_mod


@pytest.fixture()
def cache_env(tmp_path, monkeypatch):
    monkeypatch.setenv('IGUANA_CACHE_DIR', str(tmp_path / 'cache'))
    return tmp_path / 'cache'


def test_cache_dir_follows_environment(tmp_path, monkeypatch):
    monkeypatch.delenv('IGUANA_CACHE_DIR', raising=False)
    monkeypatch.setenv('XDG_CACHE_HOME', str(tmp_path / 'xdg'))
    assert model_mod.cache_dir() == tmp_path / 'xdg' / 'iguana_ros'
    monkeypatch.setenv('IGUANA_CACHE_DIR', str(tmp_path / 'mine'))
    assert model_mod.cache_dir() == tmp_path / 'mine'


def test_key_changes_with_inputs(monkeypatch):
    coarse, medium = model_mod.cache_key('coarse'), model_mod.cache_key('medium')
    assert coarse != medium and coarse == model_mod.cache_key('coarse')
    monkeypatch.setattr(model_mod, 'FORMAT_VERSION', model_mod.FORMAT_VERSION + 1)
    assert model_mod.cache_key('coarse') != coarse


def test_built_once_then_loaded_and_corrupt_file_rebuilt(cache_env, monkeypatch):
    calls = []
    real_build = model_mod.build_geometry

    def counting_build(resolution):
        calls.append(resolution)
        return real_build(resolution)

    monkeypatch.setattr(model_mod, 'build_geometry', counting_build)
    first, cached = model_mod.load_or_build_geometry('coarse')
    assert not cached and calls == ['coarse']
    path = model_mod.cache_path('coarse')
    assert path.exists() and path.parent == cache_env
    second, cached = model_mod.load_or_build_geometry('coarse')
    assert cached and calls == ['coarse']
    for key in ('rest_positions', 'tets', 'springs', 'skin_weights', 'tag_masks'):
        assert np.array_equal(first[key], second[key])
    path.write_bytes(b'not a zip file')
    with pytest.warns(UserWarning, match='unreadable'):
        third, cached = model_mod.load_or_build_geometry('coarse')
    assert not cached and calls == ['coarse', 'coarse']
    assert np.array_equal(third['tets'], first['tets'])   # the build is deterministic
    assert model_mod.load_or_build_geometry('coarse')[1]  # and the rewritten file loads again
