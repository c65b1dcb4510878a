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

"""Helpers of the viewer tests: headless Chromium through Selenium, the page's text and pixels."""
from __future__ import annotations

import io
import os
import re
import shutil
import subprocess
import tempfile
import time

import numpy as np

PIXEL_SCALE = 1.0 if os.environ.get('IGUANA_UPDATE_SCREENSHOT') == '1' else 0.5
"""Device pixels per CSS pixel: software WebGL draws a quarter of the pixels at 0.5 (the six viewer tests alone on a
quiet machine: 108 s, against 144 s at 1; one run each, and no clear gain under a loaded `make test`); the README's
screenshot is taken at 1."""

CHROMIUM_FLAGS = ('--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
                  '--disable-background-networking', '--disable-component-update', '--disable-sync',
                  '--window-size=860,500', f'--force-device-scale-factor={PIXEL_SCALE:g}')
"""Flags that run Debian's Chromium here (a closed network: no background connections)."""

APT_INSTALL_S = 600
"""Wall seconds an `apt-get install chromium chromium-driver` may take when a test has to install them."""


def find_browser() -> tuple[str, str] | str:
    """(chromium, chromedriver) paths, installing Debian's packages if missing and possible; else the reason."""
    try:
        import selenium  # noqa: F401
    except ImportError:
        return 'selenium is not installed (pip install -e .[test])'
    found = shutil.which('chromium'), shutil.which('chromedriver')
    if all(found):
        return found
    if not shutil.which('apt-get'):
        return 'chromium / chromedriver are missing and there is no apt-get to install them'
    try:
        for command in (['apt-get', 'update', '-q'], ['apt-get', 'install', '-y', '-q', 'chromium', 'chromium-driver']):
            subprocess.run(command, check=True, capture_output=True, timeout=APT_INSTALL_S,
                           env={'DEBIAN_FRONTEND': 'noninteractive', 'PATH': '/usr/sbin:/usr/bin:/sbin:/bin'})
    except (subprocess.SubprocessError, OSError) as exc:
        return f'chromium / chromedriver are missing and apt-get could not install them: {exc}'
    found = shutil.which('chromium'), shutil.which('chromedriver')
    return found if all(found) else 'apt-get ran but chromium / chromedriver are still missing'


def start_browser(chromium: str, chromedriver: str):
    """Return a headless Chromium WebDriver with a fresh profile."""
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    for flag in CHROMIUM_FLAGS:
        options.add_argument(flag)
    options.add_argument('--user-data-dir=' + tempfile.mkdtemp(prefix='iguana_view_chromium_'))
    options.binary_location = chromium
    driver = webdriver.Chrome(service=Service(chromedriver), options=options)
    driver.set_page_load_timeout(120)
    driver.set_script_timeout(120)      # a loaded 2-core machine renders software WebGL slowly
    return driver


def wait_until(predicate, timeout: float, period: float = 0.25):
    """Return the first truthy `predicate()` within `timeout` s, else None."""
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value or time.monotonic() > deadline:
            return value or None
        time.sleep(period)


def page_text(driver) -> str:
    """Return the visible text of the page ('' when the busy browser did not answer in time)."""
    from selenium.common.exceptions import TimeoutException
    try:
        return driver.execute_script('return document.body.innerText') or ''
    except TimeoutException:
        return ''


def figure(driver, name: str) -> float | None:
    """Return the number after `name` in the panel (e.g. 'simulated time'), None if it is not shown."""
    match = re.search(re.escape(name) + r' (-?[\d.]+)', page_text(driver))
    return float(match.group(1)) if match else None


def dismiss_notifications(driver) -> None:
    """Close viser's notifications (e.g. 'Software WebGL rendering detected'), which cover the scene."""
    driver.execute_script(
        "document.querySelectorAll('.mantine-Notification-closeButton').forEach(b => b.click());")


def screenshot(driver) -> tuple[bytes, np.ndarray]:
    """(PNG bytes, RGB pixels `(h, w, 3)` uint8) of the window."""
    import imageio.v3 as iio
    png = driver.get_screenshot_as_png()
    return png, iio.imread(io.BytesIO(png))[..., :3]


GIZMO_PX = 110
"""Size of the bottom-left corner where viser draws its red / green / blue axes gizmo, px (left out of counts)."""


def green_pixels(pixels: np.ndarray, margin: int = 40) -> int:
    """
    Return how many pixels have green at least `margin` above red and blue (the iguana's skin).

    Pixels in the axes gizmo's corner are not counted.
    """
    p = pixels.astype(int)
    p[-GIZMO_PX:, :GIZMO_PX] = 0
    return int(np.sum((p[..., 1] >= p[..., 0] + margin) & (p[..., 1] >= p[..., 2] + margin)))


def red_pixels(pixels: np.ndarray, margin: int = 60, tint: int = 25) -> int:
    """
    How many pixels are red.

    Red at least `margin` above green and blue, which are within `tint` of each other (the push arrows, shaded towards
    pink; not the orange path and contacts, whose green is far above their blue), outside the axes gizmo's corner.
    """
    p = pixels.astype(int)
    p[-GIZMO_PX:, :GIZMO_PX] = 0
    r, g, b = p[..., 0], p[..., 1], p[..., 2]
    return int(np.sum((r >= np.maximum(g, b) + margin) & (np.abs(g - b) <= tint)))


def click_canvas(driver, fx: float, fy: float, modifier: str | None = None) -> None:
    """Click the 3D view at fractions (`fx`, `fy`) of its width and height from its top-left corner (or shift-click)."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys
    canvas = driver.find_element(By.TAG_NAME, 'canvas')
    width, height = canvas.size['width'], canvas.size['height']
    actions = ActionChains(driver).move_to_element_with_offset(canvas, int((fx - 0.5) * width),
                                                               int((fy - 0.5) * height))
    if modifier == 'shift':
        actions = actions.key_down(Keys.SHIFT).pause(0.3).click().pause(0.3).key_up(Keys.SHIFT)
    else:
        actions = actions.click()
    actions.perform()


def click_button(driver, label: str) -> None:
    """Click the panel button labelled `label` (a DOM click: the panel's fade-in layers may cover it a moment)."""
    from selenium.webdriver.common.by import By
    button = driver.find_element(By.XPATH, f"//button[normalize-space(.)='{label}']")
    driver.execute_script('arguments[0].click();', button)


def choose_option(driver, label: str, option: str) -> None:
    """Pick `option` in the panel's dropdown labelled `label`, as a user does: open its list, click the option."""
    from selenium.webdriver.common.by import By
    box = driver.find_element(By.ID, driver.find_element(By.XPATH, f"//label[normalize-space(.)='{label}']")
                              .get_attribute('for'))
    driver.execute_script('arguments[0].click();', box)
    found = wait_until(lambda: [o for o in driver.find_elements(By.CSS_SELECTOR, '[role=option]') if o.text == option],
                       30.0)
    assert found, f'no option {option!r} in the dropdown {label!r}'
    driver.execute_script('arguments[0].click();', found[0])


# ---------------------------------------------------------------------------------------------- a page's websocket
CAMERA = {'type': 'ViewerCameraMessage', 'wxyz': [1.0, 0.0, 0.0, 0.0], 'position': [1.0, 1.0, 1.0], 'fov': 1.0,
          'near': 0.01, 'far': 100.0, 'image_height': 400, 'image_width': 600, 'look_at': [0.0, 0.0, 0.0],
          'up_direction': [0.0, 0.0, 1.0]}
"""A page's camera as viser's client sends it (viser counts a page as connected after its first one)."""

CLICK = {'type': 'ScenePointerMessage', 'event_type': 'click', 'ray_origin': [0.0, 0.0, 1.0],
         'ray_direction': [0.0, 0.0, -1.0], 'screen_pos': [[0.5, 0.5]], 'modifier': None}
"""A click in the scene as viser's client sends it: straight down through (0, 0)."""


class FakeLive:
    """What a page's live controls call: the goals and pushes it sent, (kind, arguments, keyword arguments)."""

    def __init__(self) -> None:
        """Nothing sent yet."""
        self.sent: list[tuple] = []

    def send_goal(self, *args, **kwargs) -> None:
        """Keep a goal."""
        self.sent.append(('goal', args, kwargs))

    def send_push(self, *args, **kwargs) -> None:
        """Keep a push."""
        self.sent.append(('push', args, kwargs))

    def goal_accepted(self) -> bool:
        """Return False: no planner here."""
        return False

    def send_sim(self, command: str, frames: int = 1) -> str:
        """Keep a simulation-control call."""
        self.sent.append(('sim', (command, frames), {}))
        return f'{command} sent'

    def sim_answers(self) -> list[str]:
        """Return no answers: no simulator here."""
        return []


def connect(page, path: str = '/', cookie: str | None = None):
    """Return a websocket client connected to `page` as viser's client connects (its version as subprotocol)."""
    import viser
    from websockets.sync.client import connect as ws_connect
    headers = {'Cookie': cookie} if cookie else None
    return ws_connect(f'ws://127.0.0.1:{page.port}{path}', subprotocols=[f'viser-v{viser.__version__}'],
                      additional_headers=headers, max_size=None, proxy=None)


def wait_for(predicate, timeout: float = 10.0) -> bool:
    """Return True once `predicate()` holds, False after `timeout` s."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.02)
    return predicate()


def page_messages(raw: bytes) -> list[dict]:
    """
    Return the messages of one websocket frame viser sent a page: each a map with its `type` (binary data left out).

    The frame is viser's batch: sizes (8 bytes each, little-endian) of a zstd-compressed msgpack map, that map, buffers.
    """
    import msgspec
    import zstandard
    size, packed = int.from_bytes(raw[:8], 'little'), int.from_bytes(raw[8:16], 'little')
    inner = zstandard.ZstdDecompressor().decompress(raw[16:16 + packed], max_output_size=size)
    return list(msgspec.msgpack.decode(inner)['messages'])


class PageFeed:
    """What one websocket client has been sent by a page so far (`read` takes what arrived)."""

    def __init__(self, ws) -> None:
        """Read from websocket client `ws`."""
        self.ws, self.messages = ws, []

    def read(self, seconds: float = 0.2) -> list[dict]:
        """Take the frames that arrive within `seconds`; return every message so far."""
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            try:
                raw = self.ws.recv(timeout=left)
            except TimeoutError:
                break
            if isinstance(raw, bytes):
                self.messages += page_messages(raw)
        return self.messages

    def named(self, kind: str) -> set[str]:
        """Return the scene node names of the messages of type `kind` so far (e.g. 'MeshMessage')."""
        return {m.get('name') for m in self.messages if m.get('type') == kind}

    def wait_named(self, kind: str, names: set[str], timeout: float = 20.0) -> set[str]:
        """Return the names of `kind` messages once they include `names` (or whatever came within `timeout` s)."""
        wait_for(lambda: self.read() is not None and names <= self.named(kind), timeout)
        return self.named(kind)


# ---------------------------------------------------------------------------------------------- a world of two
SQUARE = np.array([[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, -2, 0], [2, 2, 0], [-2, 2, 0]], float)
"""Two triangles covering the square |x|, |y| <= 2 m at z = 0: the terrain."""

PLACES = {'a': -1.0, 'b': 1.0}
"""Two characters and the x (m) each stands at, y = 0."""

GREEN = np.tile([0.36, 0.62, 0.30, 1.0], (3, 1))
"""RGBA of a surface's three corners: the iguana's green."""


def body(x: float, z: float = 0.1) -> np.ndarray:
    """Return a character's surface: one flat triangle 0.4 m wide around (x, 0) at height `z` m."""
    return np.array([[x - 0.2, -0.2, z], [x + 0.2, -0.2, z], [x, 0.2, z]])


def world_bag(directory):
    """Return a bag of two characters a and b (10 frames each, a push on b) and the world's scene_markers."""
    from rclpy.serialization import serialize_message

    from iguana_ros.bag.schema import message_definition
    from iguana_ros.bag.storage import BagWriter
    from iguana_ros.ros import messages as m
    from iguana_ros.ros.cdr import triangle_list_marker_cdr
    from iguana_ros.ros.conversions import frame_stamp, marker_array_msg, push_msg, triangle_list_marker
    from iguana_ros.topics import topic

    writer = BagWriter(directory)

    def channel(name: str, key: str):
        return writer.add_topic(name, topic(key).type, message_definition(topic(key).type))
    scene = channel('/scene_markers', 'scene_markers')
    channels = {(name, key): channel(f'/{name}/{key}', key) for name in PLACES
                for key in ('mesh_marker', 'iguana_state', 'push')}
    terrain = triangle_list_marker(SQUARE, np.arange(6).reshape(2, 3), np.ones((6, 4)), ns='terrain')
    writer.write(scene, serialize_message(marker_array_msg([terrain])), 1_000_000_000)
    for k in range(10):
        log_ns = 1_000_000_000 + k * 33_000_000
        for name, x in PLACES.items():
            marker = triangle_list_marker_cdr(body(x + 0.01 * k), np.array([[0, 1, 2]]), GREEN, stamp=frame_stamp(k),
                                              ns=name)
            writer.write(channels[name, 'mesh_marker'], marker, log_ns)
            writer.write(channels[name, 'iguana_state'], m.state_to_cdr([x + 0.01 * k, 0, 0.07], [0, 0, 0, 1],
                                                                        np.zeros(3), np.zeros(3), k), log_ns + 1)
        if k == 4:
            writer.write(channels['b', 'push'], serialize_message(push_msg([0.0, -40.0, 0.0], 'trunk_left')),
                         log_ns + 2)
    writer.close()
    return directory
