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

"""tools/bench_turns.py: each side runs its own checkout's code, pairs alternate, medians per field."""
from pathlib import Path
import subprocess
import sys

import pytest

from ros_harness import tool_module

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope='module')
def turns():
    """Load the tool as a module (tools/ is not a package)."""
    return tool_module('bench_turns')


def test_a_run_in_a_checkout_imports_that_checkout(turns, tmp_path):
    """The cause of measuring the same code twice: PYTHONPATH loses to the current directory under `python -m`."""
    tree = turns.checkout('HEAD', tmp_path / 'clone')
    assert (tree / 'iguana_ros' / '__init__.py').is_file()
    assert turns.imported_package(tree) == (tree / 'iguana_ros').resolve()
    assert turns.imported_package(REPO) == (REPO / 'iguana_ros').resolve()
    env_path = subprocess.run([sys.executable, '-c', 'import sys; print(sys.path[1])'], cwd=tmp_path, text=True,
                              capture_output=True, env={'PYTHONPATH': str(tree)})
    assert env_path.stdout.strip() == str(tree)         # PYTHONPATH comes after the current directory ('')


def test_a_tree_that_imports_another_package_is_refused(turns, tmp_path):
    """A tree without its own iguana_ros would measure whatever the environment installs: a clear error instead."""
    (tmp_path / 'iguana_ros').mkdir()                  # a checkout whose package is missing its files
    with pytest.raises(turns.TurnsError, match='not its own iguana_ros|cannot import'):
        turns.prepare(tmp_path)


def test_an_unknown_revision_is_one_clear_error(turns, tmp_path):
    """`--base` that git does not know: TurnsError naming it; main exits 1 with one line."""
    with pytest.raises(turns.TurnsError, match='no-such-rev'):
        turns.checkout('no-such-rev', tmp_path / 'x')
    done = subprocess.run([sys.executable, str(REPO / 'tools' / 'bench_turns.py'), '--base', 'no-such-rev', '--pairs',
                           '1', '--', 'sim'], capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 1
    assert done.stderr.count('\n') == 1 and 'no-such-rev' in done.stderr


def test_pairs_alternate_and_medians_are_per_side(turns):
    """Base first, then head first; medians of each side; only fields every run has; booleans are not figures."""
    assert [turns.pair_order(i) for i in range(3)] == [('base', 'head'), ('head', 'base'), ('base', 'head')]
    assert turns.numeric_fields({'a': 1, 'b': 2.5, 'ok': True, 'name': 'x', 'd': {'e': 1}}) == {'a': 1.0, 'b': 2.5}
    runs = {'base': [{'rtf': 1.0, 'x': 1.0}, {'rtf': 3.0, 'x': 1.0}, {'rtf': 2.0}],
            'head': [{'rtf': 4.0, 'x': 2.0}, {'rtf': 6.0, 'x': 2.0}, {'rtf': 5.0, 'x': 2.0}]}
    table = turns.summary(runs)
    assert list(table) == ['rtf']
    assert table['rtf']['base_median'] == 2.0 and table['rtf']['head_median'] == 5.0
    assert table['rtf']['base'] == [1.0, 3.0, 2.0]
    assert 'rtf' in turns.report(table, 'abc', 'worktree') and '2 -> ' in turns.report(table, 'abc', 'worktree')
