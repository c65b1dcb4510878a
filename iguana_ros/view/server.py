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
The viewer's web page (viser).

Scene nodes drawn from a `RunView`'s frames, a panel of figures, and either the live controls (a click on the terrain
sends a goal, buttons send pushes) or the bag timeline (play, pause, scrub, speed). viser serves its own web client from
the wheel; the page shows "Connecting..." in its panel when it loses the server and reconnects by itself when a server
is back. viser listens on a private loopback port behind the gate (`gate.py`), which serves `--host`/`--port`, checks
every message a browser sends (`wire.py`) and, with a token, makes pages that have not presented it read-only.

A world of several characters (`scene.WorldView`) draws every character's surface, each with its name above it; one is
selected (the 'character' dropdown, or a click on its body): its goals, pushes, path, feet, figures and the camera's
follow are its. A lone iguana's page is as it was (no dropdown, no names).
"""
from __future__ import annotations

from dataclasses import dataclass, field
import math
import socket
import threading
import time

import numpy as np

from iguana_ros.errors import InputError
from iguana_ros.render.renderer import TRAIL_LIFT, TRAIL_RGB
from iguana_ros.scene import MAX_PUSH_FORCE
from iguana_ros.view.gate import Gate, GateConfig, say, TOKEN_PARAMETER
from iguana_ros.view.playback import Playback, SPEEDS
from iguana_ros.view.scene import Body, flank_push, panel_lines, PUSH_SIDES, RunView, terrain_hit, ViewFrame, WorldView
from iguana_ros.view.wire import InputRule

DRAW_HZ = 20.0
"""How often the page is redrawn, per wall second, by default (`iguana view --rate`)."""

MAX_DRAW_HZ = 60.0
"""Most redraws per second a page may be asked for (a browser draws at most ~60 frames a second)."""

PATH_PIECE = 200
"""Segments of the root's path per scene node: a growing path resends only its last piece."""

CAMERA_OFFSET = np.array([-0.5, -0.65, 0.4])
"""Where the camera starts, relative to the root, m (behind-left and above, looking at the root)."""

CLOSE_S = 1.0
"""Wall seconds `close` waits for the server to stop."""

FOLLOW_STEP_M = 0.01
"""The cameras follow the root once it has moved this far, m."""

AIM_TOLERANCE_M = 0.001
"""How near CAMERA_OFFSET a browser's reported camera-to-look-at offset shows that it took the page's aim, m."""

CONTACT_RGB = (240, 140, 40)
PUSH_RGB = (210, 0, 0)
SIM_BUTTONS = (('pause', 'pause'), ('resume', 'resume'), ('step 1 frame', 'step'), ('reset to the start', 'reset'))
"""Live mode's simulation buttons: (label, the simulator's sim/* service they call)."""

DEFAULT_PUSH_N = 40.0
"""The push button's default force, N (Section VIII-D)."""

LABEL_LIFT_M = 0.12
"""Height of a character's name above its root, m."""

LONE = '(the iguana)'
"""How the dropdown names the character '' (a lone iguana's root topics) beside named ones."""


def character_label(name: str) -> str:
    """Return how the page names character `name` ('' : LONE)."""
    return name or LONE


def goal_topic(name: str) -> str:
    """Return the goal topic of character `name` relative to the viewer's namespace ('east/goal_pose', 'goal_pose')."""
    return f'{name}/goal_pose' if name else 'goal_pose'


def _rgb(rgba: np.ndarray) -> tuple[int, int, int]:
    """0..255 RGB of the median colour of RGBA rows `(n, 4)` in [0, 1]."""
    rgb = np.clip(np.median(np.asarray(rgba, float)[:, :3], axis=0), 0.0, 1.0)
    return tuple(int(round(c * 255)) for c in rgb)


def _quiet():
    """
    Return a context in which stdout is swallowed.

    viser prints a banner of its own at start and a line at stop (the CLI prints one line with the address).
    """
    import contextlib
    import io
    return contextlib.redirect_stdout(io.StringIO())


def check_port(host: str, port: int) -> None:
    """`InputError` (one line) unless a server can listen on `host`:`port` (0 = any free port)."""
    if not 0 <= port <= 65535:
        raise InputError(f'port {port} is out of range; expected 0..65535 (0 = any free port)')
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except socket.gaierror as exc:
        raise InputError(f'cannot listen on host {host!r}: {exc.strerror}') from None
    family, kind, proto, _, address = infos[0]
    with socket.socket(family, kind, proto) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the server will: TIME_WAIT is no obstacle
        try:
            probe.bind(address)
        except OSError as exc:
            what = 'is in use' if exc.errno == 98 else f'cannot be used ({exc.strerror})'
            raise InputError(f'port {port} on {host} {what}; choose another with --port (0 = any free port)') from None


def is_loopback(host: str) -> bool:
    """Return True if every address `host` stands for is this machine's loopback (only this machine can connect)."""
    import ipaddress
    try:
        infos = socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)
    except socket.gaierror:
        return False
    return bool(infos) and all(ipaddress.ip_address(info[4][0].split('%')[0]).is_loopback for info in infos)


TOKEN_ENV = 'IGUANA_VIEW_TOKEN'
"""Environment variable with the viewer's token when --token is not given."""

TOKEN_PATTERN = r'[A-Za-z0-9._~-]{8,128}'
"""What a token may be: it travels in an address and a cookie unescaped."""


def resolve_token(given: str | None, env: dict | None = None, flag: str = '--token') -> str | None:
    """Return the page's token: `given` ('auto': a random one), else $IGUANA_VIEW_TOKEN, else None (InputError: bad)."""
    import os
    import re
    import secrets

    if given is None:
        given = (os.environ if env is None else env).get(TOKEN_ENV) or None
        flag = TOKEN_ENV
    if given == 'auto':
        return secrets.token_urlsafe(18)
    if given is not None and not re.fullmatch(TOKEN_PATTERN, given):
        raise InputError(f'{flag} must be 8 to 128 of the characters A-Z a-z 0-9 . _ ~ - (it travels in an address '
                         f"and a cookie), or 'auto' for a random one; got {len(given)} characters")
    return given


def exposure_lines(host: str, port: int, token: str | None, live: bool) -> list[str]:
    """Return the warning (no token) or note (a token) for a page served beyond this machine; [] on loopback."""
    if is_loopback(host):
        return []
    steer = 'steer and push the iguana' if live else 'drive the timeline'
    if token is None:
        return [f'warning: serving on {host}, not on this machine only: anyone who can reach port {port} can {steer}, '
                f'with no login; --token auto (or {TOKEN_ENV}) makes every page without the token read-only']
    return [f'note: serving on {host}: anyone who can reach port {port} can watch; only a page opened with the token '
            f'can {steer} (plain HTTP: the token crosses the network unencrypted)']


def check_draw_rate(rate: float | None, flag: str = '--rate') -> float:
    """Return the page's redraws per second (DRAW_HZ for None); InputError naming `flag` outside (0, MAX_DRAW_HZ]."""
    if rate is None:
        return DRAW_HZ
    if not 0.0 < rate <= MAX_DRAW_HZ:
        raise InputError(f'{flag} is {rate:g}; expected redraws per second in (0, {MAX_DRAW_HZ:g}]')
    return float(rate)


@dataclass
class _Drawn:
    """What the page shows now, so only changes are sent."""

    terrain_version: int = 0
    mesh_times: dict = field(default_factory=dict)
    """The time of each character's drawn surface, by name."""
    labels: dict = field(default_factory=dict)
    """The (text, position) of each character's drawn name, by name."""
    path_pieces: list = field(default_factory=list)
    """The points (as bytes) of each drawn piece of the root's path."""
    contacts: bytes = b'-'
    arrows: bytes = b'-'
    goals: object = None
    panel: str = ''
    followed: np.ndarray | None = None
    """The root position the cameras were last moved for."""


class ViewerPage:
    """
    The web page of one viewer: `serve(stop)` draws until `stop` is set, `close()` stops the server.

    `view` is a lone iguana's RunView or a world's WorldView; `live` (a LiveSource) enables goals and pushes;
    `playback` (a Playback) shows the timeline.
    """

    def __init__(self, view: RunView | WorldView, host: str = '127.0.0.1', port: int = 8080, title: str = 'iguana view',
                 live=None, playback: Playback | None = None, notes: tuple = (), draw_hz: float | None = None,
                 token: str | None = None) -> None:
        """
        Start the page on `host`:`port` (InputError if the port is taken), redrawing `draw_hz` times a second.

        With `token`, a page must present it (`url` carries it) for anything but its camera to be taken.
        """
        import viser

        check_port(host, port)
        self.draw_hz = check_draw_rate(draw_hz)
        self.world = WorldView.of(view)
        self.view, self.live, self.playback, self.host, self.token = self.world.world, live, playback, host, token
        self.inputs: dict[str, InputRule] = {}
        self.gate: Gate | None = None
        with _quiet():  # on a private loopback port; the gate is the public one
            self.server = viser.ViserServer(host='127.0.0.1', port=0, verbose=False)  # Connected / Connecting...
        try:
            self._build(title, notes)
            self.gate = Gate(GateConfig(self.server.get_port(), host, port, token, self.inputs))
        except BaseException:
            self.close()
            raise
        self.port = self.gate.port

    def _build(self, title: str, notes: tuple) -> None:
        """Set up the scene, the panel, the controls and the click handlers."""
        self.server.scene.set_up_direction('+z')
        self.drawn = _Drawn()
        self.handles: dict[str, object] = {}
        self.status = ('Click on the terrain to send a goal; shift-click to point the heading to arrive in.'
                       if self.live is not None else '')
        self.pending_goal: tuple[float, float] | None = None
        self.pending_heading = ''
        self.pending_to = ''
        self.last_goals: dict[str, tuple[float, float]] = {}
        """The last goal sent to each character, for a shift-click's heading."""
        self.selected = ''
        """The selected character ('' : a lone iguana's)."""
        self.cast: tuple[str, ...] = ()
        """The characters listed (those with a surface), sorted."""
        self.bodies: list[Body] = []
        """The characters' bodies as last drawn."""
        self.aimed: set[int] = set()
        """The browsers (client ids) whose camera has shown the page's aim: from then on its pose is theirs."""
        self._selector = None
        self.server.gui.add_markdown(f'**{title}**')
        self._panel = self.server.gui.add_markdown('')
        self._status = self.server.gui.add_markdown(self.status)
        for note in notes:
            self.server.gui.add_markdown(f'*{note}*')
        self._follow = self._input(self.server.gui.add_checkbox('follow the iguana', initial_value=True),
                                   InputRule('follow the iguana', 'checkbox'))
        if self.live is not None:
            self._live_controls()
        if self.playback is not None:
            self._timeline()
        self.server.scene.on_click()(_guarded(self._on_click, 'a click'))
        self.server.scene.on_click(modifier='shift')(_guarded(self._on_heading_click, 'a shift-click'))
        self.server.on_client_connect(self._on_connect)
        self.server.on_client_disconnect(lambda client: self.aimed.discard(client.client_id))

    def _input(self, handle, rule: InputRule):
        """Return GUI input `handle`, its values from now on checked against `rule` before viser takes them."""
        self.inputs[handle._impl.uuid] = rule  # viser names an input by this uuid on the wire, and nowhere publicly
        return handle

    @property
    def url(self) -> str:
        """Return the page's address (with `?token=` when there is a token)."""
        host = f'[{self.host}]' if ':' in self.host else self.host
        query = f'?{TOKEN_PARAMETER}={self.token}' if self.token else ''
        return f'http://{host}:{self.port}/{query}'

    # ------------------------------------------------------------------------------------------ controls
    def _live_controls(self) -> None:
        """Push force and one button per flank; the simulation's pause, resume, step and reset."""
        gui = self.server.gui
        with gui.add_folder('simulation'):
            for label, command in SIM_BUTTONS:
                button = self._input(gui.add_button(label), InputRule(label, 'button'))
                button.on_click(_guarded(lambda _event, command=command: self._set_status(
                    self.live.send_sim(command, 1)), label))
        self._force = self._input(gui.add_number('push force (N)', initial_value=DEFAULT_PUSH_N, min=0.0,
                                                 max=float(MAX_PUSH_FORCE), step=1.0),
                                  InputRule('push force (N)', 'number', 0.0, float(MAX_PUSH_FORCE)))
        for side in PUSH_SIDES:
            button = self._input(gui.add_button(f'push {side} flank'), InputRule(f'push {side} flank', 'button'))
            button.on_click(_guarded(lambda _event, side=side: self._push(side), f'push {side} flank'))

    def _push(self, side: str) -> None:
        """Send a push on flank `side` with the panel's force, sideways to the iguana's heading."""
        name = self.selected
        with self.world.lock:
            view = self.world.views.get(name, self.view)
            k = view.states.index_at(view.end_time)
            yaw = float(view.states.values[k, 3]) if k >= 0 else 0.0
        force, region = flank_push(yaw, self._force.value, side)
        if name:
            self.live.send_push(force, region, character=name)
            self._set_status(f'push of {self._force.value:g} N sent on {region} of {name}.')
        else:
            self.live.send_push(force, region)
            self._set_status(f'push of {self._force.value:g} N sent on {region}.')

    def _timeline(self) -> None:
        """Play/pause, time slider, speed and loop (bag mode)."""
        gui, pb = self.server.gui, self.playback
        folder = gui.add_folder('timeline')
        low, high = round(pb.start, 3), round(max(pb.end, pb.start + 1e-3), 3)
        speeds = tuple(f'{s:g}x' for s in sorted(set(SPEEDS) | {pb.speed}))   # --speed may ask for another one
        with folder:
            self._play = self._input(gui.add_button('pause' if pb.playing else 'play'), InputRule('play', 'button'))
            self._time = self._input(gui.add_slider('time (s)', min=low, max=high, step=0.01,
                                                    initial_value=round(pb.time, 3)),
                                     InputRule('time (s)', 'number', low, high))
            self._speed = self._input(gui.add_dropdown('speed', speeds, initial_value=f'{pb.speed:g}x'),
                                      InputRule('speed', 'choice', choices=speeds))
            self._loop = self._input(gui.add_checkbox('loop', initial_value=pb.loop), InputRule('loop', 'checkbox'))
        self._was_playing = pb.playing
        self._play.on_click(_guarded(lambda _event: pb.toggle(), 'play'))
        self._time.on_update(_guarded(lambda event: pb.seek(self._time.value) if event.client is not None else None,
                                      'a time'))
        self._speed.on_update(_guarded(lambda _event: setattr(pb, 'speed', float(self._speed.value.rstrip('x'))),
                                       'a speed'))
        self._loop.on_update(_guarded(lambda _event: setattr(pb, 'loop', bool(self._loop.value)), 'loop'))

    def _on_click(self, event) -> None:
        """
        Handle a click in the scene: on a character's body (of several), select it; on the terrain in live mode, a goal.

        The nearer of the terrain and the bodies along the click's ray is what was clicked.
        """
        with self.view.lock:
            corners = self.view.terrain_points
        hit = None if corners is None else terrain_hit(event.ray_origin, event.ray_direction, corners)
        body = self._body_hit(event.ray_origin, event.ray_direction, hit)
        if body is not None:
            self._select(body)
            return
        if hit is None:
            self._set_status('That click missed the terrain; click on the ground to send a goal.')
        elif self.live is None:
            self._set_status(f'Bag mode: goals are sent in live mode (clicked x {hit[0]:.2f} m, y {hit[1]:.2f} m).')
        else:
            name = self.selected
            x, y = float(hit[0]), float(hit[1])
            self._send_goal(name, x, y, None)
            self.pending_goal = self.last_goals[name] = (x, y)
            self.pending_heading, self.pending_to = '', name
            self._set_status(f'goal x {hit[0]:.2f} m, y {hit[1]:.2f} m sent on {goal_topic(name)}; waiting for the '
                             f'planner.')

    def _send_goal(self, name: str, x: float, y: float, yaw: float | None) -> None:
        """Send a goal to character `name` (a lone iguana's call as before characters: no `character`)."""
        if name:
            self.live.send_goal(x, y, yaw, character=name)
        elif yaw is None:
            self.live.send_goal(x, y)
        else:
            self.live.send_goal(x, y, yaw)

    def _body_hit(self, origin, direction, terrain: np.ndarray | None) -> str | None:
        """Return the character whose body a ray meets before `terrain` (its hit, or None), when there are several."""
        if len(self.bodies) < 2:
            return None
        o = np.asarray(origin, float)
        nearest = math.inf if terrain is None else float(np.linalg.norm(terrain - o))
        found = None
        for body in self.bodies:
            hit = None if body.mesh is None else terrain_hit(origin, direction, np.asarray(body.mesh.points, float))
            if hit is not None and float(np.linalg.norm(hit - o)) < nearest:
                nearest, found = float(np.linalg.norm(hit - o)), body.name
        return found

    def _select(self, name: str) -> None:
        """Make character `name` the selected one (its goals, pushes, path, figures; the cameras follow it)."""
        if name not in self.cast:
            return
        if self._selector is not None and self._selector.value != character_label(name):
            self._selector.value = character_label(name)      # first: whoever sees `selected` sees the dropdown
        self.selected = name
        self._set_status(f'{character_label(name)} selected: a click on the terrain sends its goal on '
                         f'{goal_topic(name)}.' if self.live is not None else f'{character_label(name)} selected.')

    def _on_heading_click(self, event) -> None:
        """Handle a shift-click in live mode: send the last goal again, heading from it toward the clicked point."""
        with self.view.lock:
            corners = self.view.terrain_points
        hit = None if corners is None else terrain_hit(event.ray_origin, event.ray_direction, corners)
        name = self.selected
        if self.live is None or name not in self.last_goals or hit is None:
            self._set_status('Click on the terrain for a goal first, then shift-click where it should face.')
            return
        x, y = self.last_goals[name]
        if math.hypot(hit[0] - x, hit[1] - y) < 1e-3:
            self._set_status('Shift-click away from the goal to point its heading.')
            return
        yaw = math.degrees(math.atan2(hit[1] - y, hit[0] - x))
        self._send_goal(name, x, y, yaw)
        self.pending_goal, self.pending_heading, self.pending_to = (x, y), f' heading {yaw:.0f} deg', name
        self._set_status(f'goal x {x:.2f} m, y {y:.2f} m heading {yaw:.0f} deg sent on {goal_topic(name)}; waiting '
                         f'for the planner.')

    def _list_characters(self) -> None:
        """
        List the characters that have a surface; select the first once there is one, the dropdown once there are two.

        A new character (live: a late one) is added to the dropdown's options and to what the page may send.
        """
        cast = tuple(self.world.names)
        if cast == self.cast:
            return
        self.cast = cast
        if self.selected not in cast and cast:
            self.selected = cast[0]
        if len(cast) < 2:
            return
        labels = tuple(character_label(name) for name in cast)
        rule = InputRule('character', 'choice', choices=labels)
        if self._selector is None:
            self._selector = self._input(self.server.gui.add_dropdown(
                'character', labels, initial_value=character_label(self.selected), order=self._status.order - 0.5,
                hint=('clicks on the terrain send goals to this character' if self.live is not None else
                      'the character whose path and figures are shown') + '; a click on a body selects it too'), rule)
            self._selector.on_update(_guarded(lambda _event: self._select(
                cast_name(self._selector.value, self.cast)), 'a character'))
        else:
            self.inputs[self._selector._impl.uuid] = rule   # before the page can offer the new option
            self._selector.options = labels

    def _set_status(self, text: str) -> None:
        """Show `text` under the figures."""
        self.status = text
        self._status.content = text

    def _on_connect(self, client) -> None:
        """
        Hear a new browser's camera reports (`_camera_report`); the next draw points its camera at the iguana.

        Not aimed here: this runs on viser's thread pool, and an aim written into the camera's state while the
        browser's first report is handed to `_camera_report` would read as the browser having taken it.
        """
        client.camera.on_update(self._camera_report)

    async def _camera_report(self, camera) -> None:
        """
        Take note once a browser's camera shows the page's aim (CAMERA_OFFSET from what it looks at): `_follow_root`.

        A coroutine: viser runs it on its event loop as the report arrives, before the next report replaces it.
        """
        offset = np.asarray(camera.position, float) - np.asarray(camera.look_at, float)
        if np.allclose(offset, CAMERA_OFFSET, atol=AIM_TOLERANCE_M):
            self.aimed.add(camera.client.client_id)

    @staticmethod
    def _aim(camera, root: np.ndarray) -> None:
        """Camera behind-left of and above `root`, looking at it."""
        camera.position = tuple(root + CAMERA_OFFSET)
        camera.look_at = tuple(root)

    # ------------------------------------------------------------------------------------------ drawing
    def serve(self, stop: threading.Event) -> None:
        """Advance the timeline (while a browser is connected) and redraw `draw_hz` times a second until `stop`."""
        last = time.monotonic()
        while not stop.wait(1.0 / self.draw_hz):
            now = time.monotonic()
            watched = bool(self.server.get_clients())
            t = self.playback.advance(now - last if watched else 0.0) if self.playback else None
            last = now
            self._list_characters()
            self.draw(self.world.frame(self.selected, t), self.world.bodies(t))
            if self.playback is not None:
                self._show_playback()
            if self.live is not None:
                self._goal_status()
                for answer in self.live.sim_answers():
                    self._set_status(answer)

    def _show_playback(self) -> None:
        """
        Show the timeline's controls as the clock stands.

        The slider follows the clock only while it plays (and once more as it stops): paused, the slider and its number
        field are the user's, so a value being typed is never overwritten by the clock's previous one.
        """
        pb = self.playback
        if (pb.playing or self._was_playing) and abs(self._time.value - pb.time) >= 0.01:
            self._time.value = round(pb.time, 3)
        self._was_playing = pb.playing
        self._play.label = 'pause' if pb.playing else 'play'

    def draw(self, frame: ViewFrame, bodies: list[Body] | None = None) -> None:
        """
        Send what changed since the last draw.

        `frame` is the selected character's; `bodies` every character's (None: `frame`'s alone, a lone iguana's).
        """
        drawn, scene = self.drawn, self.server.scene
        if bodies is None:
            bodies = [Body(self.selected, frame.mesh, frame.root)]
        self.bodies = bodies
        with self.server.atomic():
            if frame.terrain_version != drawn.terrain_version:
                self._draw_terrain()
                drawn.terrain_version = frame.terrain_version
            for body in bodies:
                if body.mesh is not None and body.mesh.time != drawn.mesh_times.get(body.name):
                    self._draw_mesh(body)
                    drawn.mesh_times[body.name] = body.mesh.time
            self._draw_labels(bodies)
            self._draw_path(frame.path)
            self._draw_points('contacts', frame.contacts, lambda p: scene.add_point_cloud(
                '/contacts', p.astype(np.float32), colors=CONTACT_RGB, point_size=0.035, point_shape='circle',
                precision='float32'))
            self._draw_points('arrows', frame.arrows, lambda a: scene.add_arrows(
                '/pushes', a.astype(np.float32), colors=PUSH_RGB, shaft_radius=0.012, head_radius=0.03,
                head_length=0.07))
            if frame.goals is not drawn.goals:
                self._draw_goals(frame)
                drawn.goals = frame.goals
            panel = '  \n'.join(panel_lines(frame) + self._cast_lines())
            if panel != drawn.panel:
                self._panel.content = panel
                drawn.panel = panel
            if frame.root is not None:
                self._follow_root(frame.root)

    def _follow_root(self, root: np.ndarray) -> None:
        """
        Aim new browsers at the root.

        A browser is aimed at every draw until its camera has reported the aim (`aimed`; the aim is sent only when the
        camera's last report differs from it). Until then what it reports may be the pose it had before it took the aim:
        its default one, 5 m away, sent while the page loads and arriving after the aim was sent; followed, that pose
        would stay, the iguana small in a corner.

        Once the root has moved FOLLOW_STEP_M, with 'follow the iguana', every aimed camera is moved so it looks at the
        root from the angle and distance that browser has (setting a viser camera's position moves its look-at along).
        """
        drawn = self.drawn
        moved = drawn.followed is None or np.linalg.norm(root - drawn.followed) >= FOLLOW_STEP_M
        if moved:
            self._aim(self.server.initial_camera, root)
        for client_id, client in self.server.get_clients().items():
            camera = client.camera
            if client_id not in self.aimed:
                self._aim(camera, root)
            elif moved and self._follow.value:
                shift = root - np.asarray(camera.look_at, float)
                camera.position = tuple(np.asarray(camera.position, float) + shift)
        if moved:
            drawn.followed = root.copy()

    def _replace(self, name: str, handle) -> None:
        """Keep `handle` as the scene node `name` (None: remove the old one)."""
        old = self.handles.pop(name, None)
        if handle is None and old is not None:  # a new node of the same name replaces the old one by itself
            old.remove()
        if handle is not None:
            self.handles[name] = handle

    def _draw_terrain(self) -> None:
        """Draw the terrain mesh (its median colour, both sides)."""
        with self.view.lock:
            points, colors = self.view.terrain_points, self.view.terrain_colors
        n = len(points) - len(points) % 3
        self._replace('terrain', self.server.scene.add_mesh_simple(
            '/terrain', points[:n].astype(np.float32), np.arange(n, dtype=np.uint32).reshape(-1, 3),
            color=_rgb(colors[:n]), side='double', cast_shadow=False))

    def _cast_lines(self) -> list[str]:
        """Return the panel's line naming the characters, the selected one in bold (none for one character)."""
        if len(self.cast) < 2:
            return []
        names = [f'**{character_label(n)}** (selected)' if n == self.selected else character_label(n)
                 for n in self.cast]
        return [f'characters: {", ".join(names)}']

    def _draw_mesh(self, body: Body) -> None:
        """
        Draw a character's surface (its median colour, flat-shaded); the same triangle count only moves vertices.

        A lone iguana's is the scene node /iguana, character east's /iguanas/east.
        """
        key, node = ('iguana', '/iguana') if not body.name else (f'iguana/{body.name}', f'/iguanas/{body.name}')
        points = body.mesh.points.astype(np.float32)
        handle = self.handles.get(key)
        if handle is not None and handle.vertices.shape == points.shape:
            handle.vertices = points
            return
        self._replace(key, self.server.scene.add_mesh_simple(
            node, points, np.arange(len(points), dtype=np.uint32).reshape(-1, 3), color=_rgb(body.mesh.colors),
            flat_shading=True, side='double'))

    def _draw_labels(self, bodies: list[Body]) -> None:
        """Name each character above its root (when there are several), the selected one marked."""
        drawn = self.drawn.labels
        shown = bodies if len(bodies) >= 2 else []
        for body in shown:
            place = body.root if body.root is not None else (
                None if body.mesh is None else np.asarray(body.mesh.points, float).mean(axis=0))
            if place is None:
                continue
            position = tuple(round(float(v), 2) for v in np.asarray(place, float) + [0.0, 0.0, LABEL_LIFT_M])  # 1 cm
            text = f'{character_label(body.name)} (selected)' if body.name == self.selected else character_label(
                body.name)
            old = drawn.get(body.name)
            if old == (text, position):
                continue
            handle = self.handles.get(f'label/{body.name}')
            if handle is None:
                self._replace(f'label/{body.name}', self.server.scene.add_label(
                    f'/labels/{body.name or "iguana"}', text, position=position, anchor='bottom-center'))
            else:
                handle.text, handle.position = text, position
            drawn[body.name] = (text, position)
        for name in [n for n in drawn if n not in {b.name for b in shown}]:
            self._replace(f'label/{name}', None)
            del drawn[name]

    def _draw_path(self, path: np.ndarray) -> None:
        """
        Draw the root's path so far `(n, 3)`, lifted a little off the ground, in pieces of PATH_PIECE segments.

        Only the pieces whose points changed are sent: as a run goes on that is the last one (the path only grows
        between the doublings of its thinning, `scene.path_stride`), not the whole path at every draw.
        """
        lifted = (np.asarray(path, float) + np.array([0.0, 0.0, TRAIL_LIFT])).astype(np.float32)
        n_segments = max(len(lifted) - 1, 0)
        pieces, drawn = -(-n_segments // PATH_PIECE), self.drawn.path_pieces
        for c in range(pieces):
            part = lifted[c * PATH_PIECE:min((c + 1) * PATH_PIECE, n_segments) + 1]
            key = part.tobytes()
            if c < len(drawn) and drawn[c] == key:
                continue
            self._replace(f'path/{c}', self.server.scene.add_line_segments(
                f'/path/{c}', np.stack([part[:-1], part[1:]], axis=1),
                colors=tuple(int(v * 255) for v in TRAIL_RGB), thickness=0.012))
            drawn[c:c + 1] = [key]
        for c in range(pieces, len(drawn)):
            self._replace(f'path/{c}', None)
        del drawn[pieces:]

    def _draw_points(self, name: str, values: np.ndarray, add) -> None:
        """Contacts or arrows: redrawn by `add(values)` when they changed, removed when there are none."""
        key = values.tobytes()
        if key == getattr(self.drawn, name):
            return
        setattr(self.drawn, name, key)
        self._replace(name, add(values) if len(values) else None)

    def _draw_goals(self, frame: ViewFrame) -> None:
        """One sphere per goal marker."""
        for name in [n for n in self.handles if n.startswith('goal/')]:
            self._replace(name, None)
        goals = frame.goals
        if goals is None:
            return
        for i, (position, radius, color) in enumerate(zip(goals.positions, goals.radii, goals.colors)):
            self._replace(f'goal/{i}', self.server.scene.add_icosphere(
                f'/goals/{i}', radius=float(radius), color=_rgb(np.asarray(color)[None]),
                position=tuple(float(v) for v in position)))

    def _goal_status(self) -> None:
        """Once the planner lists the last goal sent among its accepted goals, say so (live mode)."""
        if self.pending_goal is not None and self.live.goal_accepted():
            x, y = self.pending_goal
            whose = f' of {self.pending_to}' if self.pending_to else ''
            self._set_status(f'goal x {x:.2f} m, y {y:.2f} m{self.pending_heading} accepted by the planner{whose}.')
            self.pending_goal = None

    def close(self) -> None:
        """
        Stop the server (the page then shows that it lost it), waiting at most CLOSE_S.

        viser's stop waits up to 5 s for a connected browser's goodbye, and its server thread is a daemon that exit ends
        anyway.
        """
        def stop() -> None:
            with _quiet():
                self.server.stop()
        if self.gate is not None:
            self.gate.close()
        stopper = threading.Thread(target=stop, name='iguana-view-stop', daemon=True)
        stopper.start()
        stopper.join(CLOSE_S)


def cast_name(label: str, cast: tuple) -> str:
    """Return the character a dropdown `label` names among `cast` ('' for LONE)."""
    return next((name for name in cast if character_label(name) == label), label)


def _guarded(callback, what: str):
    """Return `callback` that logs one line instead of raising (viser would print a traceback for each event)."""
    def guarded(event) -> None:
        try:
            callback(event)
        except Exception as exc:  # noqa: BLE001 -- one line per failed event; the page goes on
            client = getattr(getattr(event, 'client', None), 'client_id', '?')
            say(f'ignored {what} from page {client}: {type(exc).__name__}: {exc}')
    return guarded
