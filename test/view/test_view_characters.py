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
A world's characters in the viewer (issue 33): every character drawn, one selected, goals to the selected one.

Without ROS: a bag's characters are its `.../mesh_marker` topics, named by their prefixes; a world's frames take the
world's terrain and goals; a page of two characters, through its websocket, sends both meshes and names and a
dropdown, a click on a body selects that character and a click on the terrain sends the goal to the selected one; a
lone iguana's page is as before. With ROS: the live viewer finds two characters on the graph (and a third, late one),
draws them, and a click on the terrain publishes the goal on the selected character's goal_pose, as a real
subscriber receives it.
"""
from __future__ import annotations

import threading
import time

import msgspec
import numpy as np
import pytest

from iguana_ros.constants import WORLD_FRAME
from iguana_ros.render.run import GoalSet
from iguana_ros.view.bag_source import characters, load_bag
from iguana_ros.view.scene import MeshFrame, RunView, WorldView
from iguana_ros.view.server import ViewerPage
from view_harness import body, CAMERA, CLICK, connect, FakeLive, GREEN, PageFeed, PLACES, SQUARE, wait_for, world_bag

pytestmark = pytest.mark.timeout(120)


def click(x: float, y: float, modifier: str | None = None) -> bytes:
    """Return a page's click straight down through (x, y), as viser's client sends it."""
    return msgspec.msgpack.encode({**CLICK, 'ray_origin': [x, y, 1.0], 'modifier': modifier})


def choose(page: ViewerPage, value: str) -> bytes:
    """Return a page's choice of `value` in the 'character' dropdown."""
    return msgspec.msgpack.encode({'type': 'GuiUpdateMessage', 'uuid': page._selector._impl.uuid,
                                   'updates': {'value': value}})


def world_of_two() -> WorldView:
    """Return a world: the terrain, one goal, characters a and b, each with a surface and a state at 0.1 s."""
    world = WorldView(keep_meshes=1)
    world.world.set_terrain(SQUARE, np.ones((6, 4)))
    world.world.add_goals(GoalSet(0.0, np.array([[0.0, 1.5, 0.05]]), np.array([0.05]), np.ones((1, 4))))
    for name, x in PLACES.items():
        view = world.character(name)
        view.add_mesh(MeshFrame(0.1, body(x).astype(np.float32), GREEN.astype(np.float32)))
        view.add_state(0.1, [x, 0.0, 0.07], 0.0, 0.0)
    return world


@pytest.fixture
def serve():
    """Return a function serving a page (127.0.0.1, any free port) until the test ends."""
    made = []

    def start(view, live=None, **kwargs) -> ViewerPage:
        page = ViewerPage(view, '127.0.0.1', 0, live=live, **kwargs)
        stop = threading.Event()
        threading.Thread(target=page.serve, args=(stop,), daemon=True).start()
        made.append((page, stop))
        return page
    yield start
    for page, stop in made:
        stop.set()
        page.close()


# ---------------------------------------------------------------------------------------------- without ROS
def test_a_bags_characters_are_its_mesh_topics_named_by_their_prefixes():
    marker = 'visualization_msgs/msg/Marker'
    assert characters({'/mesh_marker': marker, '/iguana_state': 'nav_msgs/msg/Odometry'}) == {'': '/'}
    assert characters({'/ns/mesh_marker': marker}) == {'': '/ns/'}                  # a lone iguana in a namespace
    assert characters({'/east/mesh_marker': marker, '/west/mesh_marker': marker, '/scene_markers': 'x'}) == {
        'east': '/east/', 'west': '/west/'}
    assert characters({'/ns/east/mesh_marker': marker, '/ns/west/mesh_marker': marker}) == {
        'east': '/ns/east/', 'west': '/ns/west/'}
    assert characters({'/mesh_marker': marker, '/b/mesh_marker': marker}) == {'': '/', 'b': '/b/'}
    assert characters({'/a/mesh_marker': 'std_msgs/msg/String', '/b/my_mesh_marker': marker}) == {}


def test_a_world_frame_is_its_characters_with_the_worlds_terrain_and_goals():
    world = world_of_two()
    assert world.names == ['a', 'b']                                    # the world's own view has no surface
    frame = world.frame('b')
    assert np.allclose(frame.root, [1.0, 0.0, 0.07]) and np.allclose(frame.mesh.points, body(1.0))
    assert frame.goals is world.world.goals[-1] and frame.terrain_version == world.world.terrain_version == 1
    assert [(b.name, b.root[0]) for b in world.bodies(0.1)] == [('a', -1.0), ('b', 1.0)]
    assert world.start_time == pytest.approx(0.1) and world.end_time == pytest.approx(0.1)
    lone = RunView()
    assert WorldView.of(lone).world is lone and WorldView.of(lone).character('') is lone
    assert WorldView.of(world) is world


def test_a_world_page_draws_every_character_and_sends_goals_to_the_selected_one(serve, capsys):
    live = FakeLive()
    page = serve(world_of_two(), live)
    with connect(page) as ws:
        feed = PageFeed(ws)
        ws.send(msgspec.msgpack.encode(CAMERA))
        meshes = feed.wait_named('MeshMessage', {'/terrain', '/iguanas/a', '/iguanas/b'})
        assert {'/terrain', '/iguanas/a', '/iguanas/b'} <= meshes and '/iguana' not in meshes, meshes
        assert feed.wait_named('LabelMessage', {'/labels/a', '/labels/b'}) >= {'/labels/a', '/labels/b'}
        dropdowns = [m for m in feed.messages if m.get('type') == 'GuiDropdownMessage']
        assert [(d['props']['label'], list(d['props']['options'])) for d in dropdowns] == [('character', ['a', 'b'])]
        assert page.selected == 'a' and 'characters: **a** (selected), b' in page._panel.content

        ws.send(click(1.0, 0.0))                                           # on b's body: selects b, sends nothing
        assert wait_for(lambda: page.selected == 'b'), page.status
        assert page._selector.value == 'b' and live.sent == []
        assert 'b selected: a click on the terrain sends its goal on b/goal_pose' in page.status
        ws.send(click(0.5, 1.0))                                           # on the terrain: b's goal
        assert wait_for(lambda: live.sent), page.status
        assert live.sent == [('goal', (0.5, 1.0, None), {'character': 'b'})]
        assert 'sent on b/goal_pose' in page.status

        ws.send(choose(page, 'a'))                                         # the dropdown
        assert wait_for(lambda: page.selected == 'a'), page.status
        ws.send(click(-0.5, -1.0))
        assert wait_for(lambda: len(live.sent) == 2), live.sent
        assert live.sent[-1] == ('goal', (-0.5, -1.0, None), {'character': 'a'})
        ws.send(click(-0.5, 1.0, modifier='shift'))                         # a's last goal, heading +y
        assert wait_for(lambda: len(live.sent) == 3), live.sent
        assert live.sent[-1] == ('goal', (-0.5, -1.0, pytest.approx(90.0)), {'character': 'a'})
        ws.send(choose(page, 'nobody'))                                    # no such option: dropped by the gate
        ws.send(click(1.0, 0.0))                                           # b again, by its body
        assert wait_for(lambda: page.selected == 'b'), page.status
        feed.read()
        assert 'characters: a, **b** (selected)' in page._panel.content
    assert "'character' takes one of a, b, not 'nobody'" in capsys.readouterr().err


def test_a_lone_iguanas_page_is_as_before(serve):
    view = RunView(keep_meshes=1)
    view.set_terrain(SQUARE, np.ones((6, 4)))
    view.add_mesh(MeshFrame(0.1, body(0.0).astype(np.float32), GREEN.astype(np.float32)))
    view.add_state(0.1, [0.0, 0.0, 0.07], 0.0, 0.0)
    live = FakeLive()
    page = serve(view, live)
    with connect(page) as ws:
        feed = PageFeed(ws)
        ws.send(msgspec.msgpack.encode(CAMERA))
        assert {'/terrain', '/iguana'} <= feed.wait_named('MeshMessage', {'/terrain', '/iguana'})
        ws.send(click(0.0, 0.0))                     # on its body: the terrain under it, as before characters
        assert wait_for(lambda: live.sent), page.status
        feed.read(0.5)
    assert live.sent == [('goal', (0.0, 0.0), {})]
    assert page.status == 'goal x 0.00 m, y 0.00 m sent on goal_pose; waiting for the planner.'
    assert not [m for m in feed.messages if m.get('type') in ('LabelMessage', 'GuiDropdownMessage')]
    assert page._selector is None and page.cast == ('',) and 'characters' not in page._panel.content


def test_a_world_bag_is_read_character_by_character(tmp_path):
    bag = load_bag(world_bag(tmp_path / 'world'))
    world = bag.world
    assert world.names == ['a', 'b'] and bag.notes == [] and bag.damage == ''
    a, b = world.views['a'], world.views['b']
    assert len(a.meshes) == len(b.meshes) == 10 and a.states.n == b.states.n == 10
    assert len(a.pushes) == 0 and len(b.pushes) == 1 and b.pushes[0].region == 'trunk_left'
    assert world.world.terrain_points.shape == (6, 3) and not world.world.meshes
    assert bag.view is a                                                   # the first character's
    assert [round(float(body_.root[0]), 3) for body_ in world.bodies(0.2)] == [-0.94, 1.06]   # frame 6 of each


# ---------------------------------------------------------------------------------------------- with ROS
@pytest.mark.ros
def test_the_graphs_characters_are_the_mesh_topics_one_name_below_the_namespace():
    from iguana_ros.view.live import character_names
    marker = ['visualization_msgs/msg/Marker']
    graph = [('/east/mesh_marker', marker), ('/west/mesh_marker', marker), ('/mesh_marker', marker),
             ('/a/b/mesh_marker', marker), ('/north/mesh_marker', ['std_msgs/msg/String']),
             ('/ns/south/mesh_marker', marker), ('/east/iguana_state', ['nav_msgs/msg/Odometry'])]
    assert character_names(graph, '/') == ['east', 'west']
    assert character_names(graph, '/ns') == ['south']


class _World:
    """A stand-in for a world's simulator on the graph: characters' meshes and states, the scene, goal listeners."""

    def __init__(self, context) -> None:
        """Publish the scene (latched); listen on a, b and c's goal_pose."""
        import rclpy

        from iguana_ros.ros.conversions import marker_array_msg, triangle_list_marker
        from iguana_ros.ros.endpoints import resolve
        self.node = rclpy.create_node('characters_probe', context=context)
        self.goals: dict[str, list] = {name: [] for name in ('a', 'b', 'c')}
        for name in self.goals:
            topic_, cls, qos = resolve('goal_pose', f'{name}/')
            self.node.create_subscription(cls, topic_, lambda msg, name=name: self.goals[name].append(msg), qos)
        topic_, cls, qos = resolve('scene_markers')
        self.scene = self.node.create_publisher(cls, topic_, qos)
        self.scene.publish(marker_array_msg([triangle_list_marker(SQUARE, np.arange(6).reshape(2, 3),
                                                                  np.ones((6, 4)), ns='terrain')]))
        self.publishers: dict[str, tuple] = {}
        self.frame = 0
        self.executor = rclpy.executors.SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)

    def add(self, name: str, x: float) -> None:
        """Make character `name`, standing at x, start publishing its surface and state."""
        from iguana_ros.ros.endpoints import resolve
        pubs = []
        for key in ('mesh_marker', 'iguana_state'):
            topic_, cls, qos = resolve(key, f'{name}/')
            pubs.append(self.node.create_publisher(cls, topic_, qos))
        self.publishers[name] = (x, *pubs)

    def step(self) -> None:
        """Publish one frame of every character; spin the listeners a little."""
        from iguana_ros.ros import messages as m
        from iguana_ros.ros.cdr import triangle_list_marker_cdr
        from iguana_ros.ros.conversions import frame_stamp
        self.frame += 1
        for name, (x, mesh, state) in self.publishers.items():
            mesh.publish(triangle_list_marker_cdr(body(x), np.array([[0, 1, 2]]), GREEN, stamp=frame_stamp(self.frame),
                                                  ns=name))
            state.publish(m.state_to_cdr([x, 0.0, 0.07], [0, 0, 0, 1], np.zeros(3), np.zeros(3), self.frame))
        self.executor.spin_once(timeout_sec=0.05)


@pytest.mark.ros
def test_the_live_viewer_draws_the_graphs_characters_and_sends_a_goal_to_the_selected_ones_goal_pose(serve,
                                                                                                     ros_context):
    from iguana_ros.view.live import LiveSource
    stand_in = _World(ros_context)
    stand_in.add('a', PLACES['a'])
    stand_in.add('b', PLACES['b'])
    world = WorldView(keep_meshes=1)
    live = LiveSource(world, {}, 0.1)
    try:
        page = serve(world, live)

        def running(predicate, timeout: float = 30.0) -> bool:
            """Publish frames until `predicate()` holds."""
            end = time.monotonic() + timeout
            while time.monotonic() < end:
                stand_in.step()
                if predicate():
                    return True
            return predicate()
        with connect(page) as ws:
            feed = PageFeed(ws)
            ws.send(msgspec.msgpack.encode(CAMERA))
            assert running(lambda: feed.read(0.01) is not None and feed.named('MeshMessage') >= {
                '/terrain', '/iguanas/a', '/iguanas/b'}), (feed.named('MeshMessage'), world.names)
            assert page.cast == ('a', 'b') and page.selected == 'a'
            ws.send(choose(page, 'b'))
            assert running(lambda: page.selected == 'b'), page.status
            ws.send(click(0.5, 1.0))                                       # the terrain
            assert running(lambda: stand_in.goals['b']), page.status
            (goal,) = stand_in.goals['b']
            assert (goal.pose.position.x, goal.pose.position.y) == (0.5, 1.0) and stand_in.goals['a'] == []
            assert goal.header.frame_id == WORLD_FRAME and goal.pose.orientation.w == 0.0   # any heading, as before
            assert 'sent on b/goal_pose' in page.status

            stand_in.add('c', 0.0)                                         # a late character appears
            assert running(lambda: feed.read(0.01) is not None and '/iguanas/c' in feed.named('MeshMessage')), \
                world.names
            assert running(lambda: page.cast == ('a', 'b', 'c')) and page._selector.options == ('a', 'b', 'c')
            ws.send(choose(page, 'c'))
            assert running(lambda: page.selected == 'c'), page.status
            ws.send(click(-1.5, 1.5))
            assert running(lambda: stand_in.goals['c']), page.status
            assert (stand_in.goals['c'][0].pose.position.x, stand_in.goals['c'][0].pose.position.y) == (-1.5, 1.5)
        assert len(stand_in.goals['b']) == 1 and stand_in.goals['a'] == []
    finally:
        live.close()
        stand_in.executor.shutdown()
        stand_in.node.destroy_node()
