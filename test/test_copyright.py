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
Copyright and license headers: ament_copyright where it is installed, else an equivalent check of our own.

ament_copyright comes with ROS from apt and has no wheel on PyPI. Without it the test checks what
ament_copyright checks here, a little more strictly: every non-empty .py file under iguana_ros/, test/,
launch/, examples/, tools/ and setup.py starts (after any shebang or encoding line) with
`# Copyright <year> iguana_ros developers` and the Apache-2.0 header of ament_copyright's apache2 template;
LICENSE is the Apache-2.0 text and CONTRIBUTING.md carries the template's contribution clause.
"""

import hashlib
from pathlib import Path
import re

import pytest

try:
    from ament_copyright.main import main as ament_copyright_main
except ImportError:  # ROS 2 from PyPI wheels
    ament_copyright_main = None

ROOT = Path(__file__).resolve().parents[1]
SOURCE_DIRS = ('iguana_ros', 'lab', 'test', 'launch', 'examples', 'tools')
SOURCE_FILES = ('setup.py',)
COPYRIGHT_LINE = re.compile(r'# Copyright \d{4}(-\d{4})? iguana_ros developers')
APACHE2_HEADER = """
Licensed under the Apache License, Version 2.0 (the "License");
you may not use this file except in compliance with the License.
You may obtain a copy of the License at

    http://www.apache.org/licenses/LICENSE-2.0

Unless required by applicable law or agreed to in writing, software
distributed under the License is distributed on an "AS IS" BASIS,
WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
See the License for the specific language governing permissions and
limitations under the License."""
HEADER_LINES = ['# ' + line if line else '#' for line in APACHE2_HEADER.split('\n')]
LICENSE_SHA256 = '0ffddef9e48f8a09aed5caf2d44f7ba1c1be2d9b8e0a6f693b1635b2d5566645'
"""SHA-256 of ament_copyright's apache2_license.txt with its whitespace collapsed to single spaces."""
CONTRIBUTING_CLAUSE = """
Any contribution that you make to this repository will be under the Apache 2 License, as dictated by that
[license](http://www.apache.org/licenses/LICENSE-2.0.html): ~~~ 5. Submission of Contributions. Unless You
explicitly state otherwise, any Contribution intentionally submitted for inclusion in the Work by You to the
Licensor shall be under the terms and conditions of this License, without any additional terms or conditions.
Notwithstanding the above, nothing herein shall supersede or modify the terms of any separate license agreement
you may have executed with Licensor regarding such Contributions. ~~~"""


def _normalised(text: str) -> str:
    return ' '.join(text.split())


def source_files(root: Path = ROOT) -> list[Path]:
    """Return the .py files to check, skipping folders that start with '.' or '_'."""
    files = [root / name for name in SOURCE_FILES if (root / name).is_file()]
    for folder in SOURCE_DIRS:
        files.extend(p for p in sorted((root / folder).rglob('*.py'))
                     if not any(part[0] in '._' for part in p.relative_to(root / folder).parts[:-1]))
    return files


def header_problem(path: Path) -> str | None:
    """Return what is wrong with the header of the file at `path`, None if nothing."""
    lines = path.read_text(encoding='utf-8').splitlines()
    if not any(line.strip() for line in lines):
        return None  # ament_copyright skips empty files too
    i = 0
    while i < len(lines) and (lines[i].startswith('#!') or re.match(r'#.*coding[:=]', lines[i])):
        i += 1
    while i < len(lines) and not lines[i].strip():
        i += 1
    if i == len(lines) or not COPYRIGHT_LINE.fullmatch(lines[i]):
        return 'no "# Copyright <year> iguana_ros developers" line'
    if lines[i + 1:i + 1 + len(HEADER_LINES)] != HEADER_LINES:
        return 'no Apache-2.0 license header after the copyright line'
    return None


def problems(root: Path = ROOT) -> list[str]:
    """Return the files under `root` that miss a header, and what is wrong with LICENSE and CONTRIBUTING.md."""
    out = [f'{p.relative_to(root)}: {why}' for p in source_files(root) if (why := header_problem(p))]
    license_file, contributing = root / 'LICENSE', root / 'CONTRIBUTING.md'
    if not license_file.is_file() or hashlib.sha256(
            _normalised(license_file.read_text()).encode()).hexdigest() != LICENSE_SHA256:
        out.append('LICENSE: not the Apache-2.0 license text')
    if not contributing.is_file() or _normalised(CONTRIBUTING_CLAUSE) not in _normalised(contributing.read_text()):
        out.append("CONTRIBUTING.md: without ament_copyright's Apache-2.0 contribution clause")
    return out


@pytest.mark.copyright
@pytest.mark.linter
def test_copyright(monkeypatch):
    """Every source file has the header (ament_copyright's verdict when it is installed)."""
    monkeypatch.chdir(ROOT)
    if ament_copyright_main is not None:
        assert ament_copyright_main(argv=['.', 'test']) == 0, 'Found errors'
        return
    found = problems()
    assert not found, f'{len(found)} copyright / license problems:\n' + '\n'.join(found)


@pytest.mark.copyright
@pytest.mark.linter
def test_fallback_check_fails_without_header(tmp_path):
    """The check of our own reports a file without the header, and accepts one after a shebang line."""
    (tmp_path / 'iguana_ros').mkdir()
    (tmp_path / 'iguana_ros' / 'bare.py').write_text('"""No header."""\n')
    header = '\n'.join(['# Copyright 2026 iguana_ros developers', *HEADER_LINES]) + '\n'
    (tmp_path / 'iguana_ros' / 'ok.py').write_text('#!/usr/bin/env python3\n\n' + header + '\n"""Fine."""\n')
    (tmp_path / 'iguana_ros' / 'half.py').write_text(header.split('\n# Unless')[0] + '\n')
    found = problems(tmp_path)
    assert found == ['iguana_ros/bare.py: no "# Copyright <year> iguana_ros developers" line',
                     'iguana_ros/half.py: no Apache-2.0 license header after the copyright line',
                     'LICENSE: not the Apache-2.0 license text',
                     "CONTRIBUTING.md: without ament_copyright's Apache-2.0 contribution clause"]
