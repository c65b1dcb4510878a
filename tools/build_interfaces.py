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
Build the interface packages under interfaces/ into the Python environment that runs this script.

`make install` runs it as `.venv/bin/python tools/build_interfaces.py` after
`pip install -e '.[ros,test,interfaces]'`. The ROS 2 Jazzy wheels on PyPI carry no tf2_msgs, and no
package of ours can come from them, so each package of PACKAGES is built here with CMake, ament_cmake
and rosidl_default_generators (the `interfaces` extra of setup.py), against the message packages the
wheels installed, exactly as a colcon build would: C and C++ type support (introspection and Fast DDS),
the Python classes and their C extension modules.

It installs into the environment's prefix, the way the wheels lay themselves out:
`<prefix>/lib/lib<pkg>__rosidl_*.so`, `<site-packages>/<pkg>/` (the Python package with
`<pkg>_s__rosidl_typesupport_c.so` and friends, which rclpy imports for the type support),
`<prefix>/share/<pkg>/` (the .msg/.srv/.action/.idl files, which iguana_ros/bag/schema.py reads for
MCAP schemas) and `<prefix>/share/ament_index/`. The libraries get a RUNPATH to `<prefix>/lib`, so they
load without LD_LIBRARY_PATH (the wheels' own libraries are found through the LD_LIBRARY_PATH that
ros_wheels_bootstrapper sets for every Python of the environment): nothing is to be sourced at run time.

Build trees go to build/interfaces/<pkg>/ (CMake's install_manifest.txt there lists what was installed;
`--uninstall` removes those files). Environment variables of a sourced ROS installation
(AMENT_PREFIX_PATH, CMAKE_PREFIX_PATH, ...) are left out of the build, so it uses only the environment's
wheels. Exit status 0 when every package built, installed and imported with its type support.
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path
import re
import shutil
import subprocess
import sys
import sysconfig
import time

REPO = Path(__file__).resolve().parent.parent
SOURCES = REPO / 'interfaces'
PACKAGES = ('tf2_msgs', 'iguana_interfaces')
"""Interface packages under interfaces/, in build order."""
FIXUPS = SOURCES / 'cmake' / 'pypi_wheel_fixups.cmake'
CHECKS = {
    'tf2_msgs': ('tf2_msgs.msg.TFMessage', 'tf2_msgs.msg.TF2Error', 'tf2_msgs.srv.FrameGraph',
                 'tf2_msgs.action.LookupTransform'),
    'iguana_interfaces': ('iguana_interfaces.action.GoToPose', 'iguana_interfaces.srv.Step'),
}
"""Types imported, with their type support, after the install."""
BUILD_MODULES = ('catkin_pkg', 'ament_package', 'em', 'lark', 'numpy')
"""Python modules the CMake build runs (package.xml parsing, the rosidl templates and parser, NumPy headers)."""
BUILD_PACKAGES = ('ament_cmake', 'ament_cmake_ros', 'rosidl_default_generators', 'python_cmake_module',
                  'geometry_msgs', 'action_msgs')
"""CMake packages that must be in the prefix's share/ before a build."""
ROS_ENVIRONMENT = ('AMENT_PREFIX_PATH', 'CMAKE_PREFIX_PATH', 'COLCON_PREFIX_PATH', 'PYTHONPATH', 'ROS_PACKAGE_PATH')
MIN_CMAKE = (3, 19)
"""cmake_language(DEFER) in pypi_wheel_fixups.cmake."""


class BuildError(Exception):
    """A step failed; the message says which and what to do."""


def _missing_requirements(prefix: Path) -> list[str]:
    """Return what the build needs and the environment lacks."""
    missing = []
    for module in BUILD_MODULES:
        found = subprocess.run([sys.executable, '-c', f'import {module}'], capture_output=True).returncode == 0
        if not found:
            missing.append(f'Python module {module}')
    for package in BUILD_PACKAGES:
        if not (prefix / 'share' / package / 'cmake').is_dir():
            missing.append(f'CMake package {package} (in {prefix}/share)')
    return missing


def _cmake(prefix: Path) -> str:
    """Return the path of a CMake new enough (the environment's own first), else BuildError."""
    path = shutil.which('cmake', path=os.pathsep.join([str(prefix / 'bin'), os.environ.get('PATH', '')]))
    if path is None:
        raise BuildError('cmake is not installed: pip install cmake (the `interfaces` extra) or apt-get install cmake')
    out = subprocess.run([path, '--version'], capture_output=True, text=True).stdout
    match = re.search(r'(\d+)\.(\d+)', out)
    if not match or tuple(map(int, match.groups())) < MIN_CMAKE:
        raise BuildError(f'{path} is too old ({out.splitlines()[0] if out else "?"}); CMake >= 3.19 is needed')
    return path


def _compilers() -> None:
    """Raise BuildError unless a C and a C++ compiler are on PATH."""
    for names, what in ((('cc', 'gcc', 'clang'), 'C'), (('c++', 'g++', 'clang++'), 'C++')):
        if not any(shutil.which(name) for name in names):
            raise BuildError(f'no {what} compiler on PATH (apt-get install build-essential)')


def _environment(prefix: Path) -> dict:
    """Return the build's environment: the prefix's bin/ first on PATH, no variable of a sourced ROS setup."""
    env = {k: v for k, v in os.environ.items() if k not in ROS_ENVIRONMENT}
    env['PATH'] = os.pathsep.join([str(prefix / 'bin'), env.get('PATH', '/usr/bin:/bin')])
    return env


def _runpath(prefix: Path) -> str:
    """Return CMAKE_INSTALL_RPATH: beside the library (<prefix>/lib), and <prefix>/lib from <site-packages>/<pkg>/."""
    site = Path(sysconfig.get_paths(vars={'base': str(prefix), 'platbase': str(prefix)})['platlib'])
    from_modules = os.path.relpath(prefix / 'lib', site / 'pkg')
    return f'$ORIGIN;$ORIGIN/{from_modules}'


def _cached_prefix(build: Path) -> str | None:
    """Return CMAKE_INSTALL_PREFIX of an existing build tree, None if there is none."""
    cache = build / 'CMakeCache.txt'
    if not cache.is_file():
        return None
    match = re.search(r'^CMAKE_INSTALL_PREFIX:PATH=(.*)$', cache.read_text(), re.MULTILINE)
    return match.group(1) if match else None


def _run(cmd: list[str], env: dict, log: Path, step: str) -> None:
    """Run a build step with its output in `log`; BuildError with the log's tail if it fails."""
    with log.open('w') as out:
        result = subprocess.run(cmd, env=env, stdout=out, stderr=subprocess.STDOUT)
    if result.returncode != 0:
        tail = ''.join(log.read_text(errors='replace').splitlines(keepends=True)[-40:])
        raise BuildError(f'{step} failed (exit {result.returncode}); full log: {log}\n{tail}')


def build_package(package: str, prefix: Path, build_root: Path, cmake: str, jobs: int, env: dict) -> None:
    """Configure, build and install one package into `prefix`."""
    build = build_root / package
    if _cached_prefix(build) not in (None, str(prefix)):
        shutil.rmtree(build)                 # a tree configured for another environment
    build.mkdir(parents=True, exist_ok=True)
    python = sys.executable
    _run([cmake, '-S', str(SOURCES / package), '-B', str(build),
          '-DCMAKE_BUILD_TYPE=Release', f'-DCMAKE_INSTALL_PREFIX={prefix}', f'-DCMAKE_PREFIX_PATH={prefix}',
          f'-DCMAKE_INSTALL_RPATH={_runpath(prefix)}', '-DBUILD_TESTING=OFF',
          f'-DPython3_EXECUTABLE={python}', f'-DPYTHON_EXECUTABLE={python}',
          f'-DCMAKE_PROJECT_INCLUDE={FIXUPS}'], env, build / 'configure.log', f'{package}: cmake configure')
    _run([cmake, '--build', str(build), '--parallel', str(jobs)], env, build / 'build.log', f'{package}: build')
    _run([cmake, '--install', str(build)], env, build / 'install.log', f'{package}: install')


def check_types(types: list[str]) -> None:
    """Import each type in a fresh interpreter of the environment and load its rclpy type support."""
    code = ('import importlib, sys\n'
            'from rclpy.type_support import check_for_type_support\n'
            'for name in sys.argv[1:]:\n'
            '    module, _, cls = name.rpartition(".")\n'
            '    check_for_type_support(getattr(importlib.import_module(module), cls))\n')
    env = {k: v for k, v in os.environ.items() if k not in ROS_ENVIRONMENT}
    result = subprocess.run([sys.executable, '-c', code, *types], capture_output=True, text=True, env=env,
                            cwd=str(Path.home()) if Path.home().is_dir() else '/')
    if result.returncode != 0:
        raise BuildError(f'the built types do not load: {result.stderr.strip()[-2000:]}')


def uninstall(build_root: Path) -> int:
    """Remove the files that the last install of each package wrote (install_manifest.txt); their count."""
    removed = 0
    for package in PACKAGES:
        manifest = build_root / package / 'install_manifest.txt'
        if not manifest.is_file():
            continue
        for line in manifest.read_text().splitlines():
            path = Path(line)
            if line and (path.is_file() or path.is_symlink()):
                path.unlink()
                removed += 1
        manifest.unlink()
    return removed


def main(argv: list[str] | None = None) -> int:
    """Build, install and check the interface packages; print one line per package and the time taken."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--build-dir', type=Path, default=REPO / 'build' / 'interfaces',
                        help='build trees (default: build/interfaces/ of the repository)')
    parser.add_argument('--jobs', '-j', type=int, default=min(2, os.cpu_count() or 1),
                        help='parallel compile jobs (default: 2 at most)')
    parser.add_argument('--uninstall', action='store_true', help='remove what the last build installed')
    args = parser.parse_args(argv)
    prefix = Path(sys.prefix)
    build_root = args.build_dir.resolve()
    if args.uninstall:
        print(f'build_interfaces: removed {uninstall(build_root)} installed files from {prefix}')
        return 0
    started = time.monotonic()
    try:
        if sys.prefix == sys.base_prefix:
            raise BuildError(f"{sys.executable} is not a virtual environment's Python: run it as "
                             '.venv/bin/python tools/build_interfaces.py (the build installs into that environment)')
        missing = _missing_requirements(prefix)
        if missing:
            raise BuildError('missing: ' + '; '.join(missing) + f'\ninstall them with: {sys.executable} -m pip '
                             f"install -e '{REPO}[ros,interfaces]'")
        cmake = _cmake(prefix)
        _compilers()
        env = _environment(prefix)
        build_root.mkdir(parents=True, exist_ok=True)
        (build_root / 'COLCON_IGNORE').touch()
        for package in PACKAGES:
            began = time.monotonic()
            build_package(package, prefix, build_root, cmake, args.jobs, env)
            print(f'build_interfaces: {package} built and installed into {prefix} '
                  f'in {time.monotonic() - began:.0f} s', flush=True)
        check_types([name for package in PACKAGES for name in CHECKS[package]])
    except BuildError as exc:
        print(f'build_interfaces: {exc}', file=sys.stderr)
        return 1
    print(f'build_interfaces: {len(PACKAGES)} packages in {time.monotonic() - started:.0f} s; '
          'their types load in rclpy')
    return 0


if __name__ == '__main__':
    sys.exit(main())
