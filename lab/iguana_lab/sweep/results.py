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
A sweep's outputs.

The log of finished tasks (what `--resume` reads), the results table (CSV and JSON) and plots of its columns.

`rows.jsonl` gets one line {"key", "result"} per finished task as it finishes (flushed, so a sweep that is
stopped keeps what finished); `results.csv` has one column per row field (nested fields as dotted names, lists
as JSON text), `results.json` the rows as they are with the sweep's name, kind, timing columns and summary.
"""
from __future__ import annotations

import csv
import json
import math
from pathlib import Path
import re
from typing import Any, Iterator

from iguana_ros.errors import IguanaError, InputError

LOG_NAME = 'rows.jsonl'
TABLE_CSV = 'results.csv'
TABLE_JSON = 'results.json'


class ResultLog:
    """The finished tasks of a sweep in `out_dir`/rows.jsonl: read for a resume, appended as tasks finish."""

    def __init__(self, out_dir: Path, resume: bool) -> None:
        """
        Open the log.

        InputError if `out_dir` already holds a sweep's finished tasks and `resume` is False (nothing is overwritten),
        or if the folder cannot be written.
        """
        self.path = Path(out_dir) / LOG_NAME
        if self.path.exists() and self.path.stat().st_size and not resume:
            raise InputError(f'{out_dir} already holds the results of a sweep ({self.path.name}); pass --resume to '
                             f'continue it, or choose another folder with -o')
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = open(self.path, 'a', encoding='utf-8')
        except OSError as exc:
            raise InputError(f'cannot write the results to {out_dir}: {exc.strerror or exc}') from None

    def finished(self) -> dict[str, Any]:
        """{task key: result} of every task the log records (a line cut short by a crash is skipped)."""
        results = {}
        with open(self.path, encoding='utf-8') as fh:
            for line in fh:
                try:
                    entry = json.loads(line)
                    results[entry['key']] = entry['result']
                except (ValueError, KeyError, TypeError):
                    continue
        return results

    def append(self, key: str, result: Any) -> None:
        """Record one finished task (written through at once)."""
        self._file.write(json.dumps({'key': key, 'result': result}) + '\n')
        self._file.flush()

    def close(self) -> None:
        """Close the log file."""
        self._file.close()

    def __enter__(self) -> 'ResultLog':
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def flatten(row: dict, prefix: str = '') -> dict:
    """Return a row with nested mappings as dotted keys ({'terrain': {'seed': 1}} -> {'terrain.seed': 1})."""
    flat = {}
    for key, value in row.items():
        name = f'{prefix}{key}'
        if isinstance(value, dict) and value:
            flat.update(flatten(value, name + '.'))
        else:
            flat[name] = value
    return flat


def columns_of(rows: list[dict]) -> list[str]:
    """Every flattened column of `rows`, in first-seen order."""
    return list(dict.fromkeys(name for row in rows for name in flatten(row)))


def _cell(value: Any) -> Any:
    """Return a CSV cell: empty for None, JSON text for lists and mappings, the value otherwise (floats exact)."""
    if value is None:
        return ''
    if isinstance(value, (list, tuple, dict)):
        return json.dumps(value)
    return value


def write_table(out_dir: Path, rows: list[dict], meta: dict) -> list[Path]:
    """Write results.csv and results.json ({**meta, 'rows': rows}) in `out_dir`; their paths."""
    out_dir = Path(out_dir)
    names = columns_of(rows)
    csv_path, json_path = out_dir / TABLE_CSV, out_dir / TABLE_JSON
    with open(csv_path, 'w', encoding='utf-8', newline='') as fh:
        writer = csv.writer(fh)
        writer.writerow(names)
        for row in rows:
            flat = flatten(row)
            writer.writerow([_cell(flat.get(name)) for name in names])
    json_path.write_text(json.dumps({**meta, 'rows': rows}, indent=1), encoding='utf-8')
    return [csv_path, json_path]


def _series(rows: list[dict], plot) -> Iterator[tuple[Any, list, list]]:
    """
    Return (group value, x values, y values) per value of `plot.by` over the rows with a numeric y.

    Failed rows and missing values are left out; groups come in first-seen order.
    """
    groups: dict = {}
    for row in rows:
        flat = flatten(row)
        y = flat.get(plot.y)
        if flat.get('error') or not _is_number(y) or flat.get(plot.x) is None:
            continue
        group = json.dumps(flat.get(plot.by)) if plot.by else ''
        groups.setdefault(group, ([], []))
        groups[group][0].append(flat[plot.x])
        groups[group][1].append(float(y))
    for group, (xs, ys) in groups.items():
        yield (json.loads(group) if plot.by else None), xs, ys


def _is_number(value: Any) -> bool:
    """Return a finite int or float, not a bool."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def check_plot_columns(rows: list[dict], plots: tuple) -> None:
    """`IguanaError` (one line) if a plot names a column the table does not have."""
    names = set(columns_of(rows))
    for i, plot in enumerate(plots):
        for column in (plot.x, plot.y, plot.by):
            if column is not None and column not in names:
                raise IguanaError(f'plots[{i}]: the results have no column {column!r}; columns: '
                                  f'{", ".join(sorted(names))}')


def plot_path(out_dir: Path, plot) -> Path:
    """`out_dir`/plot_<y>_vs_<x>[_by_<by>].png (column names made file-safe)."""
    parts = [plot.y, 'vs', plot.x] + (['by', plot.by] if plot.by else [])
    return Path(out_dir) / ('plot_' + '_'.join(re.sub(r'[^A-Za-z0-9.-]+', '-', p) for p in parts) + '.png')


def plot_columns(rows: list[dict], plot, path: Path, title: str = '') -> Path:
    """
    Plot column `plot.y` against `plot.x`, one line per `plot.by` value, and save it as PNG at `path`.

    Numeric x is sorted; other x are categories in first-seen order.
    """
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    series = list(_series(rows, plot))
    categories = list(dict.fromkeys(json.dumps(x) for _, xs, _ in series for x in xs
                                    if not _is_number(x)))
    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=100)
    for group, xs, ys in series:
        if categories:
            xs = [categories.index(json.dumps(x)) if not _is_number(x) else x for x in xs]
        order = sorted(range(len(xs)), key=lambda k: xs[k])
        label = f'{plot.by} = {group}' if plot.by else None
        ax.plot([xs[k] for k in order], [ys[k] for k in order], marker='o', label=label)
    if categories:
        ax.set_xticks(range(len(categories)), [str(json.loads(c)) for c in categories], rotation=30, ha='right')
    ax.set_xlabel(plot.x)
    ax.set_ylabel(plot.y)
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    if plot.by and series:
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return Path(path)
