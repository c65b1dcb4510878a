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
A browser's camera in the viewer, through the page's websocket (no browser, no ROS).

A page is aimed at the iguana until its camera reports that aim: a report of the camera it had before (viser's default,
5 m away, sent while the page loads and arriving after the aim was sent) is aimed again, not followed. Once a page has
taken the aim, the angle and distance it chooses are followed as the iguana moves.
"""
from __future__ import annotations

import threading

import msgspec
import numpy as np
import pytest

from iguana_ros.view.scene import MeshFrame, RunView
from iguana_ros.view.server import CAMERA_OFFSET, ViewerPage
from view_harness import body, CAMERA, connect, GREEN, PageFeed, SQUARE, wait_for

pytestmark = pytest.mark.timeout(120)


def report(position, look_at) -> bytes:
    """Return a page's camera report: at `position`, looking at `look_at`."""
    return msgspec.msgpack.encode({**CAMERA, 'position': [float(v) for v in position],
                                   'look_at': [float(v) for v in look_at]})


def moved_to(feed: PageFeed, position) -> bool:
    """Return True once the page has been sent its camera's position `position` (not the initial camera's)."""
    return wait_for(lambda: any(m.get('type') == 'SetCameraPositionMessage' and not m.get('initial')
                                and np.allclose(m['position'], position, atol=1e-6) for m in feed.read()))


def test_a_page_is_aimed_until_it_reports_the_aim_then_its_own_view_is_followed():
    view = RunView(keep_meshes=1)
    view.set_terrain(SQUARE, np.ones((6, 4)))
    view.add_mesh(MeshFrame(0.1, body(0.0).astype(np.float32), GREEN.astype(np.float32)))
    root = np.array([0.0, 0.0, 0.07])
    view.add_state(0.1, root, 0.0, 0.0)
    page = ViewerPage(view, '127.0.0.1', 0)
    stop = threading.Event()
    threading.Thread(target=page.serve, args=(stop,), daemon=True).start()
    default = np.array(CAMERA['position']), np.array(CAMERA['look_at'])       # viser's camera before the aim
    try:
        with connect(page) as ws:
            feed = PageFeed(ws)
            ws.send(report(*default))
            assert moved_to(feed, root + CAMERA_OFFSET)
            ws.send(report(*default))               # sent before the page took the aim; it arrives after
            root = np.array([0.1, 0.0, 0.07])
            view.add_state(0.2, root, 0.0, 0.0)
            assert moved_to(feed, root + CAMERA_OFFSET), 'the stale camera was followed, not aimed again'
            assert not page.aimed
            ws.send(report(root + CAMERA_OFFSET, root))                        # the page took the aim
            assert wait_for(lambda: len(page.aimed) == 1)
            mine = np.array([0.0, -2.0, 1.0])                                  # then its user zoomed out, behind it
            ws.send(report(root + mine, root))
            (client,) = page.server.get_clients().values()
            assert wait_for(lambda: np.allclose(client.camera.position, root + mine))
            root = np.array([0.2, 0.0, 0.07])
            view.add_state(0.3, root, 0.0, 0.0)
            assert moved_to(feed, root + mine), 'the view the page chose was not followed'
    finally:
        stop.set()
        page.close()
