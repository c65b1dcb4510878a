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
`iguana view` in a real browser (headless Chromium driven by Selenium).

One `iguana run --view` of flat_walk (coarse model) with the four real node processes in realtime mode: the page
shows the iguana (green mesh pixels), a click on the terrain sends a goal that the run's planner accepts, the push
button sends a push, and the viewer, a child in the run's process group, stops with the run while the page says it
lost its server. Then `iguana view BAG` plays that run's bag on a timeline (plays, pauses, scrubs) and, paused just
after the push, draws the push's arrow (red pixels), absent just before it. A bag of a world of two characters lists
them and its 'character' dropdown selects one. One browser for the module. IGUANA_UPDATE_SCREENSHOT=1 saves that
bag-mode screenshot to docs/view_screenshot.png.
"""
from __future__ import annotations

from dataclasses import dataclass
import math
import os
from pathlib import Path
import re
import signal

import numpy as np
import pytest
import yaml

from ros_harness import IGUANA, NodeProcess, REPO
from view_harness import (choose_option, click_button, click_canvas, dismiss_notifications, figure, find_browser,
                          green_pixels, page_text, PIXEL_SCALE, red_pixels, screenshot, start_browser, wait_until,
                          world_bag)

pytestmark = [pytest.mark.ros, pytest.mark.timeout(600)]

SCENE = {'name': 'view_walk', 'terrain': {'kind': 'flat'}, 'model': {'resolution': 'coarse'},
         'goals': [{'x': 2.0, 'y': 0.0, 'at': 0.0}], 'duration': 600.0}
"""flat_walk with the coarse model (lighter on a shared machine)."""

RUN_S = 600.0
"""Simulated seconds the run may last; it is stopped as soon as the live tests are done."""

START_S = 300.0
"""Wall seconds the run gets to serve the page and simulate its first frames (a fresh clone compiles kernels)."""

MIN_GREEN, MIN_RED = round(800 * PIXEL_SCALE ** 2), round(100 * PIXEL_SCALE ** 2)
"""Pixels of the iguana's green and of a push arrow's red that a screenshot must hold (at 1 device pixel per CSS
pixel; fewer at the tests' PIXEL_SCALE)."""

DRAW_RATE = 5.0
"""Redraws per second of the pages under test (`--rate`; 20 by default): fewer scene updates for a browser that
shares 2 cores with a `make test` (measured alone: no shorter than at 20, 125 s against 108 s for the module)."""

SCREENSHOT = REPO / 'docs' / 'view_screenshot.png'


@dataclass
class LiveRun:
    """The run under test, its viewer's address, its bag."""

    process: NodeProcess
    url: str
    bag: Path
    tmp: Path


@dataclass
class ClickedGoal:
    """What the page said the planner accepted after a click on the terrain and a shift-click beside it."""

    accepted: re.Match | None
    headed: re.Match | None
    page: str

    @property
    def goal(self) -> tuple[float, float]:
        """Return where the click put the goal, (x, y) m."""
        return float(self.accepted.group(1)), float(self.accepted.group(2))

    @property
    def heading(self) -> float:
        """Return the shift-click's heading, degrees."""
        return float(self.headed.group(3))


@pytest.fixture(scope='module')
def browser():
    """Headless Chromium (skipped, saying why, where none can be had)."""
    found = find_browser()
    if isinstance(found, str):
        pytest.skip(f'no browser for the viewer tests: {found}')
    driver = start_browser(*found)
    yield driver
    driver.quit()


def _url(output: str) -> str:
    """Return the address in an `iguana view: http://...` line."""
    return re.search(r'iguana view: (http://\S+)', output).group(1)


@pytest.fixture(scope='module')
def live_run(tmp_path_factory, browser):
    """`iguana run SCENE --view` in realtime mode, recording a bag; stopped (SIGINT) at the end if need be."""
    tmp = tmp_path_factory.mktemp('view_run')
    bag = tmp / 'bag'
    scene = tmp / 'view_walk.yaml'
    scene.write_text(yaml.safe_dump(SCENE))
    command = [*IGUANA, 'run', str(scene), '--view', '--view-port', '0', '--view-rate', str(DRAW_RATE),
               '--mode', 'realtime',
               '--duration', str(RUN_S), '--record', str(bag)]
    process = NodeProcess(command, 'iguana_run', tmp).start(ready='iguana view: http', timeout=START_S)
    run = LiveRun(process, _url(process.output), bag, tmp)
    yield run
    if process.running:
        process.stop(timeout=60.0)


def _shows_simulated_time(driver) -> bool:
    """Whether the panel shows a state after the first frames."""
    t = figure(driver, 'simulated time')
    return t is not None and t > 0.2


def _green(driver, keep: Path) -> int:
    """Green pixels of a screenshot if at least MIN_GREEN, else 0 (the screenshot is kept at `keep`)."""
    png, pixels = screenshot(driver)
    keep.write_bytes(png)
    n = green_pixels(pixels)
    return n if n >= MIN_GREEN else 0


def test_live_page_shows_the_iguana(browser, live_run):
    browser.get(live_run.url)
    assert wait_until(lambda: _shows_simulated_time(browser), START_S), page_text(browser)
    dismiss_notifications(browser)
    green = wait_until(lambda: _green(browser, live_run.tmp / 'live.png'), 60.0)
    assert green, f'no green iguana pixels in {live_run.tmp / "live.png"}; page: {page_text(browser)}'
    text = page_text(browser)
    assert 'Connected' in text and 'realtime factor' in text and 'clip ' in text and 'speed ' in text


def _open_live_page(browser, live_run) -> None:
    """Show the live run's page (once it shows a state), its notifications dismissed."""
    if live_run.url not in browser.current_url:
        browser.get(live_run.url)
        wait_until(lambda: _shows_simulated_time(browser), START_S)
    dismiss_notifications(browser)


@pytest.fixture(scope='module')
def clicked_goal(browser, live_run) -> ClickedGoal:
    """Click the terrain, then shift-click beside the goal; return what the page said the planner accepted."""
    _open_live_page(browser, live_run)
    click_canvas(browser, 0.35, 0.85)                                  # the ground in front of the camera
    accepted = wait_until(lambda: re.search(r'goal x (-?[\d.]+) m, y (-?[\d.]+) m accepted by the planner',
                                            page_text(browser)), 60.0)
    if not accepted:
        return ClickedGoal(None, None, page_text(browser))
    click_canvas(browser, 0.2, 0.9, modifier='shift')          # toward another point (the panel is on the right)
    headed = wait_until(lambda: re.search(r'goal x (-?[\d.]+) m, y (-?[\d.]+) m heading (-?\d+) deg accepted by',
                                          page_text(browser)), 60.0)
    return ClickedGoal(accepted, headed, page_text(browser))


@pytest.fixture(scope='module')
def pushed(browser, live_run) -> str | None:
    """Press 'push left flank'; return the page's text once it says the push was sent, else None."""
    _open_live_page(browser, live_run)
    click_button(browser, 'push left flank')

    def said_sent():
        text = page_text(browser)
        return text if 'push of 40 N sent on trunk_left' in text else None
    return wait_until(said_sent, 60.0)


def test_a_click_on_the_terrain_sends_a_goal_the_planner_accepts(clicked_goal):
    assert clicked_goal.accepted, clicked_goal.page
    assert clicked_goal.headed, clicked_goal.page
    assert (float(clicked_goal.headed.group(1)), float(clicked_goal.headed.group(2))) == clicked_goal.goal


def test_the_push_button_sends_a_push(pushed, browser):
    assert pushed, page_text(browser)          # its arrow is checked on the bag's timeline, paused at the push


def test_the_simulation_buttons_pause_step_and_resume_the_run(browser, live_run, pushed):
    _open_live_page(browser, live_run)
    click_button(browser, 'pause')
    paused = wait_until(lambda: re.search(r'pause: paused at frame (\d+)', page_text(browser)), 60.0)
    assert paused, page_text(browser)
    frame = int(paused.group(1))
    assert wait_until(lambda: figure(browser, 'simulated time') == pytest.approx(frame / 30.0, abs=0.01), 30.0), \
        page_text(browser)
    click_button(browser, 'step 1 frame')
    stepped = wait_until(lambda: re.search(r'step: stepped to frame (\d+)', page_text(browser)), 60.0)
    assert stepped and int(stepped.group(1)) == frame + 1, page_text(browser)
    click_button(browser, 'resume')
    assert wait_until(lambda: (figure(browser, 'simulated time') or 0.0) > (frame + 15) / 30.0, 60.0), \
        page_text(browser)


def _children(pid: int) -> dict[str, int]:
    """{'viewer' | 'recorder': pid} among the live child processes of `pid` (from /proc)."""
    out = {}
    for proc in Path('/proc').glob('[0-9]*'):
        try:
            stat = (proc / 'stat').read_text()
            line = (proc / 'cmdline').read_bytes().replace(b'\0', b' ').decode(errors='replace')
        except OSError:
            continue
        if int(stat.rsplit(')', 1)[1].split()[1]) != pid:
            continue
        if ' iguana_ros.cli view ' in line:
            out['viewer'] = int(proc.name)
        elif ' bag record ' in line:
            out['recorder'] = int(proc.name)
    return out


def _gone(pid: int) -> bool:
    """Whether process `pid` has exited (no such process, or a zombie)."""
    try:
        return (Path('/proc') / str(pid) / 'stat').read_text().rsplit(')', 1)[1].split()[0] == 'Z'
    except OSError:
        return True


def test_the_viewer_is_a_child_of_the_run_and_stops_with_it(browser, live_run, clicked_goal, pushed):
    # this test stops the run: the goal and the push its bag is checked for are sent first (`clicked_goal`, `pushed`)
    assert live_run.process.running, f'the run ended before it was stopped: {live_run.process.tail()}'
    children = _children(live_run.process.pid)
    assert set(children) == {'viewer', 'recorder'}, children
    assert os.getpgid(children['viewer']) == os.getpgid(children['recorder']) != os.getpgid(os.getpid())
    live_run.process.send(signal.SIGINT)
    code = live_run.process.wait(timeout=120.0)
    assert code == 128 + signal.SIGINT, live_run.process.tail()
    assert 'stopped by SIGINT' in live_run.process.output
    assert _gone(children['viewer'])
    assert 'Traceback' not in live_run.process.output
    if live_run.url in browser.current_url:        # the page says it lost its server
        assert wait_until(lambda: 'Connecting' in page_text(browser), 30.0), page_text(browser)


AFTER_PUSH_S = 1.0
"""Simulated seconds the run goes on after the push before its bag is taken (the bag-mode test pauses 0.5 s after)."""


@pytest.fixture(scope='module')
def recorded_bag(browser, live_run, clicked_goal, pushed):
    """
    Return the run's bag, once the run has stopped (after the goal clicks and the push were sent).

    A run still going (this module's tests run alone: no test between the push and the bag stopped it) is stopped
    AFTER_PUSH_S of simulated time after the page said the push was sent, so the bag holds the moment after the push.
    """
    if live_run.process.running:
        sent_at = re.search(r'simulated time (-?[\d.]+)', pushed or '')
        if sent_at:
            _open_live_page(browser, live_run)
            wait_until(lambda: (figure(browser, 'simulated time') or 0.0) >= float(sent_at.group(1)) + AFTER_PUSH_S,
                       60.0)
        live_run.process.stop(timeout=60.0)
    assert (live_run.bag / 'metadata.yaml').exists(), live_run.process.tail()
    return live_run


def test_the_bag_holds_the_goal_the_planner_accepted_and_the_push(recorded_bag, clicked_goal, pushed):
    from rclpy.serialization import deserialize_message

    from iguana_ros.bag.trajectory import read_topics
    from iguana_ros.ros.endpoints import resolve
    assert clicked_goal.accepted and clicked_goal.headed and pushed, clicked_goal.page
    keys = ['accepted_goals', 'push', 'goal_pose']
    recorded = {key: [deserialize_message(data, resolve(key)[1]) for data in messages]
                for key, messages in read_topics(recorded_bag.bag, keys).messages.items()}
    accepted = recorded['accepted_goals'][-1].poses
    poses = [(p.pose.position.x, p.pose.position.y) for p in accepted]
    assert len(poses) == 3 and poses[0] == (2.0, 0.0)            # the scene's, the click's, the shift-click's heading
    assert np.allclose(poses[1], clicked_goal.goal, atol=0.006) and np.allclose(poses[2], clicked_goal.goal, atol=0.006)
    assert [p.pose.orientation.w for p in accepted[1:2]] == [0.0]           # the click: any heading
    q = accepted[2].pose.orientation
    assert math.degrees(2 * math.atan2(q.z, q.w)) == pytest.approx(clicked_goal.heading, abs=0.6)
    (push,) = recorded['push']
    force = push.wrench.force
    assert push.header.frame_id == 'trunk_left' and math.isclose(math.hypot(force.x, force.y), 40.0)


def _scrub(browser, seconds: float) -> None:
    """Type a time into the timeline's number field."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys
    field_ = browser.find_element(By.CSS_SELECTOR, 'input.mantine-NumberInput-input')
    field_.send_keys(Keys.CONTROL, 'a')
    field_.send_keys(f'{seconds:.2f}', Keys.ENTER)


def test_bag_mode_plays_the_run_on_a_timeline_and_draws_its_push(browser, recorded_bag, pushed, tmp_path):
    from iguana_ros.view.bag_source import load_bag
    assert pushed, 'the live run was not pushed'
    view = load_bag(recorded_bag.bag).view
    pushes = view.pushes
    command = [*IGUANA, 'view', str(recorded_bag.bag), '--port', '0', '--speed', '0.2', '--rate', str(DRAW_RATE)]
    with NodeProcess(command, 'iguana_view', tmp_path).start(ready='iguana view: http', timeout=120.0) as viewer:
        browser.get(_url(viewer.output))
        assert wait_until(lambda: 'time (s)' in page_text(browser) and figure(browser, 'simulated time') is not None,
                          60.0), page_text(browser)
        dismiss_notifications(browser)
        first = figure(browser, 'simulated time')
        assert wait_until(lambda: (figure(browser, 'simulated time') or 0.0) > first + 0.02, 60.0), 'no advance'
        assert wait_until(lambda: _green(browser, tmp_path / 'bag.png'), 60.0), f'no green pixels in {tmp_path}'
        click_button(browser, 'pause')
        assert wait_until(lambda: 'play' in page_text(browser).split(), 30.0)
        # Paused, the clock stands still. The positive sign, no sleep-and-look: scrubbed back to a time before the
        # pause, the page shows that time exactly. A playing clock would never: it was past that time, and the redraw
        # after the scrub moves it on by at least speed / rate = 0.04 s (the server's loop advances, then draws).
        paused = wait_until(lambda: figure(browser, 'simulated time'), 30.0)     # past first + 0.02: not 0
        back = round((view.start_time + paused) / 2, 2)
        assert paused - back >= 0.01, (view.start_time, paused)
        _scrub(browser, back)
        assert wait_until(lambda: figure(browser, 'simulated time') == back, 30.0), page_text(browser)
        _scrub(browser, 1.5)
        assert wait_until(lambda: figure(browser, 'simulated time') == 1.5, 30.0), page_text(browser)
        assert len(pushes) == 1                   # paused just after the push: its arrow is drawn
        at = round(pushes[0].time + 0.5, 2)
        _scrub(browser, at)
        assert wait_until(lambda: figure(browser, 'simulated time') == at, 30.0), page_text(browser)

        def arrow_shot():
            png, pixels = screenshot(browser)
            (tmp_path / 'push.png').write_bytes(png)
            return (png, pixels) if red_pixels(pixels) >= MIN_RED and green_pixels(pixels) >= MIN_GREEN else None
        shot = wait_until(arrow_shot, 60.0)
        assert shot is not None, f'no red push arrow beside the iguana in {tmp_path / "push.png"}'
        if os.environ.get('IGUANA_UPDATE_SCREENSHOT') == '1':
            SCREENSHOT.write_bytes(shot[0])
        _scrub(browser, max(pushes[0].time - 0.5, 0.0))      # before the push: no arrow
        assert wait_until(lambda: red_pixels(screenshot(browser)[1]) < MIN_RED, 60.0)
        assert viewer.running
    assert viewer.proc.returncode == 0, viewer.tail()


def test_bag_mode_of_a_world_lists_its_characters_and_the_dropdown_selects_one(browser, tmp_path):
    bag = world_bag(tmp_path / 'world')
    command = [*IGUANA, 'view', str(bag), '--port', '0', '--paused', '--rate', str(DRAW_RATE)]
    with NodeProcess(command, 'iguana_view_world', tmp_path).start(ready='iguana view: http', timeout=120.0) as viewer:
        assert '2 characters: a, b' in viewer.output, viewer.output
        browser.get(_url(viewer.output))
        assert wait_until(lambda: 'characters: a (selected), b' in page_text(browser), 60.0), page_text(browser)
        dismiss_notifications(browser)
        choose_option(browser, 'character', 'b')
        assert wait_until(lambda: 'characters: a, b (selected)' in page_text(browser), 60.0), page_text(browser)
        assert 'b selected.' in page_text(browser)
        assert viewer.running
    assert viewer.proc.returncode == 0, viewer.tail()
