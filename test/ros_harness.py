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

"""Node-level test helpers: spin until a condition, real node processes, dumps of serialized messages."""
from __future__ import annotations

import base64
from collections.abc import Callable
import importlib.util
import json
from pathlib import Path
import signal
import sys
import time
import typing

import yaml

from iguana_ros.supervisor.process import NodeProcess as _PackageNodeProcess
from iguana_ros.supervisor.process import wait_for  # noqa: F401 (re-exported for tests)

REPO = Path(__file__).resolve().parent.parent
HELPERS = Path(__file__).resolve().parent / 'helpers'
IGUANA = [sys.executable, '-c', 'import sys; from iguana_ros.cli import main; sys.exit(main())']
"""Command line of the `iguana` CLI run with the test interpreter."""


PLAY_PAUSED = ['--start-paused', '--wait-for-subscribers', '30']
"""`iguana bag play` arguments of a test that resumes the player itself (`resume_player`)."""


def resume_player(node, topics: list[str], spin_once: Callable[[], None], timeout: float = 60.0,
                  playing: Callable[[], bool] = lambda: False) -> str:
    """
    Wait until `node`'s graph lists a publisher of every topic, then call the paused player's resume; its message.

    A reader has matched a writer once its node lists it: a volatile reader that matches `iguana bag play` after the
    player matched it misses the first messages, so a test that must get every message plays with PLAY_PAUSED.
    A ready service is only matched on the request's side: its reply can be lost (seen under load: the player played
    and the caller waited out its timeout), so once `playing()` (messages arrive) the call counts as answered, and
    with neither an answer nor messages it is sent again every RESUME_RETRY_S (resuming a playing player is harmless).
    """
    from iguana_ros.errors import IguanaError
    from iguana_ros.ros.endpoints import resolve_service
    deadline = time.monotonic() + timeout
    while not all(node.count_publishers(topic) for topic in topics):
        if time.monotonic() > deadline:
            raise IguanaError(f'no publisher of {[t for t in topics if not node.count_publishers(t)]} in {timeout} s')
        spin_once()
    name, srv_type = resolve_service('bag_player_resume')
    client = node.create_client(srv_type, '/' + name)
    try:
        while not client.service_is_ready():
            if time.monotonic() > deadline:
                raise IguanaError(f'no /{name} service in {timeout} s')
            spin_once()
        futures, sent = [], 0.0
        while not any(f.done() for f in futures):
            if time.monotonic() > deadline:
                raise IguanaError(f'/{name} did not answer in {timeout} s')
            if playing():
                return 'playing (messages arrive; the answer to resume did not come)'
            if not futures or time.monotonic() - sent > RESUME_RETRY_S:
                futures.append(client.call_async(srv_type.Request()))
                sent = time.monotonic()
            spin_once()
        return next(f for f in futures if f.done()).result().message
    finally:
        node.destroy_client(client)


RESUME_RETRY_S = 2.0
"""Seconds `resume_player` waits for the answer or the first message before it calls resume again."""


def spin_until(executor_or_node, predicate: Callable[[], bool], timeout: float = 10.0) -> bool:
    """Spin (executor or node) until `predicate()` is true; False if `timeout` s pass first."""
    executor, own = executor_or_node, False
    if not hasattr(executor, 'spin_once'):
        from rclpy.executors import SingleThreadedExecutor
        executor, own = SingleThreadedExecutor(context=executor_or_node.context), True
        executor.add_node(executor_or_node)
    try:
        deadline = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() > deadline:
                return False
            executor.spin_once(timeout_sec=0.02)
        return True
    finally:
        if own:
            executor.remove_node(executor_or_node)
            executor.shutdown()


class NodeProcess(_PackageNodeProcess):
    """The package's NodeProcess, run from the repository root."""

    def __init__(self, args: list[str], name: str = 'proc', log_dir: str | Path | None = None,
                 env: dict | None = None) -> None:
        super().__init__(args, name, log_dir, env, cwd=REPO)


class SceneRun(typing.NamedTuple):
    """A started `iguana run` of a scene written for a test: its process, scene file and bag directory."""

    process: NodeProcess
    scene: Path
    bag: Path


def start_scene_run(folder: Path, scene: dict, *args: str) -> SceneRun:
    """Write `scene` as folder/<name>.yaml and start `iguana run` of it recording folder/bag, with `args`."""
    path = folder / f'{scene["name"]}.yaml'
    path.write_text(yaml.safe_dump(scene))
    run = NodeProcess([*IGUANA, 'run', str(path), *args, '--record', str(folder / 'bag')], 'iguana_run', folder)
    run.start()
    return SceneRun(run, path, folder / 'bag')


def stop_scene_run(run: NodeProcess) -> None:
    """SIGTERM the run if it is still going (it finalises its bag), then reap it."""
    if run.running:
        run.proc.send_signal(signal.SIGTERM)
        wait_for(lambda: not run.running, 30.0, 0.1)
    run.stop()


def tool_module(name: str):
    """Load tools/<name>.py as a module (tools/ is not a package)."""
    spec = importlib.util.spec_from_file_location(name, REPO / 'tools' / f'{name}.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def helper(script: str, *args) -> list[str]:
    """Command line running test/helpers/<script> with the test interpreter."""
    return [sys.executable, str(HELPERS / script), *map(str, args)]


def write_dump(path: str | Path, records: list[tuple[str, bytes]], extra: dict | None = None) -> None:
    """Save (topic, serialized bytes) records (and extra info) as JSON for a test to compare."""
    Path(path).write_text(json.dumps({
        'messages': [[topic, base64.b64encode(data).decode()] for topic, data in records],
        'extra': extra or {}}))


def read_dump(path: str | Path) -> tuple[dict[str, list[bytes]], dict]:
    """({topic: [bytes, …] in order}, extra) of a dump written by `write_dump`."""
    data = json.loads(Path(path).read_text())
    by_topic: dict[str, list[bytes]] = {}
    for topic, b64 in data['messages']:
        by_topic.setdefault(topic, []).append(base64.b64decode(b64))
    return by_topic, data['extra']
