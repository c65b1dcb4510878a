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

"""iguana_ros: soft-body iguana character control (Kwon, Kim, Lee, IEEE Access 2018) for ROS 2."""
from __future__ import annotations


def package_version() -> str:
    """
    Return the version of package.xml (setup.py copies it into the distribution's metadata).

    The installed distribution's, else the one in package.xml beside a plain source tree.
    """
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version('iguana_ros')
    except PackageNotFoundError:
        import xml.etree.ElementTree as ET
        from pathlib import Path
        return ET.parse(Path(__file__).resolve().parent.parent / 'package.xml').getroot().findtext('version')


def __getattr__(name: str) -> str:
    """`iguana_ros.__version__`, read when asked for (nothing is read at import)."""
    if name == '__version__':
        return package_version()
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
