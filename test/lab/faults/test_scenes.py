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
Scene fault injection, the short version of `iguana bench faults scenes` (issue 12).

300 seeded mutations of the shipped scenes each load as a valid Scene within the limits or fail with one SceneError line
naming the file (and the damaged field), quickly and in bounded memory; a sample runs through the real `iguana simulate`
in subprocesses under an address-space limit: exit 1 with one line for an invalid scene, never a traceback.
"""
import json

from iguana_lab.faults.scene_files import CLI_RSS_LIMIT, mutations, MUTATORS, run_suite
from iguana_ros.cli import main


def test_300_scene_mutations_load_or_fail_with_one_line():
    result = run_suite(trials=300, seed=12, cli_sample=12, workers=2)
    assert result['trials'] == 300 and result['crashed'] == 0
    assert result['failures'] == [], result['failures'][:3]
    assert result['survived'] == 300
    assert set(result['by_kind']) == set(MUTATORS) and all(c['trials'] >= 20 for c in result['by_kind'].values())
    assert result['valid'] > 0 and result['rejected'] > 200     # both outcomes are exercised
    assert result['cli_failures'] == [], result['cli_failures'][:3]
    assert result['cli_trials'] == 12 and result['cli_rejected'] >= 10
    assert 0 < result['cli_max_peak_rss_mb'] < CLI_RSS_LIMIT / 2 ** 20


def test_mutations_are_seeded():
    first, again, other = mutations(28, 5), mutations(28, 5), mutations(28, 6)
    assert [m.data for m in first] == [m.data for m in again]
    assert [m.data for m in first] != [m.data for m in other]


def test_bench_command(capsys):
    assert main(['bench', 'faults', 'scenes', '--trials', '28', '--cli-sample', '0', '--json']) == 0
    result = json.loads(capsys.readouterr().out)
    assert result['trials'] == result['survived'] == 28 and result['cli_trials'] == 0
