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
ament_flake8 over the package's Python: ament's configuration with setup.cfg's [flake8] on top.

A --config passed to flake8 replaces every other configuration file, so the test writes ament_flake8.ini
with setup.cfg's [flake8] options (max-line-length, import-order-style, application-import-names) merged in,
and passes that file and the line length.
"""

import configparser
from pathlib import Path

import ament_flake8
from ament_flake8.main import main_with_errors
import pytest

ROOT = Path(__file__).resolve().parents[1]
PATHS = ['iguana_ros', 'lab', 'test', 'launch', 'examples', 'setup.py', 'tools']


def merged_config(path: Path) -> tuple[Path, int]:
    """Write ament_flake8.ini with setup.cfg's [flake8] options to `path`; return it and the line length."""
    ament = configparser.ConfigParser()
    ament.read(Path(ament_flake8.__file__).parent / 'configuration' / 'ament_flake8.ini')
    ours = configparser.ConfigParser()
    ours.read(ROOT / 'setup.cfg')
    for key, value in ours['flake8'].items():
        ament['flake8'][key] = value
    # one process: flake8's pool forks this pytest worker, and a fork of a process that has run rclpy (DDS threads)
    # segfaults in its children's garbage collection, which the pool respawns forever (seen with -n 2 beside node tests)
    ament['flake8']['jobs'] = '1'
    with path.open('w') as f:
        ament.write(f)
    return path, int(ours['flake8']['max-line-length'])


@pytest.mark.flake8
@pytest.mark.linter
def test_flake8(tmp_path, monkeypatch):
    """Every checked file is clean, as `ament_flake8` with the merged configuration sees it."""
    config, line_length = merged_config(tmp_path / 'flake8.ini')
    monkeypatch.chdir(ROOT)
    rc, errors = main_with_errors(argv=['--config', str(config), '--linelength', str(line_length), *PATHS])
    assert rc == 0, f'Found {len(errors)} code style errors / warnings:\n' + '\n'.join(errors)
