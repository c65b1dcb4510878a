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

"""Sweep outputs: the finished-task log (refused without --resume, a cut line skipped), the CSV/JSON table, plots."""
import csv
import json

import pytest

from iguana_lab.sweep.engine import in_order, is_engine_failure, Plan, row_stream, Task
from iguana_lab.sweep.results import check_plot_columns, flatten, plot_columns, plot_path, ResultLog, write_table
from iguana_lab.sweep.spec import PlotSpec
from iguana_ros.errors import IguanaError, InputError

ROWS = [
    {'scene': 'a', 'terrain': {'seed': 1, 'amplitude': 0.04}, 'friction': 0.5, 'adaptation': True,
     'stance_fraction': [0.5, 0.6], 'time_to_goal': 10.0, 'fell': False},
    {'scene': 'a', 'terrain': {'seed': 1, 'amplitude': 0.04}, 'friction': 1.0, 'adaptation': True,
     'time_to_goal': 1 / 3, 'fell': False, 'note': None},
    {'scene': 'b', 'terrain': {}, 'friction': 0.5, 'adaptation': False, 'error': 'InputError: no', 'wall_s': 0.1},
    {'scene': 'b', 'terrain': {}, 'friction': 1.0, 'adaptation': False, 'time_to_goal': 12.0},
]


def test_log_refuses_to_overwrite_and_resumes_skipping_a_cut_line(tmp_path):
    with ResultLog(tmp_path / 'out', resume=False) as log:
        log.append('k1', {'x': 1})
        log.append('k2', {'x': 2, 'error_type': 'KilledWorker'})
    with pytest.raises(InputError, match='already holds the results of a sweep.*--resume'):
        ResultLog(tmp_path / 'out', resume=False)
    with open(tmp_path / 'out' / 'rows.jsonl', 'a') as fh:
        fh.write('{"key": "k3", "resu')                                   # a crash in mid-line
    with ResultLog(tmp_path / 'out', resume=True) as log:
        finished = log.finished()
        assert finished == {'k1': {'x': 1}, 'k2': {'x': 2, 'error_type': 'KilledWorker'}}
        assert [is_engine_failure(r) for r in finished.values()] == [False, True]
    (tmp_path / 'empty').mkdir()
    (tmp_path / 'empty' / 'rows.jsonl').write_text('')                   # a sweep that never got going
    ResultLog(tmp_path / 'empty', resume=False).close()
    (tmp_path / 'file').write_text('x')
    with pytest.raises(InputError, match='cannot write the results to'):
        ResultLog(tmp_path / 'file' / 'out', resume=False)


def test_table_csv_and_json(tmp_path):
    assert flatten(ROWS[0])['terrain.amplitude'] == 0.04 and flatten(ROWS[2])['terrain'] == {}
    paths = write_table(tmp_path, ROWS, {'sweep': 's', 'timing_columns': ['wall_s']})
    assert [p.name for p in paths] == ['results.csv', 'results.json']
    with open(paths[0], newline='') as fh:
        table = list(csv.DictReader(fh))
    assert list(table[0]) == ['scene', 'terrain.seed', 'terrain.amplitude', 'friction', 'adaptation',
                              'stance_fraction', 'time_to_goal', 'fell', 'note', 'terrain', 'error', 'wall_s']
    assert float(table[1]['time_to_goal']) == 1 / 3                      # floats written exactly
    assert json.loads(table[0]['stance_fraction']) == [0.5, 0.6] and table[1]['note'] == ''
    assert table[2]['error'] == 'InputError: no' and table[2]['time_to_goal'] == ''
    assert json.loads(paths[1].read_text()) == {'sweep': 's', 'timing_columns': ['wall_s'], 'rows': ROWS}


def test_plots_of_numeric_and_categorical_columns(tmp_path):
    numeric = PlotSpec(x='friction', y='time_to_goal', by='adaptation')
    categorical = PlotSpec(x='scene', y='time_to_goal')
    for plot in (numeric, categorical):
        path = plot_columns(ROWS, plot, plot_path(tmp_path, plot), title='t')
        assert path.stat().st_size > 5000 and path.read_bytes()[:4] == b'\x89PNG'
    assert plot_path(tmp_path, PlotSpec('fidelity.dt', 'slip per/stride')).name == \
        'plot_slip-per-stride_vs_fidelity.dt.png'
    check_plot_columns(ROWS, (numeric, PlotSpec('terrain.seed', 'time_to_goal')))
    with pytest.raises(IguanaError, match="plots\\[1\\]: the results have no column 'speed'"):
        check_plot_columns(ROWS, (numeric, PlotSpec('friction', 'speed')))


def test_results_in_task_order_and_rows_as_soon_as_they_can_be_made():
    seen = []
    deliver = in_order(lambda k, r: seen.append((k, r)))
    for k in (2, 0, 3, 1):
        deliver(k, f'r{k}')
    assert seen == [(0, 'r0'), (1, 'r1'), (2, 'r2'), (3, 'r3')]
    plan = Plan([Task(str(k), print, (), {}, str(k)) for k in range(3)],
                rows=lambda results: [{'sum': sum(results[:k + 1])} for k in range(1, len(results))])
    shown = []
    stream = row_stream(plan, shown.append)
    stream(1, 10)
    assert shown == []                                                   # row 1 needs result 0
    stream(0, 1)
    stream(2, 100)
    assert shown == [{'sum': 11}, {'sum': 111}]
