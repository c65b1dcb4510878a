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
Rewrite the package's Python mechanically so that the ament lint tests pass; running it again changes nothing.

``python tools/lint_fix.py`` rewrites every .py file under iguana_ros/, test/, launch/, examples/, tools/ and
setup.py (run it on a fresh checkout, then commit); ``python tools/lint_fix.py --check-ast [REV]`` then proves
that no module changed beyond docstrings, import order, dict displays and the hand fixes: it compares each
file's AST with that of ``git show REV:path`` (default HEAD) with PATCHES applied, and each docstring's words
with the old ones. Both print what they could not do and exit 1 then. Steps, per file:

1. PATCHES: the hand fixes, exact replacements applied to the original text (reported as stale when their
   text is gone from a file the tool has not run on yet): long code lines (E501), F401, F541, C416, C420,
   summaries pydocstyle takes for the signature (D402: `name(` in them), two summaries that needed new
   words (D401), and A003: the dataclass fields named `type` / `range` mirror message or file fields and
   keep their name with ``# noqa: A003``; the method CdrWriter.bytes() became CdrWriter.to_bytes().
2. ``dict(a=1)`` -> ``{'a': 1}`` (C408), moving continuation lines that were aligned under ``dict(``.
3. Quotes as flake8-quotes wants them (Q000, Q001, Q003), never in docstrings.
4. Each block of module-level imports sorted with flake8-import-order's own classifier and google sort keys
   (application names from setup.cfg's [flake8]), one blank line between groups, the names of
   ``from x import a, b`` sorted (I100, I101, I201). Imports inside functions are not touched; a block that
   code (``pytest.importorskip``) keeps after a later-sorting one gets ``# noqa: I100``.
5. Continuation lines aligned with their bracket (E127, E128) and blank lines (E302, E303, E305, W391).
6. Docstrings, as ament_pep257 (pydocstyle, ament's ignore list) and flake8-docstrings check them: a
   multi-line docstring has its summary on the line after the opening quotes (D213) and its closing quotes
   on a line of their own (D209); the summary is one line ending with a period (D400, D415) and a blank
   line follows it (D205). The first paragraph is joined if it fits, with its indent and quotes, in the line
   length; else it is split at its first sentence end ('. ', or ': ' / '; ' when that ends the first clause,
   the word after it capitalised) if that fits, else at the last ', ' or ' (' that fits, else before the
   last clause word (CLAUSE_WORDS) that fits; the summary ends with a period and the rest is re-flowed
   into the description, never breaking inside backticks. A function's summary that does not start with
   a verb (D401) gets one: 'Return' if the function returns a value, 'Yield' if it is a generator, else its
   verb in VERBS (a summary that starts 'Returns' or the like gets the imperative instead). A first word
   that pydocstyle wants capitalised (D403) is put in backticks when it is code (CamelCase, a single
   letter, an argument or an imported name), else capitalised. A docstring with backslashes becomes a raw
   string (D301); long lines of later paragraphs are re-flowed (E501). Every word is kept.
7. The header of ament_copyright's apache2 template, after any shebang or encoding line.
"""

from __future__ import annotations

import argparse
import ast
import configparser
import io
import os
from pathlib import Path
import re
import subprocess
import sys
import textwrap
import tokenize

ROOT = Path(__file__).resolve().parents[1]
SOURCE_DIRS = ('iguana_ros', 'test', 'launch', 'examples', 'tools')
SOURCE_FILES = ('setup.py',)
YEAR = 2026
HOLDER = 'iguana_ros developers'
HEADER = f"""# Copyright {YEAR} {HOLDER}
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
COPYRIGHT_RE = re.compile(r'^# Copyright \d{4}(-\d{4})? ', re.M)

# (file, original text, replacement): the hand fixes, applied before everything else.
PATCHES = [
    # E501: long code lines
    ('iguana_ros/bench/sim.py',
     'REFERENCE = dict(dt=1.0 / 4800.0, cg_tol=1e-8, cg_max_iter=1000, jacobian_every=1, '
     'factor_every=1, polar_iters=20)\n',
     'REFERENCE = dict(dt=1.0 / 4800.0, cg_tol=1e-8, cg_max_iter=1000, jacobian_every=1, factor_every=1,\n'
     '                 polar_iters=20)\n'),
    ('iguana_ros/cli/bench_faults_topics.py',
     "    parser.add_argument('--seconds', type=positive('--seconds'), default=6.0, help='simulated "
     "seconds per run (default 6)')\n",
     "    parser.add_argument('--seconds', type=positive('--seconds'), default=6.0,\n"
     "                        help='simulated seconds per run (default 6)')\n"),
    ('iguana_ros/faults/topic_fuzz.py',
     "            'rejected_lines': sum(r['rejected_lines'] for r in rows), 'ignored_lines': "
     "sum(r['ignored_lines'] for r in rows),\n",
     "            'rejected_lines': sum(r['rejected_lines'] for r in rows),\n"
     "            'ignored_lines': sum(r['ignored_lines'] for r in rows),\n"),
    ('iguana_ros/locomotion_bench.py',
     'from iguana_ros.random_scenes import BENCH_KINDS, GOAL_DISTANCE, GOAL_RADIUS, TERRAIN_EXTENT, '
     'random_scenes  # noqa: F401\n',
     'from iguana_ros.random_scenes import (BENCH_KINDS, GOAL_DISTANCE, GOAL_RADIUS, random_scenes,  '
     '# noqa: F401\n'
     '                                      TERRAIN_EXTENT)\n'),
    ('iguana_ros/pipeline.py',
     '                            reference_contacts=self.reference_contacts, clip_frames=frames, '
     'clip_names=names, goals=np.array(self.goals, float),\n',
     '                            reference_contacts=self.reference_contacts, clip_frames=frames, '
     'clip_names=names,\n'
     '                            goals=np.array(self.goals, float),\n'),
    ('test/nodes/test_cdr.py',
     '    assert list(decoded.texture.data) == [0, 1, 2, 3, 4] and decoded.uv_coordinates[1].v == '
     "values['uv_coordinates'][1, 1]\n",
     '    assert (list(decoded.texture.data) == [0, 1, 2, 3, 4]\n'
     "            and decoded.uv_coordinates[1].v == values['uv_coordinates'][1, 1])\n"),
    ('test/sweep/test_sweep_spec.py',
     "        ('softer', False, load_scene('flat_walk').duration)                              # the "
     "second case keeps the scene's\n",
     "        ('softer', False, load_scene('flat_walk').duration)                # the second case "
     "keeps the scene's\n"),
    ('test/test_diagnostics.py',
     '    assert inside_triangle((0.2, 0.2), (0, 0), (1, 0), (0, 1)) and not inside_triangle((0.8, '
     '0.8), (0, 0), (1, 0), (0, 1))\n',
     '    assert (inside_triangle((0.2, 0.2), (0, 0), (1, 0), (0, 1))\n'
     '            and not inside_triangle((0.8, 0.8), (0, 0), (1, 0), (0, 1)))\n'),
    ('test/test_import_layers.py',
     "    return top not in NOT_MIDDLEWARE and (top in ROS_MODULES or top.endswith(('_msgs', "
     "'_interfaces')) or top.startswith('rosidl')\n"
     '            or top in _ros_distribution_modules())\n',
     "    return top not in NOT_MIDDLEWARE and (top in ROS_MODULES or top.endswith(('_msgs', '_interfaces'))\n"
     "                                          or top.startswith('rosidl') or top in "
     '_ros_distribution_modules())\n'),
    # F401, F541, C416, C420
    ('test/helpers/publish_topics.py',
     '    from iguana_ros.ros.cdr import triangle_list_marker_cdr\n'
     '    from iguana_ros.ros.endpoints import resolve\n',
     '    from iguana_ros.ros.endpoints import resolve\n'),
    ('iguana_ros/doctor.py',
     "f'run from a folder you can write to, or choose one: iguana run --record DIR')",
     "'run from a folder you can write to, or choose one: iguana run --record DIR')"),
    ('iguana_ros/render/run.py',
     'parts = [p for p in self.mesh_points[::step]] + ',
     'parts = list(self.mesh_points[::step]) + '),
    ('test/faults/test_bag_faults.py',
     'late = [m for m in BagReader(src).messages()][-1]',
     'late = list(BagReader(src).messages())[-1]'),
    ('iguana_ros/bag/trajectory.py',
     '{key: [] for key in keys}, {key: 0 for key in keys})',
     '{key: [] for key in keys}, dict.fromkeys(keys, 0))'),
    # A003: class attributes named like builtins. Fields that mirror a message or a file keep their name.
    ('iguana_ros/bag/storage.py',
     '    name: str\n'
     '    type: str\n'
     '    offered_qos_profiles',
     '    name: str\n'
     "    type: str  # noqa: A003 - rosbag2 metadata.yaml's topic_metadata.type\n"
     '    offered_qos_profiles'),
    ('iguana_ros/parameters.py',
     '    name: str\n'
     '    type: str\n'
     '    default: object\n',
     '    name: str\n'
     '    type: str  # noqa: A003 - the `type` key of msg_configs/parameters.yaml\n'
     '    default: object\n'),
    ('iguana_ros/parameters.py',
     '    range: tuple | None = None\n',
     '    range: tuple | None = None  # noqa: A003 - the `range` key of msg_configs/parameters.yaml\n'),
    ('iguana_ros/ros/cdr.py',
     '    ns: str\n'
     '    type: int\n',
     '    ns: str\n'
     '    type: int  # noqa: A003 - visualization_msgs/Marker.type\n'),
    ('iguana_ros/topics.py',
     '    name: str\n'
     '    type: str\n'
     '    qos: QosSpec\n',
     '    name: str\n'
     '    type: str  # noqa: A003 - the `type` key of msg_configs/topics.yaml\n'
     '    qos: QosSpec\n'),
    # A003: a method, renamed
    ('iguana_ros/ros/cdr.py',
     '    def bytes(self) -> bytes:\n',
     '    def to_bytes(self) -> bytes:\n'),
    ('iguana_ros/ros/cdr.py',
     '    return writer.bytes()\n',
     '    return writer.to_bytes()\n'),
    ('test/nodes/test_cdr.py',
     '    data = writer.bytes()        #',
     '    data = writer.to_bytes()     #'),
    ('test/nodes/test_cdr.py',
     "_decoder('visualization_msgs/msg/Marker')(writer.bytes())",
     "_decoder('visualization_msgs/msg/Marker')(writer.to_bytes())"),
    # D402: summaries pydocstyle takes for the signature (`name(` in them); D401 that needs rewording
    ('iguana_ros/bag/scan.py',
     '"""Whether any region of the file is damaged (truncation alone is not damage)."""',
     '"""Whether any region of the file is damaged; truncation alone is not damage."""'),
    ('iguana_ros/config.py',
     '    """Return a path inside msg_configs/, e.g. config_path(\'scenes\', \'hills.yaml\')."""',
     '    """\n'
     '    Return a path inside msg_configs/.\n'
     '\n'
     "    E.g. config_path('scenes', 'hills.yaml').\n"
     '    """'),
    ('iguana_ros/motion/motion_graph.py',
     '"""Clip names (graph nodes)."""',
     '"""Clip names, the graph nodes."""'),
    ('iguana_ros/nodes/commander.py',
     '"""The newest iguana_state (spins briefly for it);',
     '"""The newest `iguana_state` (spins briefly for it);'),
    ('iguana_ros/ros/cdr.py',
     '"""A CDR string (undecodable bytes replaced)."""',
     '"""A CDR string, undecodable bytes replaced."""'),
    ('iguana_ros/terrain/heightfield.py',
     '"""Terrain height (m) `(...)` at world points `xy (..., 2)`."""',
     '"""Terrain height `(...)` (m) at world points `xy (..., 2)`."""'),
    ('iguana_ros/terrain/heightfield.py',
     '"""Height gradient (dh/dx, dh/dy) `(..., 2)` at world points `xy (..., 2)`."""',
     '"""Height gradient `(..., 2)` (dh/dx, dh/dy) at world points `xy (..., 2)`."""'),
    ('iguana_ros/terrain/heightfield.py',
     '"""Smooth random hills (sum of 8 plane waves near `wavelength` m), peak |height| = `amplitude` m."""',
     '"""Smooth random hills: a sum of 8 plane waves near `wavelength` m, peak |height| = `amplitude` m."""'),
    ('test/conftest.py',
     '"""Factory `make_node(name)` creating nodes on the test\'s context (destroyed afterwards)."""',
     '"""A factory `make_node` (call it with a node name) creating nodes on the test\'s context '
     '(destroyed afterwards)."""'),
    ('iguana_ros/doctor.py',
     '    """(can a file be created in `folder` or, if it does not exist yet, in its nearest '
     'existing parent (tried\n'
     '    for real: permission bits say nothing to root or on a read-only mount), that folder)."""',
     '    """\n'
     '    Return (whether a file can be created in `folder`, else in its nearest existing parent; '
     'that folder).\n'
     '\n'
     '    The parent is tried when `folder` does not exist yet, and the test is for real: permission '
     'bits say nothing\n'
     '    to root or on a read-only mount.\n'
     '    """'),
    ('iguana_ros/supervisor/run.py',
     '        """Called while the run starts: raise if a child exited, the domain turned out to be '
     'shared or DDS does not\n'
     '        connect processes here; take in the run\'s messages."""',
     '        """\n'
     '        Raise if a child exited, the domain turned out to be shared or DDS does not connect '
     'processes here.\n'
     '\n'
     "        Then take in the run's messages. Called while the run starts.\n"
     '        """'),
]

# Verbs for the summaries of functions that neither return a value nor yield (D401), by (file, qualname).
VERBS = {
    ('iguana_ros/scene.py', '_check_grid'): 'Check that',
    ('iguana_ros/scene.py', '_check_heightmap'): 'Check that',
    ('iguana_ros/supervisor/progress_monitor.py', 'RunMonitor.launched'): 'Note that',
    ('iguana_ros/supervisor/progress_monitor.py', 'RunMonitor._on_event'): 'Handle',
    ('iguana_ros/supervisor/progress_monitor.py', 'RunMonitor._on_state'): 'Handle',
    ('iguana_ros/supervisor/progress_monitor.py', 'RunMonitor._on_goals'): 'Handle',
    ('iguana_ros/supervisor/run.py', 'SceneRun.start'): 'Start the',
    ('iguana_ros/faults/processes.py', '_check_bag'): 'Check',
    ('iguana_ros/nodes/simulator_node.py', 'SimulatorNode._make_io'): 'Make',
    ('iguana_ros/physics/simulator.py', 'SoftBodySimulator._build_model_arrays'): 'Build',
    ('iguana_ros/sweep/spec.py', '_check_knobs'): 'Check:',
    ('iguana_ros/ros/cdr.py', 'CdrWriter.__init__'): 'Start',
    ('iguana_ros/ros/cdr.py', 'CdrWriter.string'): 'Write',
    ('iguana_ros/ros/cdr.py', 'CdrWriter.sequence'): 'Write',
    ('iguana_ros/cli/bench_faults.py', 'add_run_options'): 'Add',
    ('iguana_ros/view/scene.py', 'Series.__init__'): 'Start',
    ('iguana_ros/view/server.py', 'ViewerPage._on_click'): 'Handle',
    ('iguana_ros/view/server.py', 'ViewerPage._show_playback'): 'Show',
    ('iguana_ros/view/server.py', 'ViewerPage._draw_terrain'): 'Draw',
    ('iguana_ros/view/server.py', 'ViewerPage._draw_mesh'): 'Draw',
    ('iguana_ros/view/server.py', 'ViewerPage._draw_path'): 'Draw',
    ('iguana_ros/view/decode.py', '*'): 'Take',
    ('test/nodes/test_end_to_end.py', '_assert_roots_equal_library'): 'Assert that',
}
# First words that are verbs for sure: replaced by their imperative ('Returns' -> 'Return'), not prefixed.
THIRD_PERSON_VERBS = {
    'returns', 'yields', 'gets', 'computes', 'creates', 'builds', 'makes', 'raises', 'writes', 'reads', 'loads',
    'saves', 'adds', 'starts', 'sends', 'publishes', 'converts', 'parses', 'finds', 'applies', 'handles',
    'waits', 'prints', 'renders',
}
# Words a summary that has no ', ' or ' (' to split at is split before, if it must be: the last that fits of
# the first tier, else of the second; never right after one of them or an article.
CLAUSE_WORDS = ('where which whose that when while after before with if unless until'.split(),
                'for from between along over into on at by in to as and or of per than'.split())
ARTICLES = {'a', 'an', 'the'}
ABBREVIATIONS = {'e.g', 'i.e', 'etc', 'vs', 'cf', 'approx', 'resp', 'incl', 'al', 'eq', 'fig', 'no'}
KEEP_CASE = {'True', 'False', 'None'}

problems: list[str] = []
LOCAL_MODULES = {p.stem for p in (ROOT / 'test').rglob('*.py')} - {'conftest'}


def problem(path: str, line: int, text: str) -> None:
    """Record something the tool could not fix."""
    problems.append(f'{path}:{line}: {text}')


def flake8_options() -> configparser.SectionProxy:
    """Return setup.cfg's [flake8] section."""
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / 'setup.cfg')
    return cfg['flake8']


def source_files() -> list[Path]:
    """Return every .py file the lint tests check, skipping folders that start with '.' or '_'."""
    files = [ROOT / name for name in SOURCE_FILES if (ROOT / name).is_file()]
    for folder in SOURCE_DIRS:
        for dirpath, dirnames, filenames in os.walk(ROOT / folder):
            dirnames[:] = sorted(d for d in dirnames if d[0] not in '._')
            files.extend(Path(dirpath) / f for f in sorted(filenames) if f.endswith('.py'))
    return files


# ----------------------------------------------------------------------------------------------------------
# Offsets


class Source:
    """A module's text with conversions between (line, UTF-8 column) and character offsets."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.lines = text.splitlines(keepends=True)
        self.starts = [0]
        for line in self.lines:
            self.starts.append(self.starts[-1] + len(line))

    def offset(self, lineno: int, col_bytes: int) -> int:
        """Return the character offset of an ast position."""
        line = self.lines[lineno - 1]
        return self.starts[lineno - 1] + len(line.encode()[:col_bytes].decode())

    def node_span(self, node: ast.AST) -> tuple[int, int]:
        """Return the character span of a node."""
        return self.offset(node.lineno, node.col_offset), self.offset(node.end_lineno, node.end_col_offset)


def apply_edits(text: str, edits: list[tuple[int, int, str]]) -> str:
    """Replace the spans (start, end) of `text` by the strings, which must not overlap."""
    for start, end, new in sorted(edits, key=lambda e: (e[0], e[1]), reverse=True):
        text = text[:start] + new + text[end:]
    return text


# ----------------------------------------------------------------------------------------------------------
# 1. Patches


def apply_patches(rel: str, text: str, report: bool = True) -> str:
    """Apply the PATCHES of file `rel` (a patch is stale if its text is gone from a file the tool never ran on)."""
    report = report and not COPYRIGHT_RE.search(text)
    for path, old, new in PATCHES:
        if path != rel:
            continue
        if text.count(old) == 1:
            text = text.replace(old, new)
        elif new not in text and report:
            problem(rel, 0, f'stale patch, its text is gone: {old[:60]!r}')
    return text


# ----------------------------------------------------------------------------------------------------------
# 2. dict(a=1) -> {'a': 1}


def fix_dict_calls(text: str) -> str:
    """Rewrite dict() calls with keyword arguments only as dict displays (C408)."""
    src = Source(text)
    edits = []
    for node in ast.walk(ast.parse(text)):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == 'dict'
                and not node.args and node.keywords and all(k.arg for k in node.keywords)):
            continue
        start, end = src.node_span(node)
        func_end = src.offset(node.func.end_lineno, node.func.end_col_offset)
        paren = text.index('(', func_end)
        edits.append((start, paren + 1, '{'))
        edits.append((end - 1, end, '}'))
        for kw in node.keywords:
            kw_start = src.offset(kw.lineno, kw.col_offset)
            value_start = src.offset(kw.value.lineno, kw.value.col_offset)
            edits.append((kw_start, value_start, f"'{kw.arg}': "))
        paren_col = paren - src.starts[node.lineno - 1]
        for lineno in range(node.lineno + 1, node.end_lineno + 1):
            line = src.lines[lineno - 1]
            if len(line) - len(line.lstrip(' ')) == paren_col + 1:
                edits.append((src.starts[lineno - 1], src.starts[lineno - 1] + 4, ''))
    return apply_edits(text, edits)


# ----------------------------------------------------------------------------------------------------------
# 3. Quotes


def fix_quotes(text: str) -> str:
    """Single quotes for inline strings, double for multi-line ones, no escaped quotes (Q000, Q001, Q003)."""
    from flake8_quotes.docstring_detection import get_docstring_tokens

    tokens = list(tokenize.generate_tokens(io.StringIO(text).readline))
    docstrings = get_docstring_tokens(tokens)
    src = Source(text)
    edits = []
    for tok in tokens:
        if tok.type != tokenize.STRING or tok.string[-1] not in '\'"' or tok in docstrings:
            continue
        quote_at = tok.string.index(tok.string[-1])
        prefix, rest = tok.string[:quote_at], tok.string[quote_at:]
        raw = 'r' in prefix.lower()
        new = None
        if rest[:3] in ('"""', "'''"):
            body = rest[3:-3]
            if rest[:3] == "'''" and '"""' not in body and not body.endswith('"'):
                new = f'{prefix}"""{body}"""'
        else:
            body = rest[1:-1]
            if rest[0] == '"' and "'" not in body and not (raw and '\\"' in body):
                new = f"{prefix}'{body if raw else body.replace(chr(92) + chr(34), chr(34))}'"
            elif rest[0] == "'" and not raw and "\\'" in body and '"' not in body:
                new = f'{prefix}"{body.replace(chr(92) + chr(39), chr(39))}"'
        if new is not None and new != tok.string:
            start = src.starts[tok.start[0] - 1] + tok.start[1]
            edits.append((start, start + len(tok.string), new))
    return apply_edits(text, edits)


# ----------------------------------------------------------------------------------------------------------
# 4. Imports


def _import_text(stmt: ast.ImportFrom, original: str, max_line: int) -> str | None:
    """Return the text of `stmt` with its names sorted, None if it carries comments inside."""
    from flake8_import_order.styles import Google

    code, _, comment = original.rstrip('\n').partition('#')
    if comment and '\n' in original.rstrip('\n'):
        return None
    comment = '  #' + comment if comment else ''
    names = sorted(stmt.names, key=lambda a: Google.name_key(a.name))
    parts = [a.name + (f' as {a.asname}' if a.asname else '') for a in names]
    head = f'from {"." * stmt.level}{stmt.module or ""} import '
    one = head + ', '.join(parts) + comment
    if len(one) <= max_line:
        return one + '\n'
    hanging = code.split('\n')[0].rstrip().endswith('(')
    indent = ' ' * 4 if hanging else ' ' * (len(head) + 1)
    lines = [head + '(' if hanging else '']
    current = '' if hanging else head + '('
    for i, part in enumerate(parts):
        piece = part + (', ' if i < len(parts) - 1 else ')')
        if current.strip() and len((current + piece).rstrip()) > max_line:
            lines.append(current.rstrip())
            current = indent
        elif not current:
            current = indent
        current += piece
    lines.append(current.rstrip() + comment)
    return '\n'.join(line for line in lines if line) + '\n'


def _import_runs(text: str, app_names: list[str]) -> tuple[list[list[ast.stmt]], dict]:
    """Return the blocks of consecutive module-level imports and flake8-import-order's view of each, by line."""
    from flake8_import_order import ImportVisitor

    tree = ast.parse(text)
    visitor = ImportVisitor(app_names, [])
    visitor.visit(tree)
    runs, current = [], []
    for stmt in tree.body:
        if isinstance(stmt, (ast.Import, ast.ImportFrom)):
            current.append(stmt)
        elif current:
            runs.append(current)
            current = []
    if current:
        runs.append(current)
    return runs, {ci.lineno: ci for ci in visitor.imports}


def _noqa_between_blocks(rel: str, text: str, app_names: list[str], max_line: int) -> str:
    """Add I100 to the noqa of a block's first import when code between blocks keeps it after a later one."""
    from flake8_import_order.styles import Google

    runs, classified = _import_runs(text, app_names)
    lines = text.splitlines(keepends=True)
    for previous, run in zip(runs, runs[1:]):
        if Google.import_key(classified[run[0].lineno]) >= Google.import_key(classified[previous[-1].lineno]):
            continue
        i = run[0].lineno - 1
        line = lines[i].rstrip('\n')
        m = re.search(r'# noqa(: ?(?P<codes>[A-Z0-9, ]+))?$', line)
        if m and not m.group('codes'):
            continue
        if m and 'I100' in m.group('codes'):
            continue
        line = line + ', I100' if m else line + '  # noqa: I100'
        if len(line) > max_line:
            problem(rel, i + 1, 'I100 across code between import blocks: noqa does not fit')
            continue
        lines[i] = line + '\n'
    return ''.join(lines)


def fix_imports(rel: str, text: str, app_names: list[str], max_line: int) -> str:
    """Sort each block of module-level imports as flake8-import-order's google style does."""
    from flake8_import_order.styles import Google

    runs, classified = _import_runs(text, app_names)
    for ci in classified.values():
        if ci.package in LOCAL_MODULES and ci.package not in app_names:
            problem(rel, ci.lineno, f'{ci.package} is a test module: add it to application-import-names')
    src = Source(text)
    edits = []
    for run in runs:
        if any(a.end_lineno >= b.lineno for a, b in zip(run, run[1:])):
            problem(rel, run[0].lineno, 'import statements share a line: left alone')
            continue
        chunks = []
        for i, stmt in enumerate(run):
            first = run[i - 1].end_lineno + 1 if i else stmt.lineno
            comments = [line for line in src.lines[first - 1:stmt.lineno - 1] if line.strip()]
            original = ''.join(src.lines[stmt.lineno - 1:stmt.end_lineno])
            body = original
            if isinstance(stmt, ast.ImportFrom) and Google.sorted_names([a.name for a in stmt.names]) != [
                    a.name for a in stmt.names]:
                body = _import_text(stmt, original, max_line)
                if body is None:
                    problem(rel, stmt.lineno, 'unsorted names with comments inside: left alone')
                    body = original
            ci = classified[stmt.lineno]
            chunks.append((Google.import_key(ci), ci.type, ''.join(comments) + body))
        chunks.sort(key=lambda c: c[0])
        out, previous = [], None
        for _, kind, chunk in chunks:
            if previous is not None and kind != previous:
                out.append('\n')
            out.append(chunk)
            previous = kind
        start = src.starts[run[0].lineno - 1]
        end = src.starts[run[-1].end_lineno]
        if ''.join(out) != text[start:end]:
            edits.append((start, end, ''.join(out)))
    return _noqa_between_blocks(rel, apply_edits(text, edits), app_names, max_line)


# ----------------------------------------------------------------------------------------------------------
# Layout: continuation lines and blank lines


def _pycodestyle(text: str, codes: list[str], max_line: int) -> list[tuple[int, int, str]]:
    """Return (line, column, code) of the pycodestyle `codes` found in `text`."""
    import pycodestyle

    class Collect(pycodestyle.BaseReport):
        def __init__(self, options) -> None:
            super().__init__(options)
            self.found = []

        def error(self, line_number, offset, text, check):
            code = super().error(line_number, offset, text, check)
            if code:
                self.found.append((line_number, offset, code))
            return code

    style = pycodestyle.StyleGuide(select=codes, max_line_length=max_line, reporter=Collect, quiet=True)
    checker = pycodestyle.Checker(lines=text.splitlines(keepends=True), options=style.options)
    checker.check_all()
    return checker.report.found


def _visual_indent(text: str, lineno: int) -> int | None:
    """Return the column after the innermost bracket open at the start of line `lineno`, if text follows it."""
    stack: list[list] = []
    awaiting = None
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type in (tokenize.NL, tokenize.COMMENT):
            continue
        if awaiting is not None:
            stack[awaiting][2] = tok.start[0] == stack[awaiting][0]
            awaiting = None
        if tok.start[0] >= lineno:
            return stack[-1][1] + 1 if stack and stack[-1][2] else None
        if tok.type == tokenize.OP and tok.string in '([{':
            stack.append([tok.start[0], tok.start[1], False])
            awaiting = len(stack) - 1
        elif tok.type == tokenize.OP and tok.string in ')]}' and stack:
            stack.pop()
    return None


def fix_layout(rel: str, text: str, max_line: int) -> str:
    """Align continuation lines with their bracket (E127, E128) and fix blank lines (E302, E303, E305, W391)."""
    for _ in range(5):
        found = _pycodestyle(text, ['E127', 'E128', 'E302', 'E303', 'E305', 'W391'], max_line)
        if not found:
            break
        lines = text.splitlines(keepends=True)
        for lineno, _, code in sorted(found, reverse=True):
            i = lineno - 1
            if code in ('E127', 'E128'):
                want = _visual_indent(text, lineno)
                if want is None:
                    problem(rel, lineno, f'{code}: no visual indent to align with')
                    continue
                lines[i] = ' ' * want + lines[i].lstrip(' ')
            elif code == 'W391':
                while lines and not lines[-1].strip():
                    lines.pop()
            else:
                k = i
                while k > 0 and lines[k - 1].lstrip().startswith('#'):
                    k -= 1
                j = k
                while j > 0 and not lines[j - 1].strip():
                    j -= 1
                blank = 2 if code != 'E303' or not lines[i][:1].isspace() else 1
                lines[j:k] = ['\n'] * blank
        text = ''.join(lines)
    return text


# ----------------------------------------------------------------------------------------------------------
# 5. Docstrings


def definitions(tree: ast.Module) -> list[tuple[str, ast.AST]]:
    """Return (qualname, node) for the module and every class and function in it."""
    out = [('', tree)]
    seen: dict[str, int] = {}

    def visit(node: ast.AST, qual: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                name = f'{qual}.{child.name}' if qual else child.name
                seen[name] = seen.get(name, 0) + 1
                out.append((name if seen[name] == 1 else f'{name}#{seen[name]}', child))
                visit(child, name)
            else:
                visit(child, qual)

    visit(tree, '')
    return out


def docstring_of(node: ast.AST) -> ast.Constant | None:
    """Return the docstring node of a module, class or function."""
    if not isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
        return None
    body = node.body
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
            and isinstance(body[0].value.value, str):
        return body[0].value
    return None


def _own_nodes(function: ast.AST):
    """Yield the nodes of a function's body outside nested functions and classes."""
    stack = list(function.body)
    while stack:
        node = stack.pop()
        yield node
        stack.extend(c for c in ast.iter_child_nodes(node)
                     if not isinstance(c, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda, ast.ClassDef)))


def default_verb(function: ast.AST) -> str | None:
    """Return 'Yield' for a generator, 'Return' for a function that returns a value, else None."""
    nodes = list(_own_nodes(function))
    if any(isinstance(n, (ast.Yield, ast.YieldFrom)) for n in nodes):
        return 'Yield'
    if any(isinstance(n, ast.Return) and n.value is not None
           and not (isinstance(n.value, ast.Constant) and n.value.value is None) for n in nodes):
        return 'Return'
    return None


def _depths(text: str) -> list[int]:
    """Return the bracket-and-backtick depth before each character of `text`."""
    depth, tick, out = 0, False, []
    for ch in text:
        out.append(depth + tick)
        if ch == '`':
            tick = not tick
        elif not tick and ch in '([{':
            depth += 1
        elif not tick and ch in ')]}':
            depth = max(0, depth - 1)
    return out


def with_period(text: str) -> str:
    """End `text` with a period (a trailing ',', ';' or ':' becomes one)."""
    text = text.rstrip()
    if text.endswith('.'):
        return text
    if text[-1:] in ',;:':
        return text[:-1] + '.'
    return text + '.'


def split_summary(text: str, width: int, force: bool = False, keep: frozenset = frozenset()) \
        -> tuple[str, str] | None:
    """Return (summary, rest): `text` if it fits in `width` with its period, else split as the module doc says."""
    if not force and len(with_period(text)) <= width:
        return with_period(text), ''
    depth = _depths(text)
    for i in range(len(text) - 1):
        if text[i] in '.:;' and text[i + 1] == ' ' and depth[i] == 0 and depth[i + 1] == 0:
            word = text[:i].split()[-1].lstrip('(').lower() if text[:i].split() else ''
            if text[i] == '.' and word in ABBREVIATIONS:
                continue
            summary = with_period(text[:i + 1])
            if len(summary) <= width:
                rest = text[i + 2:].lstrip()
                return summary, (_capitalised(rest, keep) if text[i] in ':;' else rest)
            break
    best = None
    for i in range(len(text) - 1):
        if depth[i] != 0:
            continue
        if text[i:i + 2] == ', ':
            summary, rest = text[:i] + '.', text[i + 2:]
        elif text[i:i + 2] == ' (' and depth[i + 1] == 0:
            summary, rest = text[:i] + '.', text[i + 1:]
        else:
            continue
        if len(summary) <= width and rest.strip() and len(summary.split()) >= 3:
            best = (summary, rest.lstrip())
    words_before = {w for tier in CLAUSE_WORDS for w in tier} | ARTICLES | {'so', 'such', 'not'}
    for tier in CLAUSE_WORDS:
        if best is not None:
            break
        for m in re.finditer(r'(\S+) (?=(\w+) )', text):
            i = m.end() - 1
            summary = with_period(text[:i])
            if (depth[i] == 0 and m.group(2) in tier and m.group(1).lower() not in words_before
                    and len(summary) <= width and len(summary.split()) >= 3):
                best = (summary, text[i + 1:])
    return best


def _capitalised(text: str, keep: frozenset) -> str:
    """Capitalise the first word of `text` if it is a plain lower-case word, not a name in `keep`."""
    m = re.match(r'([a-z]+)(?=[,;:.)]?(\s|$))', text)
    if m and m.group(1) not in keep:
        return text[0].upper() + text[1:]
    return text


def _is_structural(line: str, previous: str) -> bool:
    """Whether a docstring line is part of a list, a table, code or a literal block."""
    return (line[:1] == ' ' or previous.rstrip().endswith('::')
            or re.match(r'([-*+\u2022] |\d+[.)] |>>>|\||\.\. |:\w)', line) is not None)


def _wrap(text: str, width: int) -> list[str]:
    """Return `text` filled to `width`, breaking lines only at spaces outside backticks."""
    if text.count('`') % 2:
        return textwrap.wrap(text, width, break_long_words=False, break_on_hyphens=False)
    lines, line = [], ''
    for word in re.findall(r'(?:`[^`]*`|[^\s`])+', text):
        if line and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = word
        else:
            line = f'{line} {word}' if line else word
    return lines + [line] if line else lines


def _rewrap_long(rel: str, line: int, lines: list[str], width: int) -> list[str]:
    """Re-flow the plain paragraphs of `lines` that have a line longer than `width`."""
    out, para = [], []

    def flush() -> None:
        if para and any(len(p) > width for p in para):
            if any(_is_structural(p, q) for p, q in zip(para[1:], para)) or para[0][:1] == ' ':
                problem(rel, line, 'long line in a structured docstring paragraph: left alone')
                out.extend(para)
            else:
                out.extend(_wrap(' '.join(p.strip() for p in para), width))
        else:
            out.extend(para)
        para.clear()

    for text in lines:
        if text.strip():
            para.append(text)
        else:
            flush()
            out.append('')
    flush()
    return out


class DocFixer:
    """The docstring rewrite of one module (step 5 of the module doc)."""

    def __init__(self, rel: str, text: str, max_line: int, proper_words: set[str]) -> None:
        self.rel, self.text, self.max_line, self.proper_words = rel, text, max_line, proper_words

    def errors(self) -> dict[int, set[str]]:
        """Return the docstring codes ament_pep257 and flake8 report, by docstring line."""
        from ament_pep257.main import _ament_ignore
        from pydocstyle.checker import ConventionChecker

        out: dict[int, set[str]] = {}
        for error in ConventionChecker().check_source(self.text, self.rel):
            if error.code not in _ament_ignore:
                out.setdefault(error.line, set()).add(error.code)
        return out

    def first_word(self, text: str, function: ast.AST | None, qual: str, codes: set[str], line: int) -> str:
        """Apply D403 and D401 to the first word of the summary text."""
        from pydocstyle.wordlists import IMPERATIVE_VERBS, stem

        word, _, rest = text.partition(' ')
        if 'D403' in codes:
            args = {a.arg for a in ast.walk(function.args) if isinstance(a, ast.arg)} if function else set()
            codeish = (any(c.isupper() for c in word[1:]) or len(word) == 1 or word in args
                       or word in self.imported or word == 'iguana')
            word = f'`{word}`' if codeish else word[0].upper() + word[1:]
        if 'D401' in codes and function is not None:
            bare = re.sub(r'[\W_]+', '', word).lower()
            forms = IMPERATIVE_VERBS.get(stem(bare), set())
            if bare in THIRD_PERSON_VERBS and forms:
                best = max(forms, key=lambda f: len(os.path.commonprefix([bare, f])))
                return best.capitalize() + word[len(bare):] + (' ' + rest if rest else '')
            verb = VERBS.get((self.rel, qual)) or default_verb(function) or VERBS.get((self.rel, '*'))
            if verb is None:
                problem(self.rel, line, f'D401: no verb for {qual} (add it to VERBS)')
                return text
            alpha = re.match(r'[A-Za-z]+', word)
            plain = alpha.group() if alpha else ''
            if (plain.istitle() and (len(plain) > 1 or plain == 'A') and word[len(plain):] in ',;:'
                    and plain not in KEEP_CASE and plain not in self.proper_words):
                word = word.lower()
            return f'{verb} {word}' + (' ' + rest if rest else '')
        return word + (' ' + rest if rest else '')

    def run(self) -> str:
        """Return the module text with its docstrings rewritten."""
        tree = ast.parse(self.text)
        src = Source(self.text)
        errors = self.errors()
        self.imported = set()
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                self.imported.update(a.name.split('.')[0] for a in node.names)
                self.imported.update(a.asname for a in node.names if a.asname)
                if isinstance(node, ast.ImportFrom) and node.module:
                    self.imported.add(node.module.split('.')[0])
        edits = []
        for qual, node in definitions(tree):
            doc = docstring_of(node)
            if doc is None:
                continue
            start, end = src.node_span(doc)
            literal = self.text[start:end]
            codes = errors.get(doc.lineno, set())
            long_lines = any(len(line.rstrip('\n')) > self.max_line
                             for line in src.lines[doc.lineno - 1:doc.end_lineno])
            if not codes and not long_lines:
                continue
            new = self.rewrite(literal, doc, node, qual, codes, src)
            if new is not None and new != literal:
                edits.append((start, end, new))
        return apply_edits(self.text, edits)

    def rewrite(self, literal: str, doc: ast.Constant, node: ast.AST, qual: str, codes: set[str],
                src: Source) -> str | None:
        """Return the new literal of one docstring."""
        line = doc.lineno
        m = re.fullmatch(r'([rRuU]?)("""|\'\'\'|"|\')(.*)\2', literal, re.S)
        if m is None or len(list(tokenize.generate_tokens(io.StringIO(literal).readline))) > 3:
            problem(self.rel, line, 'docstring is not a single plain string literal: left alone')
            return None
        prefix, quote, body = m.groups()
        value = doc.value
        if body != value:
            raw = f'r"""{value}"""'
            if '\\' in value and '"""' not in value and not value.endswith(('\\', '"')) \
                    and ast.literal_eval(raw) == value:
                prefix, body = 'r', value
            else:
                problem(self.rel, line, 'docstring with escapes that a raw string cannot hold: left alone')
                return None
        quote = '"""'
        indent = ' ' * (len(src.lines[line - 1].encode()[:doc.col_offset].decode()))
        lines = body.split('\n')
        content = [lines[0].strip()] + [(ln[len(indent):] if ln.startswith(indent) else ln.lstrip()).rstrip()
                                        for ln in lines[1:]]
        while content and not content[0]:
            content.pop(0)
        while content and not content[-1]:
            content.pop()
        if not content:
            return None
        k = 1
        while k < len(content) and content[k] and not _is_structural(content[k], content[k - 1]):
            k += 1
        text = ' '.join(c.strip() for c in content[:k])
        after = content[k:]
        while after and not after[0]:
            after.pop(0)
        function = node if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) else None
        text = self.first_word(text, function, qual, codes, line)
        width = self.max_line - len(indent)
        one_line = width - len(prefix) - 6
        if not after and len(with_period(text)) <= one_line:
            return f'{prefix}{quote}{with_period(text)}{quote}'
        keep = frozenset(self.imported | ({a.arg for a in ast.walk(function.args) if isinstance(a, ast.arg)}
                                          if function else set()))
        split = split_summary(text, width, force=not after and len(with_period(text)) <= width, keep=keep)
        if split is None:
            problem(self.rel, line, f'summary does not fit and has no place to split: {text[:70]!r}')
            return None
        summary, rest = split
        description = _wrap(rest, width) if rest else []
        if description and after:
            description.append('')
        description += _rewrap_long(self.rel, line, after, width)
        if summary.endswith(('?.', '!.')):
            problem(self.rel, line, 'summary ends with ? or !')
        body_lines = [summary, ''] + description
        out = '\n' + '\n'.join(indent + b if b else '' for b in body_lines) + '\n' + indent
        return f'{prefix}{quote}{out}{quote}'


def proper_words(texts: list[str]) -> set[str]:
    """Return the capitalised words that occur after a lower-case word in docstrings (names, not sentence starts)."""
    words = set()
    for text in texts:
        for doc in _all_docstrings(text):
            words.update(re.findall(r'(?<=[a-z,] )[A-Z][a-z]+\b', doc))
    return words


def _all_docstrings(text: str) -> list[str]:
    try:
        tree = ast.parse(text)
    except SyntaxError:
        return []
    return [d.value for _, n in definitions(tree) if (d := docstring_of(n)) is not None]


# ----------------------------------------------------------------------------------------------------------
# 6. Copyright header


def fix_header(rel: str, text: str) -> str:
    """Put the license header after any shebang or encoding line, unless the file has it."""
    if not text.strip():
        return text  # ament_copyright skips empty files
    lines = text.splitlines(keepends=True)
    n = 0
    while n < len(lines) and (lines[n].startswith('#!') or re.match(r'#.*coding[:=]', lines[n])):
        n += 1
    first = n
    while first < len(lines) and not lines[first].strip():
        first += 1
    if first < len(lines) and COPYRIGHT_RE.match(lines[first]):
        expected = HEADER.splitlines(keepends=True)[1:]
        if lines[first + 1:first + 1 + len(expected)] != expected:
            problem(rel, first + 1, 'a copyright line without our license header: left alone')
        return text
    before = ''.join(lines[:n]) + ('\n' if n else '')
    return before + HEADER + '\n' + ''.join(lines[n:]).lstrip('\n')


# ----------------------------------------------------------------------------------------------------------
# The AST check


class _Normalise(ast.NodeTransformer):
    """Make equal what the tool may change: import order within a block, dict() as a display, docstrings."""

    def generic_visit(self, node: ast.AST) -> ast.AST:
        node = super().generic_visit(node)
        for field in ('body', 'orelse', 'finalbody'):
            stmts = getattr(node, field, None)
            if isinstance(stmts, list):
                setattr(node, field, self._sort_imports(stmts))
        if isinstance(node, ast.ImportFrom):
            node.names = sorted(node.names, key=lambda a: (a.name, a.asname or ''))
        if docstring_of(node) is not None:
            docstring_of(node).value = ''
        return node

    @staticmethod
    def _sort_imports(stmts: list) -> list:
        out, run = [], []
        for stmt in stmts + [None]:
            if isinstance(stmt, (ast.Import, ast.ImportFrom)):
                run.append(stmt)
                continue
            out.extend(sorted(run, key=ast.dump))
            run = []
            if stmt is not None:
                out.append(stmt)
        return out

    def visit_Call(self, node: ast.Call) -> ast.AST:  # noqa: N802
        node = self.generic_visit(node)
        if isinstance(node.func, ast.Name) and node.func.id == 'dict' and not node.args and node.keywords \
                and all(k.arg for k in node.keywords):
            return ast.Dict(keys=[ast.Constant(k.arg) for k in node.keywords], values=[k.value for k in node.keywords])
        return node


def _doc_words(text: str) -> list[str]:
    return [w.lower() for w in re.findall(r'[^\s.,;:`]+', text)]


def _same_words(old: str, new: str) -> bool:
    """Whether docstring `new` keeps every word of `old`, allowing a verb in front (D401)."""
    from pydocstyle.wordlists import IMPERATIVE_VERBS, stem

    a, b = _doc_words(old), _doc_words(new)
    if a == b:
        return True
    if a and b and a[1:] == b[1:] and b[0] in IMPERATIVE_VERBS.get(stem(a[0]), set()):
        return True
    prefixes = {'return', 'yield'} | {v.lower() for v in VERBS.values()}
    for p in prefixes:
        words = _doc_words(p)
        if b[:len(words)] == words and b[len(words):] == a:
            return True
    return False


def check_ast(rev: str) -> int:
    """Compare every source file with its version at `rev`; return the number of files that differ."""
    bad = 0
    for path in source_files():
        rel = path.relative_to(ROOT).as_posix()
        shown = subprocess.run(['git', 'show', f'{rev}:{rel}'], cwd=ROOT, capture_output=True, text=True)
        if shown.returncode != 0:
            continue
        old_text = apply_patches(rel, shown.stdout, report=False)
        new_text = path.read_text()
        old_tree, new_tree = ast.parse(old_text), ast.parse(new_text)
        old_docs = {q: d.value for q, n in definitions(old_tree) if (d := docstring_of(n)) is not None}
        new_docs = {q: d.value for q, n in definitions(new_tree) if (d := docstring_of(n)) is not None}
        if old_docs.keys() != new_docs.keys():
            print(f'{rel}: docstrings added or removed: {sorted(old_docs.keys() ^ new_docs.keys())}')
            bad += 1
            continue
        changed = [q for q in old_docs if not _same_words(old_docs[q], new_docs[q])]
        for q in changed:
            print(f'{rel}: docstring of {q or "<module>"} lost or changed words:\n  old: {old_docs[q]!r}\n'
                  f'  new: {new_docs[q]!r}')
        if ast.dump(_Normalise().visit(old_tree)) != ast.dump(_Normalise().visit(new_tree)):
            print(f'{rel}: code differs beyond docstrings, import order and PATCHES')
            bad += 1
        elif changed:
            bad += 1
    print(f'--check-ast against {rev}: {bad} file(s) differ')
    return bad


# ----------------------------------------------------------------------------------------------------------


def fix_file(path: Path, proper: set[str], app_names: list[str], max_line: int) -> bool:
    """Rewrite one file; return whether it changed."""
    rel = path.relative_to(ROOT).as_posix()
    text = original = path.read_text()
    text = apply_patches(rel, text)
    text = fix_dict_calls(text)
    text = fix_quotes(text)
    text = fix_imports(rel, text, app_names, max_line)
    text = fix_layout(rel, text, max_line)
    text = DocFixer(rel, text, max_line, proper).run()
    text = fix_header(rel, text)
    ast.parse(text)
    if text != original:
        path.write_text(text)
        return True
    return False


def main(argv: list[str] | None = None) -> int:
    """Run the tool (see the module doc)."""
    parser = argparse.ArgumentParser(description=__doc__.strip().split('\n')[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--check-ast', nargs='?', const='HEAD', metavar='REV',
                        help='compare every module with git show REV:path instead of rewriting')
    parser.add_argument('files', nargs='*', type=Path, help='only these files (default: all)')
    args = parser.parse_args(argv)
    if args.check_ast:
        return 1 if check_ast(args.check_ast) else 0
    options = flake8_options()
    max_line = int(options['max-line-length'])
    app_names = [n.strip() for n in options['application-import-names'].split(',') if n.strip()]
    files = [f.resolve() for f in args.files] or source_files()
    proper = proper_words([f.read_text() for f in source_files()])
    changed = sum(fix_file(f, proper, app_names, max_line) for f in files)
    print(f'{changed} of {len(files)} files changed')
    for line in problems:
        print(line)
    return 1 if problems else 0


if __name__ == '__main__':
    sys.exit(main())
