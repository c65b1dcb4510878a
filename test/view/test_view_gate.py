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
The viewer's websocket as a browser or anyone else reaches it (issue 30).

A real websocket client speaks viser's protocol to a real page: each malformed message is one line on the viewer's
stderr (what was wrong, from where) and the connection goes on serving; with a token, a page that has not presented
it is read-only, one that has (on the address, or in the cookie the page's address sets) steers; a wrong token is
refused. `iguana view --host 0.0.0.0` warns that anyone who reaches the port can steer, and with `--token auto` prints
an address that carries a random token.
"""
from __future__ import annotations

import http.client
import subprocess
import threading
import time

import msgspec
import pytest

from iguana_ros.view.scene import RunView
from iguana_ros.view.server import ViewerPage
from ros_harness import IGUANA, NodeProcess, REPO
from view_harness import CAMERA, CLICK, connect, FakeLive, wait_for

pytestmark = pytest.mark.timeout(120)


@pytest.fixture
def page_with(request):
    """Return a factory of live pages on 127.0.0.1 (any free port) with a FakeLive, served until the test ends."""
    made = []

    def make(token: str | None = None) -> tuple[ViewerPage, FakeLive]:
        live = FakeLive()
        extra = {'token': token} if token else {}
        page = ViewerPage(RunView(keep_meshes=1), '127.0.0.1', 0, live=live, **extra)
        stop = threading.Event()
        threading.Thread(target=page.serve, args=(stop,), daemon=True).start()
        made.append((page, stop))
        return page, live
    yield make
    for page, stop in made:
        stop.set()
        page.close()


class Log:
    """The viewer's stderr lines so far (read from pytest's capture)."""

    def __init__(self, capsys) -> None:
        """Start with nothing read."""
        self.capsys, self.lines = capsys, []

    def read(self) -> list[str]:
        """Return every line so far."""
        self.lines += self.capsys.readouterr().err.splitlines()
        return self.lines

    def wait(self, count: int) -> list[str]:
        """Return the lines once there are `count` of them (at most 10 s)."""
        wait_for(lambda: len(self.read()) >= count)
        return self.read()


def push_button(page: ViewerPage) -> str:
    """Return the uuid of the page's 'push left flank' button."""
    return next(handle._impl.uuid for handle in page.server.gui._gui_input_handle_from_uuid.values()
                if getattr(handle, 'label', '') == 'push left flank')


def pushed(page: ViewerPage) -> bytes:
    """Return a click on 'push left flank' as the page sends it."""
    return msgspec.msgpack.encode({'type': 'GuiUpdateMessage', 'uuid': push_button(page), 'updates': {'value': True}})


def connected(page: ViewerPage, count: int = 1) -> bool:
    """Return True once viser counts `count` pages as connected."""
    return wait_for(lambda: len(page.server.get_clients()) >= count)


MALFORMED = [
    (b'\x00garbage', 'not msgpack'),
    ('a text frame', 'a text frame'),
    (msgspec.msgpack.encode([1, 2]), 'not a map with a type'),
    (msgspec.msgpack.encode({'type': 'NoSuchMessage'}), "type 'NoSuchMessage' is not one this page takes"),
    (msgspec.msgpack.encode({'type': 'ShareUrlRequest'}), "type 'ShareUrlRequest' is not one this page takes"),
    (msgspec.msgpack.encode({**CLICK, 'ray_origin': 'x'}), 'ray_origin must be 3 finite numbers'),
    (msgspec.msgpack.encode({**CLICK, 'ray_direction': [0.0, float('nan'), -1.0]}),
     'ray_direction must be 3 finite numbers'),
    (msgspec.msgpack.encode({k: v for k, v in CLICK.items() if k != 'modifier'}), 'lacks modifier'),
    (msgspec.msgpack.encode({**CAMERA, 'look_at': ['a', 'b', 'c']}), 'look_at must be 3 finite numbers'),
    (msgspec.msgpack.encode({'type': 'GuiUpdateMessage', 'uuid': 'nope', 'updates': {'value': True}}),
     "uuid 'nope' is no input of this page"),
]
"""Malformed messages and what their line must say."""


def test_each_malformed_message_is_one_line_and_the_connection_goes_on(page_with, capsys):
    page, live = page_with()
    log = Log(capsys)
    with connect(page) as ws:
        ws.send(msgspec.msgpack.encode(CAMERA))
        assert connected(page)
        force = next(handle._impl.uuid for handle in page.server.gui._gui_input_handle_from_uuid.values()
                     if getattr(handle, 'label', '') == 'push force (N)')
        cases = MALFORMED + [
            (msgspec.msgpack.encode({'type': 'GuiUpdateMessage', 'uuid': force, 'updates': {'value': 'abc'}}),
             "'push force (N)' takes a number in [0, 1000], not 'abc'"),
            (msgspec.msgpack.encode({'type': 'GuiUpdateMessage', 'uuid': force, 'updates': {'label': 'x'}}),
             'updates must be {"value": ...}')]
        for k, (raw, why) in enumerate(cases, start=1):
            ws.send(raw)
            lines = log.wait(k)
            assert len(lines) == k, lines                                  # one line per message, no traceback
            assert lines[-1].startswith('iguana view: dropped a malformed message from 127.0.0.1:'), lines[-1]
            assert why in lines[-1], (why, lines[-1])
        ws.send(pushed(page))                                              # the same connection still steers
        assert wait_for(lambda: live.sent), 'the push after the malformed messages was not taken'
        assert live.sent[0][0] == 'push' and live.sent[0][1][1] == 'trunk_left'
        ws.ping().wait(5)
    assert not [line for line in log.read() if 'Traceback' in line or line.startswith('  File')]
    assert len(log.read()) == len(cases)


def test_a_page_without_the_token_is_read_only(page_with, capsys):
    page, live = page_with(token='s3cret-token')
    log = Log(capsys)
    with connect(page) as ws:
        ws.send(msgspec.msgpack.encode(CAMERA))
        assert connected(page)                                             # its camera is taken: it can watch
        ws.send(pushed(page))
        ws.send(pushed(page))
        lines = log.wait(1)
        assert lines == [f'iguana view: 127.0.0.1:{ws.local_address[1]} has not presented the token: its goals, '
                         'pushes and controls are ignored (read-only)'], lines
        time.sleep(0.5)
        assert live.sent == [] and len(log.read()) == 1                    # one line, not one per command


def test_the_token_on_the_websocket_or_in_the_pages_cookie_lets_a_page_steer(page_with, capsys):
    page, live = page_with(token='s3cret-token')
    assert page.url == f'http://127.0.0.1:{page.port}/?token=s3cret-token'
    with connect(page, '/?token=s3cret-token') as ws:
        ws.send(msgspec.msgpack.encode(CAMERA))
        ws.send(pushed(page))
        assert wait_for(lambda: len(live.sent) == 1), live.sent
    conn = http.client.HTTPConnection('127.0.0.1', page.port, timeout=10)
    conn.request('GET', '/?token=s3cret-token')
    answer = conn.getresponse()
    body, cookie = answer.read(), answer.getheader('Set-Cookie')
    assert answer.status == 200 and b'<html' in body.lower()               # viser's page, through the gate
    assert cookie.startswith(f'iguana_view_token_{page.port}=s3cret-token;') and 'HttpOnly' in cookie, cookie
    with connect(page, cookie=cookie.split(';')[0]) as ws:                 # as the browser connects afterwards
        ws.send(msgspec.msgpack.encode(CAMERA))
        assert connected(page, 1)
        ws.send(pushed(page))
        assert wait_for(lambda: len(live.sent) == 2), live.sent
    assert 'read-only' not in capsys.readouterr().err


def test_a_wrong_token_is_refused(page_with, capsys):
    from websockets.exceptions import InvalidStatus
    page, live = page_with(token='s3cret-token')
    conn = http.client.HTTPConnection('127.0.0.1', page.port, timeout=10)
    conn.request('GET', '/?token=guess-guess')
    answer = conn.getresponse()
    assert answer.status == 403 and answer.read() == b'iguana view: wrong token\n'
    with pytest.raises(InvalidStatus, match='403'):
        connect(page, '/?token=guess-guess')
    assert capsys.readouterr().err.count(': wrong token') == 2 and live.sent == []


def test_tokens_and_who_is_warned():
    from iguana_ros.view.server import exposure_lines, is_loopback, resolve_token
    assert resolve_token(None, {}) is None
    assert resolve_token(None, {'IGUANA_VIEW_TOKEN': 'from-the-env'}) == 'from-the-env'
    auto = resolve_token('auto', {})
    assert len(auto) >= 20 and auto != resolve_token('auto', {})
    with pytest.raises(ValueError, match='--token must be 8 to 128 of the characters'):
        resolve_token('short', {})
    with pytest.raises(ValueError, match='IGUANA_VIEW_TOKEN must be'):
        resolve_token(None, {'IGUANA_VIEW_TOKEN': 'has space'})
    assert is_loopback('127.0.0.1') and is_loopback('localhost') and is_loopback('::1')
    assert not is_loopback('0.0.0.0') and not is_loopback('::')
    assert exposure_lines('127.0.0.1', 8080, None, live=True) == []
    warning, = exposure_lines('0.0.0.0', 8080, None, live=True)
    assert warning.startswith('warning: serving on 0.0.0.0, not on this machine only: anyone who can reach port 8080 '
                              'can steer and push the iguana, with no login; --token auto'), warning
    note, = exposure_lines('0.0.0.0', 8080, 'a-token-here', live=False)
    assert 'only a page opened with the token can drive the timeline' in note and 'unencrypted' in note


def _view_until_address(*args: str, tmp_path) -> tuple[str, str]:
    """Start `iguana view ARGS` (live), return (its output up to the address line, that line), then stop it."""
    view = NodeProcess([*IGUANA, 'view', '--port', '0', *args], 'view', tmp_path)
    with view.start(ready='iguana view: http', timeout=60):
        lines = view.output.splitlines()
    address = next(line for line in lines if line.startswith('iguana view: http'))
    return '\n'.join(lines[:lines.index(address)]), address


@pytest.mark.ros
def test_serving_beyond_this_machine_warns_and_a_token_goes_in_the_address(tmp_path):
    before, address = _view_until_address('--host', '0.0.0.0', tmp_path=tmp_path)
    assert ('iguana view: warning: serving on 0.0.0.0, not on this machine only: anyone who can reach port '
            in before and 'can steer and push the iguana, with no login' in before), before
    before, address = _view_until_address('--host', '0.0.0.0', '--token', 'auto', tmp_path=tmp_path / 'auto')
    assert 'iguana view: note: serving on 0.0.0.0: anyone who can reach port' in before, before
    assert '?token=' in address and 'warning' not in before, address
    before, address = _view_until_address(tmp_path=tmp_path / 'local')
    assert 'warning' not in before and 'note' not in before and '?token=' not in address


def test_a_bad_token_is_one_line():
    done = subprocess.run([*IGUANA, 'view', '--token', 'short'], cwd=REPO, capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 1 and done.stderr.strip().splitlines() == [
        'iguana view: error: --token must be 8 to 128 of the characters A-Z a-z 0-9 . _ ~ - (it travels in an address '
        "and a cookie), or 'auto' for a random one; got 5 characters"], done.stderr
