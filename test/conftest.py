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
Session set-up shared by every test: an isolated ROS 2 domain and rclpy fixtures.

At session start ROS_DOMAIN_ID is set to a per-run value derived from the pid (1..200) unless
IGUANA_TEST_DOMAIN_ID gives one ('keep' keeps an already-set ROS_DOMAIN_ID); discovery is
localhost-only and the RMW is Fast DDS, so child processes inherit one private graph.
Tests marked `ros` get a 60 s pytest-timeout unless they set their own.
"""
from __future__ import annotations

import os

import pytest

ROS_TEST_TIMEOUT_S = 60


def _test_domain_id() -> str:
    """ROS_DOMAIN_ID for this run (see module docstring)."""
    wanted = os.environ.get('IGUANA_TEST_DOMAIN_ID', '')
    if wanted == 'keep' and os.environ.get('ROS_DOMAIN_ID'):
        return os.environ['ROS_DOMAIN_ID']
    if wanted.isdigit():
        return wanted
    return str(1 + os.getpid() % 200)


def pytest_configure(config) -> None:
    """Isolate this run's DDS traffic before any rclpy import or child process."""
    os.environ['ROS_DOMAIN_ID'] = _test_domain_id()
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ['RMW_IMPLEMENTATION'] = 'rmw_fastrtps_cpp'
    config.addinivalue_line('markers', 'timeout(seconds): pytest-timeout limit')


HEAVY_FIRST = ('test/view/test_view_browser.py', 'test/lab/sweep/test_sweep_engine.py',
               'test/lab/test_paper_experiments.py', 'test/physics/test_determinism.py',
               'test/supervisor/test_end_to_end.py', 'test/lab/faults/', 'test/cli/test_goal.py',
               'test/test_examples.py', 'test/nodes/', 'test/bag/')
"""Modules run first, the costliest first (worker seconds of a `make test`, 2 workers: browser 263, sweep engine 127,
paper experiments 88, ...): `--dist loadscope` hands modules out in this order, so the long ones do not start last
while the other worker has nothing left (the determinism test alone ran 55 s at the end of a 577 s run)."""


def _heavy_rank(item) -> int:
    """Return the position of `item`'s module in HEAVY_FIRST (len(HEAVY_FIRST) for the rest)."""
    path = item.nodeid.split('::')[0]
    return next((i for i, prefix in enumerate(HEAVY_FIRST) if path.startswith(prefix)), len(HEAVY_FIRST))


def pytest_collection_modifyitems(config, items) -> None:
    """Give every `ros` test a timeout so a hung DDS exchange fails instead of hanging; heavy modules first."""
    for item in items:
        if item.get_closest_marker('ros') and not item.get_closest_marker('timeout'):
            item.add_marker(pytest.mark.timeout(ROS_TEST_TIMEOUT_S))
    items.sort(key=_heavy_rank)                      # stable: each module keeps its order


@pytest.fixture
def ros_context():
    """Yield a fresh rclpy.Context, initialised for this test and shut down after it."""
    rclpy = pytest.importorskip('rclpy')
    context = rclpy.Context()
    rclpy.init(context=context)
    yield context
    from iguana_ros.ros.endpoints import release_context
    release_context(context)          # its nodes leave the graph now: a later run's domain check must not see them


@pytest.fixture
def make_node(ros_context):
    """
    Yield a factory `make_node` (call it with a node name) creating nodes on the test's context.

    The nodes are destroyed afterwards.
    """
    import rclpy
    nodes = []

    def factory(name: str = 'test_node', **kwargs):
        node = rclpy.create_node(name, context=ros_context, **kwargs)
        nodes.append(node)
        return node
    yield factory
    for node in nodes:
        node.destroy_node()


@pytest.fixture
def executor(ros_context):
    """Yield a SingleThreadedExecutor on the test's context (add nodes, then `spin_until(executor, …)`)."""
    from rclpy.executors import SingleThreadedExecutor
    ex = SingleThreadedExecutor(context=ros_context)
    yield ex
    ex.shutdown()


@pytest.fixture
def cli(capsys):
    """
    Yield a runner of the iguana CLI in this process: given ARGV, it returns (exit status, stdout, stderr).

    The arguments are passed through `str`, so paths may be given as they are.
    """
    from iguana_ros.cli import main

    def run(argv) -> tuple[int, str, str]:
        status = main([str(arg) for arg in argv])
        out, err = capsys.readouterr()
        return status, out, err
    return run
