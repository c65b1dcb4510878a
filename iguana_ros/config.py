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

"""Locating the package's configuration folder `msg_configs/` (source tree, pip or colcon install)."""
from __future__ import annotations

import os
from pathlib import Path
import sys

CONFIG_ENV = 'IGUANA_CONFIG_DIR'
"""Environment variable that overrides where msg_configs/ is read from."""


def config_dir() -> Path:
    """
    Return the msg_configs/ folder.

    $IGUANA_CONFIG_DIR, the source tree, <prefix>/share/iguana_ros, or the ament index.
    """
    override = os.environ.get(CONFIG_ENV)
    if override:
        return Path(override)
    return shared_path('msg_configs', hint=f'; set {CONFIG_ENV}')


def shared_path(*parts: str, hint: str = '') -> Path:
    """
    Return a file or folder the package installs under share/iguana_ros/.

    These are msg_configs/, rviz/iguana.rviz and foxglove/iguana_layout.json, found in the source tree, in
    <prefix>/share/iguana_ros (pip), or through the ament index (colcon); FileNotFoundError names where it looked.
    """
    source = Path(__file__).resolve().parent.parent.joinpath(*parts)
    if source.exists():
        return source
    prefix_share = Path(sys.prefix).joinpath('share', 'iguana_ros', *parts)  # pip install (non-editable)
    if prefix_share.exists():
        return prefix_share
    try:
        from ament_index_python.packages import get_package_share_directory
        return Path(get_package_share_directory('iguana_ros')).joinpath(*parts)
    except Exception as exc:  # ament index missing or package not registered
        raise FileNotFoundError(
            f'cannot find {"/".join(parts)}: not in the source tree ({source}) and not installed '
            f'under share/iguana_ros ({exc}){hint}') from exc


def config_path(*parts: str) -> Path:
    """
    Return a path inside msg_configs/.

    E.g. config_path('scenes', 'hills.yaml').
    """
    return config_dir().joinpath(*parts)


def params_file() -> Path:
    """
    Return the standard ROS params file of every node (`--params-file`).

    `iguana run` and launch/iguana.launch.py give it to each node.
    """
    return config_path('params', 'iguana.yaml')
