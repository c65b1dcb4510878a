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
The floors of the house, checked over the `ast` imports of every module of iguana_ros/ and of the lab beside it.

Each floor imports only from the floors below it (and, unless it is marked independent, from its own); nothing
below the ROS adapter imports rclpy or a message package; no two units form a cycle. FLOORS (iguana_ros) and
LAB_FLOORS (iguana_lab, all of it above iguana_ros, which never imports it) are the one table of the floors:
docs/ARCHITECTURE.md's table is generated from them (`python test/test_import_layers.py --write-docs`) and a test
here checks that it is. The checker is tested on a synthetic tree with planted violations, so it cannot pass by
finding nothing.
"""
from __future__ import annotations

import ast
from dataclasses import dataclass
from functools import lru_cache
import importlib.metadata
import importlib.util
from pathlib import Path
import textwrap

import iguana_ros


@dataclass(frozen=True)
class Floor:
    """One floor: its name, its units, what it holds, and whether its units may import each other."""

    name: str
    units: tuple
    what: str = ''
    independent: bool = False


def floors(*rows: tuple) -> tuple[Floor, ...]:
    """Floors from (name, 'unit unit ...'[, what[, independent]]) rows, lowest first."""
    return tuple(Floor(row[0], tuple(row[1].split()), *row[2:]) for row in rows)


FLOORS = floors(
    ('base', 'constants errors config jit geometry topics parameters executables yaml_files',
     'physical constants, error types, the kernel cache, the one rotation toolkit, the ROS-free tables of '
     '`msg_configs/`, the one list of executables, bounded reading of YAML files'),
    ('core rooms', 'body motion terrain physics metrics render visuals',
     "the paper's algorithms, numpy + numba, no ROS; headless drawing of a recorded run; the simulator's colours"),
    ('scene', 'scene validation',
     'the scene description and its limits; the bounds of every topic payload'),
    ('pipeline stages', 'stages pipeline world run_metrics',
     'each stage built from the scene by one factory; the frame loop; several characters in one world; the figures '
     'of a run'),
    ('library tools', 'warmup doctor.checks clip_calibration',
     "ROS-free tools over the library loop: compiling the kernels, the doctor's checks, the clips' tracking "
     'measurement'),
    ('ROS adapter', 'ros',
     'topics and QoS resolved from `msg_configs/topics.yaml`, numpy ⇄ message conversions, the one CDR codec, stage '
     "values as messages, the node events' vocabulary, the listeners' lean wait loop; the lowest floor that may "
     'import rclpy'),
    ('nodes and bag', 'nodes bag',
     'the four nodes, goal sending and `IguanaCommander`; MCAP record, play, read, damage scan', True),
    ('supervisor', 'supervisor',
     "`iguana run`: processes in one group, domain check, start-up phases and progress display, the run's summary "
     'from its bag'),
    ('tools', 'view doctor doctor.dds',
     "the browser viewer; the doctor's DDS checks and the order of `iguana doctor` (its room, doctor/, spans floors)"),
    ('cli', 'cli', 'the `iguana` command: parses, calls one function below, prints one line on error'),
)
"""The floors of iguana_ros, lowest first."""

LAB_FLOORS = floors(
    ('studies', 'random_scenes diagnostics bench',
     'seeded random benchmark scenes, the statics study of a model variant, the benchmarks of `iguana bench`'),
    ('sweep engine', 'sweep', 'distributed sweeps (Dask) and the benchmarks that run on them'),
    ('experiments', 'locomotion_bench push_experiment faults',
     'the randomized locomotion benchmark, the push experiment (paper VIII-D), the fault-injection suites'),
    ('lab cli', 'cli', "the lab's sub-commands, added to `iguana` through the `iguana_ros.commands` entry points"),
)
"""The floors of iguana_lab (lab/), lowest first; all of them stand on the whole of iguana_ros."""

ROS_FLOOR = 'ROS adapter'
"""The lowest floor that may import rclpy, rosidl or message packages."""

ROS_MODULES = frozenset({'rclpy', 'rcl_interfaces', 'builtin_interfaces', 'rosgraph_msgs', 'rosbag2_py', 'launch',
                         'launch_ros', 'rpyutils'})
"""Top-level modules of ROS 2 (besides any *_msgs, *_interfaces, rosidl* module, or one a ros-* wheel installs)."""

NOT_MIDDLEWARE = frozenset({'ament_index_python'})
"""ROS 2 modules allowed on any floor: the ament index is a file lookup (config.py finds msg_configs/ in a colcon
install with it), no middleware, messages or rclpy."""


@dataclass(frozen=True)
class Import:
    """One import statement's target as seen from a module: importer, imported module path, line."""

    importer: str
    target: str
    line: int


def module_name(root: Path, path: Path) -> str:
    """Dotted name of the module at `path` in the package rooted at `root` (its __init__ names the package)."""
    parts = (root.name, *path.relative_to(root).with_suffix('').parts)
    return '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)


def imports_of(root: Path, path: Path) -> list[Import]:
    """
    Every import of the module at `path` (module level, in functions, under TYPE_CHECKING), relative ones resolved.

    `from P import x` yields P.x (x may be a module or a name in P).
    """
    name = module_name(root, path)
    package = name if path.name == '__init__.py' else name.rpartition('.')[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [Import(name, alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ''
            if node.level:
                anchor = package.split('.')[:len(package.split('.')) - (node.level - 1)]
                base = '.'.join(anchor + ([node.module] if node.module else []))
            out += [Import(name, f'{base}.{alias.name}', node.lineno) for alias in node.names]
    return sorted(out, key=lambda imp: imp.line)


def unit_of(root: Path, module: str, split: frozenset = frozenset()) -> str | None:
    """
    Return the unit of a dotted path in the package at `root`.

    The module or subpackage right below the package, '' for the package's own __init__ (a name defined there, such as
    `package_version`), None outside the package. A module of a room whose modules stand on different floors is a
    unit of its own when `split` names it ('doctor.checks'); the room's other modules are the room's unit.
    """
    parts = module.split('.')
    if parts[0] != root.name:
        return None
    if len(parts) > 2 and f'{parts[1]}.{parts[2]}' in split:
        return f'{parts[1]}.{parts[2]}'
    if len(parts) > 1 and ((root / parts[1]).is_dir() or (root / f'{parts[1]}.py').is_file()):
        return parts[1]
    return ''


@lru_cache(maxsize=1)
def _ros_distribution_modules() -> frozenset:
    """Top-level modules installed by ros-* wheels (the PyPI form of ROS 2 Jazzy) in this environment."""
    mapping = importlib.metadata.packages_distributions()
    return frozenset(m for m, dists in mapping.items() if any(d.lower().startswith('ros-') for d in dists))


def is_ros(module: str) -> bool:
    """Whether a dotted module path belongs to ROS 2 (rclpy, rosidl, message and interface packages)."""
    top = module.split('.')[0]
    return top not in NOT_MIDDLEWARE and (top in ROS_MODULES or top.endswith(('_msgs', '_interfaces'))
                                          or top.startswith('rosidl') or top in _ros_distribution_modules())


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one unit (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return found


def layer_violations(root: Path, layout: tuple[Floor, ...] = FLOORS, ros_floor: str = ROS_FLOOR) -> list[str]:
    """
    Every breach of the floors by the package at `root`.

    Units on no floor, upward imports, imports between the units of an independent floor, ROS imports below `ros_floor`,
    cycles between units; one line each.
    """
    level = {unit: k for k, floor in enumerate(layout) for unit in floor.units}
    split = frozenset(unit for unit in level if '.' in unit)
    level[''] = 0
    independent = {unit for floor in layout if floor.independent for unit in floor.units}
    lowest_ros = next(k for k, floor in enumerate(layout) if floor.name == ros_floor)
    problems, edges = [], {}
    for path in sorted(root.rglob('*.py')):
        where = path.relative_to(root.parent)
        unit = unit_of(root, module_name(root, path), split)
        if unit not in level:
            problems.append(f'{where}: unit {unit!r} is on no floor (declare it in FLOORS)')
            continue
        for imp in imports_of(root, path):
            target = unit_of(root, imp.target, split)
            if target is None:
                if is_ros(imp.target) and level[unit] < lowest_ros:
                    problems.append(f'{where}:{imp.line}: imports {imp.target} below the {ros_floor} floor '
                                    f'({unit} is on {layout[level[unit]].name})')
                continue
            if target == unit or target == '':
                continue
            edges.setdefault(unit, set()).add(target)
            if target not in level:
                problems.append(f'{where}:{imp.line}: imports {imp.target}, whose unit {target!r} is on no floor')
            elif level[target] > level[unit]:
                problems.append(f'{where}:{imp.line}: imports {imp.target} from the floor above '
                                f'({unit} on {layout[level[unit]].name}, {target} on {layout[level[target]].name})')
            elif level[target] == level[unit] and unit in independent:
                problems.append(f'{where}:{imp.line}: imports {imp.target}, but {unit} and {target} share the '
                                f'independent floor {layout[level[unit]].name}')
    problems += [f'import cycle between units: {" <-> ".join(c)}' for c in _cycles(edges)]
    return problems


def test_iguana_ros_keeps_its_floors():
    root = Path(iguana_ros.__file__).resolve().parent
    assert layer_violations(root) == []


def test_the_lab_keeps_its_floors_and_iguana_ros_never_imports_it():
    import iguana_lab

    lab = Path(iguana_lab.__file__).resolve().parent
    assert layer_violations(lab, LAB_FLOORS, LAB_FLOORS[0].name) == []
    root = Path(iguana_ros.__file__).resolve().parent
    upward = [f'{path.relative_to(root.parent)}:{imp.line}: {imp.target}' for path in sorted(root.rglob('*.py'))
              for imp in imports_of(root, path) if imp.target.split('.')[0] == lab.name]
    assert upward == []


DOC = Path(__file__).resolve().parent.parent / 'docs' / 'ARCHITECTURE.md'
"""The document whose floor table is generated from FLOORS and LAB_FLOORS."""

TABLE_BEGIN = '<!-- floors: generated from FLOORS and LAB_FLOORS in test/test_import_layers.py; do not edit -->'
TABLE_END = '<!-- end of floors -->'


def _shown_units(root: Path, floor: Floor) -> str:
    """Return a floor's units as the doc shows them: packages as `name/`, modules as `name`."""
    return ', '.join(f'`{u}/`' if (root / u).is_dir() else f'`{u}`' for u in floor.units)


def floor_table() -> str:
    """Return the Markdown floor table of docs/ARCHITECTURE.md, top floor first, the lab's floors above."""
    root = Path(iguana_ros.__file__).resolve().parent
    rows = ['| floor | units | what |', '|---|---|---|']
    for k, floor in reversed(list(enumerate(LAB_FLOORS, start=len(FLOORS) + 1))):
        rows.append(f'| {k}. {floor.name} | lab: {_shown_units(root.parent / "lab" / "iguana_lab", floor)} | '
                    f'{floor.what} |')
    for k, floor in reversed(list(enumerate(FLOORS, start=1))):
        units = _shown_units(root, floor) + (' (independent of each other)' if floor.independent else '')
        rows.append(f'| {k}. {floor.name} | {units} | {floor.what} |')
    return '\n'.join([TABLE_BEGIN, *rows, TABLE_END])


def _documented_table(text: str) -> str:
    """Return the generated block of `text` (between TABLE_BEGIN and TABLE_END, both included), '' if none."""
    begin, end = text.find(TABLE_BEGIN), text.find(TABLE_END)
    return text[begin:end + len(TABLE_END)] if 0 <= begin < end else ''


def test_the_architecture_doc_shows_the_floors_of_this_file():
    """docs/ARCHITECTURE.md's table is FLOORS and LAB_FLOORS; regenerate it with `--write-docs`."""
    assert _documented_table(DOC.read_text()) == floor_table(), \
        'run: python test/test_import_layers.py --write-docs'


def write_docs() -> None:
    """Replace the floor table of docs/ARCHITECTURE.md by the one generated from FLOORS and LAB_FLOORS."""
    text = DOC.read_text()
    old = _documented_table(text)
    if not old:
        raise SystemExit(f'{DOC}: no {TABLE_BEGIN!r} ... {TABLE_END!r} block to replace')
    DOC.write_text(text.replace(old, floor_table()))


def test_every_imported_name_of_the_package_exists():
    """A move leaves no stale path behind, in function-level imports either (which run only when called)."""
    root = Path(iguana_ros.__file__).resolve().parent
    test_dir = Path(__file__).resolve().parent
    missing = []
    for path in sorted([*root.rglob('*.py'), *test_dir.rglob('*.py')]):
        module = module_name(root, path) if root in path.parents else None
        for imp in imports_of(root, path) if module else _plain_imports(path):
            if imp.target.split('.')[0] == root.name and not _resolves(imp.target):
                missing.append(f'{path.relative_to(root.parent)}:{imp.line}: {imp.target}')
    assert missing == []


def _plain_imports(path: Path) -> list[Import]:
    """Return the absolute imports of a file outside the package (a test)."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [Import(str(path), alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            out += [Import(str(path), f'{node.module}.{alias.name}', node.lineno) for alias in node.names]
    return out


def _resolves(target: str) -> bool:
    """Whether dotted `target` is a module, or a name defined in the module it ends in."""
    module, _, name = target.rpartition('.')
    if not module:
        return importlib.util.find_spec(target) is not None
    try:
        if importlib.util.find_spec(module) is None:
            return False
    except ModuleNotFoundError:   # a parent of `module` is missing (find_spec imports the parents)
        return False
    parent = importlib.import_module(module)
    if hasattr(parent, name):
        return True
    return hasattr(parent, '__path__') and importlib.util.find_spec(target) is not None


def test_name_check_finds_stale_paths():
    assert _resolves('iguana_ros.ros.endpoints.RECORDER_NODE_NAME') and _resolves('iguana_ros.ros.endpoints')
    assert _resolves('iguana_ros.package_version') and _resolves('iguana_ros.ros')
    assert not _resolves('iguana_ros.nodes.base.frame_stamp')             # moved to the adapter layer
    assert not _resolves('iguana_ros.terrain.from_scene.terrain_from_spec')   # the module is gone
    assert not _resolves('iguana_ros.nodes.launch.RunOptions')            # the module moved to supervisor/
    assert not _resolves('iguana_ros.nodes.launch.deeper.Name')


def test_every_floor_unit_is_declared_once():
    units = [unit for floor in FLOORS for unit in floor.units]
    assert len(units) == len(set(units))


def _tree(tmp_path: Path, files: dict[str, str]) -> Path:
    """Return a synthetic package `pkg` under `tmp_path` with the given module texts."""
    root = tmp_path / 'pkg'
    for rel, text in {'__init__.py': '', **files}.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))
    return root


SYNTHETIC = floors(('low', 'core'), ('adapter', 'ros'), ('middle', 'nodes bag', '', True), ('top', 'cli'))
"""A small house for the planted violations."""

SOUND = {
    'core/__init__.py': '',
    'core/maths.py': 'import numpy as np\nfrom . import helpers\n',
    'core/helpers.py': 'import math\n',
    'ros/__init__.py': 'import rclpy\nfrom std_msgs.msg import Header\nfrom pkg.core.maths import np\n',
    'nodes/__init__.py': 'from pkg.ros import Header\n',
    'bag/__init__.py': 'from ..ros import rclpy\n',
    'cli.py': 'def main():\n    from pkg.nodes import Header\n    from pkg.bag import rclpy\n',
}


def test_checker_accepts_a_sound_tree(tmp_path):
    assert layer_violations(_tree(tmp_path, SOUND), SYNTHETIC, 'adapter') == []


def test_checker_finds_an_upward_import_in_a_function(tmp_path):
    tree = _tree(tmp_path, {**SOUND, 'core/helpers.py': 'def f():\n    from pkg.cli import main\n'})
    problems = layer_violations(tree, SYNTHETIC, 'adapter')
    assert len(problems) == 2 and 'pkg/core/helpers.py:2: imports pkg.cli.main from the floor above' in problems[0]
    assert problems[1] == 'import cycle between units: bag <-> cli <-> core <-> nodes <-> ros'


def test_checker_finds_rclpy_below_the_adapter_layer(tmp_path):
    tree = _tree(tmp_path, {**SOUND, 'core/maths.py': 'if False:\n    import rclpy.node\n',
                            'core/helpers.py': 'from geometry_msgs.msg import Pose\n'})
    problems = layer_violations(tree, SYNTHETIC, 'adapter')
    assert [p.split(': ')[0] for p in problems] == ['pkg/core/helpers.py:1', 'pkg/core/maths.py:2']
    assert all('below the adapter floor' in p for p in problems)


def test_checker_finds_nodes_and_bag_importing_each_other(tmp_path):
    tree = _tree(tmp_path, {**SOUND, 'bag/__init__.py': 'from ..nodes import Header\n'})
    problems = layer_violations(tree, SYNTHETIC, 'adapter')
    assert problems == ['pkg/bag/__init__.py:1: imports pkg.nodes.Header, but bag and nodes share the independent '
                        'floor middle']


def test_checker_finds_a_cycle_within_a_floor(tmp_path):
    layout = floors(('low', 'core extra'), ('adapter', 'ros'), ('middle', 'nodes bag', '', True), ('top', 'cli'))
    tree = _tree(tmp_path, {**SOUND, 'extra.py': 'from pkg.core import maths\n',
                            'core/helpers.py': 'import pkg.extra\n'})
    assert layer_violations(tree, layout, 'adapter') == ['import cycle between units: core <-> extra']


def test_checker_places_the_modules_of_a_split_room_on_their_own_floors(tmp_path):
    layout = floors(('low', 'core doc.checks'), ('adapter', 'ros'), ('middle', 'nodes bag', '', True),
                    ('top', 'cli doc'))
    files = {**SOUND, 'doc/__init__.py': 'def every():\n    from pkg.cli import main\n',
             'doc/checks.py': 'import os\n', 'core/helpers.py': 'from pkg.doc.checks import os\n'}
    assert layer_violations(_tree(tmp_path, files), layout, 'adapter') == []
    files['doc/checks.py'] = 'from pkg.doc import every\n'
    problems = layer_violations(_tree(tmp_path / 'b', files), layout, 'adapter')
    assert problems[0] == ('pkg/doc/checks.py:1: imports pkg.doc.every from the floor above (doc.checks on low, doc '
                           'on top)')


def test_checker_finds_a_unit_on_no_floor(tmp_path):
    tree = _tree(tmp_path, {**SOUND, 'stray.py': 'import os\n', 'cli.py': 'import pkg.stray\n'})
    problems = layer_violations(tree, SYNTHETIC, 'adapter')
    assert problems == ["pkg/cli.py:1: imports pkg.stray, whose unit 'stray' is on no floor",
                        "pkg/stray.py: unit 'stray' is on no floor (declare it in FLOORS)"]


if __name__ == '__main__':
    import sys

    if sys.argv[1:] != ['--write-docs']:
        raise SystemExit('usage: python test/test_import_layers.py --write-docs')
    write_docs()
