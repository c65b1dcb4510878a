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

"""`ruff check` over the package's Python with the repository's ruff.toml."""
from pathlib import Path
import shutil
import subprocess
import sys

import pytest

ROOT = Path(__file__).resolve().parents[1]
PATHS = ['iguana_ros', 'lab', 'test', 'launch', 'examples', 'setup.py', 'tools']


@pytest.mark.linter
def test_ruff():
    """Every checked file is clean as `ruff check` sees it (rules in ruff.toml)."""
    ruff = shutil.which('ruff', path=str(Path(sys.executable).parent)) or shutil.which('ruff')
    assert ruff, 'ruff is not installed: make install (the test extras) installs it'
    done = subprocess.run([ruff, 'check', '--no-cache', '--config', str(ROOT / 'ruff.toml'), *PATHS], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
