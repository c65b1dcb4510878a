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
