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
Packaging and ROS 2 conventions.

The launch file, a real colcon build, one version, one node list, the dependencies setup.py declares.
"""
from __future__ import annotations

import ast
import importlib.metadata
import json
import os
from pathlib import Path
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest
import yaml

import iguana_ros
from iguana_ros.config import params_file
from iguana_ros.executables import CLI_EXECUTABLE, NODE_EXECUTABLES, SIM_TIME_NODES
import launch_api

REPO = Path(__file__).resolve().parent.parent
LAUNCH_FILE = REPO / 'launch' / 'iguana.launch.py'
PACKAGE = 'iguana_ros'
ROS_MODULES = {'rclpy', 'rcl_interfaces', 'rosgraph_msgs', 'builtin_interfaces', 'ament_index_python',
               'rosidl_runtime_py', 'rosbag2_py'}
"""Top-level modules that come with ROS 2 (the `ros` extra on PyPI, apt on a ROS machine) besides *_msgs."""


def _setup_keyword(name: str):
    """Return the literal value of keyword `name` of setup.py's setup() call."""
    tree = ast.parse((REPO / 'setup.py').read_text())
    call = next(node for node in ast.walk(tree)
                if isinstance(node, ast.Call) and getattr(node.func, 'id', '') == 'setup')
    return ast.literal_eval(next(k.value for k in call.keywords if k.arg == name))


def _launch(monkeypatch, share: Path, **arguments) -> tuple[list, launch_api.Resolver]:
    """Run generate_launch_description() of the launch file on the Jazzy API stand-ins: (Node actions, resolver)."""
    launch_api.install(monkeypatch)
    namespace = {'__name__': 'iguana_launch', '__file__': str(LAUNCH_FILE)}
    exec(compile(LAUNCH_FILE.read_text(), str(LAUNCH_FILE), 'exec'), namespace)
    description = namespace['generate_launch_description']()
    declared = {e.name: e for e in description.entities if isinstance(e, launch_api.DeclareLaunchArgument)}
    assert set(declared) == {'scene', 'mode', 'namespace', 'use_sim_time', 'record', 'rviz'}
    for name, value in arguments.items():
        assert declared[name].choices is None or value in declared[name].choices
    values = {name: arg.default_value for name, arg in declared.items()} | arguments
    nodes = [e for e in description.entities if isinstance(e, launch_api.Node)]
    assert nodes == launch_api.Node.created  # every Node made is in the description
    processes = [e for e in description.entities if isinstance(e, launch_api.ExecuteProcess)]
    assert processes == launch_api.ExecuteProcess.created
    return nodes + processes, launch_api.Resolver(values, {PACKAGE: share})


def test_launch_file_imports_only_the_documented_jazzy_api():
    tree = ast.parse(LAUNCH_FILE.read_text(), str(LAUNCH_FILE))
    imported = [(node.module, alias.name) for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                for alias in node.names]
    assert not [n for n in ast.walk(tree) if isinstance(n, ast.Import)], 'use `from module import name`'
    for module, name in imported:
        if module.split('.')[0] in ('launch', 'launch_ros'):
            assert name in launch_api.JAZZY_EXPORTS[module], f'{module}.{name} is not in the Jazzy API'
        else:
            assert module.startswith(f'{PACKAGE}.') and hasattr(importlib.import_module(module), name), module
    assert 'generate_launch_description' in {f.name for f in tree.body if isinstance(f, ast.FunctionDef)}


def _nodes(actions: list) -> list:
    """Return the Node actions of a launch."""
    return [a for a in actions if isinstance(a, launch_api.Node)]


def _processes(actions: list, resolver: launch_api.Resolver) -> list[list[str]]:
    """Return the command lines of the processes (not nodes) a launch starts."""
    return [a.command(resolver) for a in actions if isinstance(a, launch_api.ExecuteProcess) and a.runs(resolver)]


def test_launch_file_takes_mode_namespace_record_and_rviz(monkeypatch):
    actions, resolver = _launch(monkeypatch, REPO)
    assert _processes(actions, resolver) == []                     # by default: the nodes only
    assert {resolver.text(n.namespace) for n in _nodes(actions)} == {''}
    actions, resolver = _launch(monkeypatch, REPO, mode='realtime', namespace='iguana1', record='bags/run1',
                                rviz='true')
    simulator = next(n for n in _nodes(actions) if n.name == 'simulator_node')
    assert simulator.parameter_values(resolver) == {'scene': 'hills', 'mode': 'realtime'}
    assert {resolver.text(n.namespace) for n in _nodes(actions)} == {'iguana1'}
    assert all(n.remappings == [('/clock', 'clock')] for n in _nodes(actions))   # <namespace>/clock in one
    assert _processes(actions, resolver) == [[CLI_EXECUTABLE, 'bag', 'record', '-o', 'bags/run1', '--namespace',
                                              'iguana1'],
                                             ['rviz2', '-d', str(REPO / 'rviz' / 'iguana.rviz')]]


def test_launch_file_starts_the_installed_node_executables_with_the_run_params_file(monkeypatch):
    nodes, resolver = _launch(monkeypatch, REPO)  # the source tree stands for share/iguana_ros
    nodes = _nodes(nodes)
    assert [n.executable for n in nodes] == list(NODE_EXECUTABLES)
    assert {n.package for n in nodes} == {PACKAGE} and [n.name for n in nodes] == list(NODE_EXECUTABLES)
    for node in nodes:
        files = node.parameter_files(resolver)
        assert files == [REPO / params_file().relative_to(REPO)]  # the file `iguana run` gives every node
        clock = {'use_sim_time': True} if node.name in SIM_TIME_NODES else {}
        mode = {'mode': 'lockstep'} if node.name == 'simulator_node' else {}
        assert node.parameter_values(resolver) == {'scene': 'hills', **clock, **mode}
    assert [n.executable for n in nodes if n.on_exit is not None] == ['simulator_node']
    nodes, resolver = _launch(monkeypatch, REPO, scene='flat_walk', use_sim_time='false')
    nodes = _nodes(nodes)
    assert nodes[0].name == 'planner_node'
    assert nodes[0].parameter_values(resolver) == {'scene': 'flat_walk', 'use_sim_time': False}
    assert nodes[3].parameter_values(resolver) == {'scene': 'flat_walk', 'mode': 'lockstep'}


def test_iguana_run_gives_each_node_the_params_file_then_its_own_values():
    from iguana_ros.scene import load_scene, scene_path
    from iguana_ros.supervisor.run import RunOptions, node_commands
    for single in (False, True):
        commands = node_commands(RunOptions(scene='goal_sequence', single_process=single),
                                 load_scene('goal_sequence'), scene_path('goal_sequence'))
        assert list(commands) == (['nodes'] if single else list(NODE_EXECUTABLES))
        for name, command in commands.items():
            ros = command[command.index('--ros-args'):]
            assert ros[1:3] == ['--params-file', str(params_file())]
            values = ros[3:]
            assert values[::2] == ['-p'] * (len(values) // 2) and values
            # node:name:=value, since the file's section of a node beats a value given to every node
            nodes = {value.split(':')[0] for value in values[1::2]}
            assert nodes == (set(NODE_EXECUTABLES) if single else {name})
            assert 'simulator_node:wait_for_recorder:=true' in values or name != 'simulator_node'
    params = yaml.safe_load(params_file().read_text())
    assert params['/**/planner_node']['ros__parameters']['use_sim_time'] is True
    assert 'use_sim_time' not in params['/**']['ros__parameters']
    assert params['/**/simulator_node']['ros__parameters']['wait_for_recorder'] is False


def test_installed_console_scripts_are_the_nodes_and_the_cli():
    scripts = {ep.name: ep for ep in importlib.metadata.entry_points(group='console_scripts')
               if ep.dist is not None and ep.dist.name.replace('-', '_') == PACKAGE}
    assert set(scripts) == {CLI_EXECUTABLE, *NODE_EXECUTABLES}
    for name in NODE_EXECUTABLES:
        assert scripts[name].value == f'iguana_ros.nodes.{name}:main'
        assert callable(scripts[name].load())


def test_version_has_one_source():
    manifest = ET.parse(REPO / 'package.xml').getroot()
    version = manifest.findtext('version')
    assert iguana_ros.__version__ == iguana_ros.package_version() == version
    assert importlib.metadata.version(PACKAGE) == version
    assert importlib.metadata.metadata(PACKAGE)['License'] == manifest.findtext('license')
    assert version not in (REPO / 'setup.py').read_text()
    result = subprocess.run([sys.executable, '-m', 'iguana_ros.cli', '--version'], capture_output=True, text=True)
    assert result.stdout.strip() == f'iguana {version}'


def _third_party_imports() -> set[str]:
    """Top-level modules imported anywhere in iguana_ros/ that are neither stdlib, the package nor ROS 2."""
    found = set()
    for path in (REPO / PACKAGE).rglob('*.py'):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                found.update(alias.name.split('.')[0] for alias in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                found.add(node.module.split('.')[0])
    return {m for m in found if m not in sys.stdlib_module_names and m != PACKAGE
            and m not in ROS_MODULES and not m.endswith(('_msgs', '_interfaces'))}


def test_declared_dependencies_are_exactly_the_imported_ones():
    from packaging.requirements import Requirement
    declared = {Requirement(r).name.lower() for r in _setup_keyword('install_requires')}
    providers = importlib.metadata.packages_distributions()
    imported = {}
    for module in _third_party_imports():
        assert module in providers, f'iguana_ros imports {module}, which no installed distribution provides'
        imported[module] = {d.lower() for d in providers[module]}
    missing = {m: d for m, d in imported.items() if not d & declared}
    assert not missing, f'imported but not in install_requires: {missing}'
    unused = declared - set().union(*imported.values())
    assert not unused, f'in install_requires but never imported: {unused}'


WITHOUT_LAB = """
import importlib.abc, importlib.metadata, sys


class NoLab(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split('.')[0] in ('iguana_lab', 'dask', 'distributed'):
            raise ModuleNotFoundError(f'No module named {name!r} (the lab is not installed here)')
        return None


sys.meta_path.insert(0, NoLab())
every_entry_point = importlib.metadata.entry_points
importlib.metadata.entry_points = lambda **kw: (
    [] if kw.get('group') == 'iguana_ros.commands' else every_entry_point(**kw))
from iguana_ros.cli import main
sys.exit(main(sys.argv[1:]))
"""
"""`iguana` as installed without the lab: iguana_lab, dask and distributed cannot be imported, no command is added."""


def _iguana_without_lab(*argv: str, timeout: float = 300) -> subprocess.CompletedProcess:
    """Return the finished `iguana argv...` run as if the lab (and Dask) were not installed."""
    return subprocess.run([sys.executable, '-c', WITHOUT_LAB, *argv], capture_output=True, text=True,
                          timeout=timeout, cwd=REPO)


def test_the_product_wheel_holds_no_lab_and_needs_no_dask(tmp_path):
    """`pip install .` ships iguana_ros only: the wheel has no iguana_lab module and no Dask requirement."""
    built = subprocess.run([sys.executable, '-m', 'pip', 'wheel', '--no-deps', '--no-build-isolation', '-q',
                            '-w', str(tmp_path), str(REPO)], capture_output=True, text=True, timeout=300)
    assert built.returncode == 0, built.stderr[-2000:]
    import zipfile
    (wheel,) = tmp_path.glob('iguana_ros-*.whl')
    names = zipfile.ZipFile(wheel).namelist()
    assert not [n for n in names if n.startswith(('iguana_lab/', 'lab/'))]
    assert 'iguana_ros/cli/run.py' in names and 'iguana_ros/data/clips.npz' in names
    metadata = next(n for n in names if n.endswith('.dist-info/METADATA'))
    requires = [line for line in zipfile.ZipFile(wheel).read(metadata).decode().splitlines()
                if line.startswith('Requires-Dist:') and 'extra ==' not in line]
    assert requires and not [r for r in requires if 'dask' in r or 'distributed' in r]


def test_iguana_works_without_the_lab():
    """Without the lab: no bench or sweep command, and the product's commands run (simulate end to end)."""
    shown = _iguana_without_lab('--help')
    assert shown.returncode == 0 and ' simulate ' in shown.stdout
    assert ' bench ' not in shown.stdout and ' sweep ' not in shown.stdout and not shown.stderr
    for command in ('run', 'goal', 'bag', 'view', 'render', 'doctor', 'motion', 'model', 'topics'):
        helped = _iguana_without_lab(command, '--help')
        assert helped.returncode == 0, (command, helped.stderr)
    refused = _iguana_without_lab('bench', 'sim')
    assert refused.returncode == 2 and "invalid choice: 'bench'" in refused.stderr
    simulated = _iguana_without_lab('simulate', 'flat_walk', '--duration', '0.5', '--json')
    assert simulated.returncode == 0, simulated.stderr[-2000:]
    assert json.loads(simulated.stdout)['outcome'] == 'completed'


def test_the_lab_adds_its_commands_through_entry_points():
    """Where the lab is installed, `iguana` has `bench` and `sweep`, from the `iguana_ros.commands` group."""
    from iguana_ros.cli import added_commands, build_parser
    assert dict(added_commands()) == {'bench': 'iguana_lab.cli.bench', 'sweep': 'iguana_lab.cli.sweep'}
    assert importlib.metadata.version('iguana_lab') == importlib.metadata.version(PACKAGE)
    commands = build_parser()._subparsers._group_actions[0].choices
    assert {'bench', 'sweep', 'run', 'simulate'} <= set(commands) and 'bench-adaptation' not in commands


def _colcon(tmp_path: Path, *args: str) -> Path:
    """`colcon build` of this package (source symlinked into a workspace in tmp_path); the package's prefix."""
    colcon = shutil.which('colcon', path=str(Path(sys.executable).parent))
    if colcon is None:
        pytest.fail('colcon is not installed: pip install -e .[test] (colcon-core, colcon-ros)')
    (tmp_path / 'src').mkdir()
    (tmp_path / 'src' / PACKAGE).symlink_to(REPO)
    result = subprocess.run([colcon, '--log-base', str(tmp_path / 'log'), 'build', '--base-paths', 'src',
                             '--build-base', str(tmp_path / 'build'), '--install-base', str(tmp_path / 'install'),
                             *args], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    return tmp_path / 'install' / PACKAGE


@pytest.mark.parametrize('symlink', [False, True], ids=['install', 'symlink-install'])
def test_colcon_build_puts_nodes_in_lib_and_the_cli_on_path(tmp_path, monkeypatch, symlink):
    prefix = _colcon(tmp_path, *(['--symlink-install'] if symlink else []))
    for name in NODE_EXECUTABLES:  # where `ros2 run iguana_ros <name>` looks
        assert os.access(prefix / 'lib' / PACKAGE / name, os.X_OK), name
    assert os.access(prefix / 'bin' / CLI_EXECUTABLE, os.X_OK)
    assert (prefix / 'share' / 'ament_index' / 'resource_index' / 'packages' / PACKAGE).is_file()
    share = prefix / 'share' / PACKAGE
    assert (share / 'launch' / 'iguana.launch.py').is_file()
    assert (share / 'rviz' / 'iguana.rviz').is_file() and (share / 'foxglove' / 'iguana_layout.json').is_file()
    actions, resolver = _launch(monkeypatch, share, rviz='true')
    assert Path(_processes(actions, resolver)[-1][-1]).is_file()           # the installed RViz2 config
    for node in _nodes(actions):
        assert all(f.is_file() for f in node.parameter_files(resolver))
        assert (prefix / 'lib' / node.package / node.executable).is_file()
    env = {k: v for k, v in os.environ.items() if k not in ('PYTHONPATH', 'AMENT_PREFIX_PATH')}
    env['PATH'] = '/usr/bin:/bin'  # nothing of the test's venv: the workspace's setup script must do it
    shell = subprocess.run(['sh', '-c', f'. {tmp_path}/install/setup.sh && command -v iguana && iguana --version'],
                           capture_output=True, text=True, env=env, timeout=60)
    version = ET.parse(REPO / 'package.xml').getroot().findtext('version')
    assert shell.stdout.split() == [str(prefix / 'bin' / CLI_EXECUTABLE), 'iguana', version], shell.stderr
