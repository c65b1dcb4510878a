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
The viewer's front door: every byte between a browser and viser passes through it.

viser serves on a private loopback port; the gate listens on `iguana view --host/--port`, hands the page through and
relays each websocket message. A message from a page is passed on only if `wire.check_message` accepts it: anything
else is dropped with one line on stderr (what was wrong, from which address), and the connection stays open. With a
token, a page that has not presented it (`?token=` on the page's address, kept in a cookie for its websocket, or on
the websocket's own address) is read-only: only its camera reaches viser, so it can watch but sends no goal, push or
other control.
"""
from __future__ import annotations

import asyncio
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
import hmac
import http.client
from http.cookies import CookieError, SimpleCookie
import logging
import sys
import threading
from urllib.parse import parse_qs, urlsplit

from iguana_ros.errors import InputError
from iguana_ros.view.wire import BadMessage, check_message, InputRule, READ_ONLY_TYPES

MAX_PAGE_MESSAGE = 1 << 20
"""Largest websocket message a page may send, bytes (its largest real one, a camera or a click, is ~200 bytes)."""

MAX_LINES_PER_CONNECTION = 50
"""Dropped messages of one connection that get a line each; the rest are counted in one last line."""

START_S = 10.0
"""Wall seconds the gate may take to listen."""

TOKEN_PARAMETER = 'token'
"""The query parameter that carries the token (`http://HOST:PORT/?token=...`)."""


def say(line: str) -> None:
    """Print one line of the viewer's log on stderr."""
    print(f'iguana view: {line}', file=sys.stderr, flush=True)


def cookie_name(port: int) -> str:
    """Return the name of the cookie that keeps a page's token (per port: cookies do not tell ports apart)."""
    return f'iguana_view_token_{port}'


@dataclass
class _Peer:
    """One browser connection: where from, whether it presented the token, how many of its messages were dropped."""

    address: str
    allowed: bool
    dropped: int = 0
    refused: bool = False


@dataclass
class GateConfig:
    """What the gate serves: viser's loopback port, the public address, the token (None: none), the page's inputs."""

    inner_port: int
    host: str
    port: int
    token: str | None = None
    inputs: Mapping[str, InputRule] = field(default_factory=dict)
    log: Callable[[str], None] = say


class Gate:
    """The public server of one viewer page, relaying to viser on `config.inner_port`; `close()` stops it."""

    def __init__(self, config: GateConfig) -> None:
        """Listen on `config.host`:`config.port` (0: any free port; InputError if it cannot) in a thread of its own."""
        self.config = config
        self.port = 0
        self._loop = asyncio.new_event_loop()
        self._stop: asyncio.Event | None = None
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name='iguana-view-gate', daemon=True)
        self._thread.start()
        if not self._ready.wait(START_S):
            raise InputError(f'the viewer could not listen on {config.host}:{config.port} within {START_S:g} s')
        if self._error is not None:
            raise InputError(f'cannot listen on {config.host}:{config.port}: {self._error}') from None

    # ------------------------------------------------------------------------------------------ server
    def _run(self) -> None:
        """Thread body: serve until `close()`."""
        asyncio.set_event_loop(self._loop)
        try:
            self._loop.run_until_complete(self._serve())
        except BaseException as exc:  # noqa: BLE001 -- reported to the constructor, which raises InputError
            self._error = exc
            self._ready.set()
        finally:
            self._loop.close()

    async def _serve(self) -> None:
        """Listen, report the port, wait for `close()`."""
        from websockets.asyncio.server import serve

        self._stop = asyncio.Event()
        async with serve(self._relay, self.config.host, self.config.port, process_request=self._http,
                         select_subprotocol=_viser_subprotocol, compression=None, max_size=MAX_PAGE_MESSAGE,
                         logger=_quiet_logger()) as server:
            self.port = server.sockets[0].getsockname()[1]
            self._ready.set()
            await self._stop.wait()

    def close(self) -> None:
        """Stop listening and drop every connection (waits up to a second)."""
        if self._stop is not None and not self._loop.is_closed():
            self._loop.call_soon_threadsafe(self._stop.set)
        self._thread.join(1.0)

    # ------------------------------------------------------------------------------------------ token
    def _presented(self, request) -> str | None:
        """Return the token a request presents: `?token=` on its address, else the page's cookie (None: none)."""
        given = parse_qs(urlsplit(request.path).query).get(TOKEN_PARAMETER)
        if given:
            return given[0]
        try:
            cookie = SimpleCookie(request.headers.get('Cookie', ''))
        except CookieError:
            return None
        morsel = cookie.get(cookie_name(self.port))
        return morsel.value if morsel is not None else None

    def _matches(self, given: str | None) -> bool:
        """Return True if there is no token, or `given` is it."""
        token = self.config.token
        return token is None or (given is not None and hmac.compare_digest(given.encode(), token.encode()))

    # ------------------------------------------------------------------------------------------ http
    async def _http(self, connection, request):
        """Answer a page request with viser's (a wrong token: 403); None lets a websocket handshake go on."""
        from websockets.datastructures import Headers
        from websockets.http11 import Response

        query = parse_qs(urlsplit(request.path).query)
        if TOKEN_PARAMETER in query and not self._matches(query[TOKEN_PARAMETER][0]):
            self.config.log(f'refused {_address(connection)}: wrong token')
            return Response(403, 'Forbidden', Headers({'Content-Type': 'text/plain; charset=utf-8'}),
                            b'iguana view: wrong token\n')
        if request.headers.get('Upgrade', '').lower() == 'websocket':
            return None
        status, reason, headers, body = await asyncio.to_thread(self._fetch, request.path,
                                                                request.headers.get('Accept-Encoding', ''))
        if self.config.token is not None and TOKEN_PARAMETER in query:
            headers['Set-Cookie'] = (f'{cookie_name(self.port)}={query[TOKEN_PARAMETER][0]}; Path=/; HttpOnly; '
                                     'SameSite=Strict')
        return Response(status, reason, Headers(headers), body)

    def _fetch(self, path: str, encoding: str) -> tuple[int, str, dict, bytes]:
        """Return viser's answer to GET `path`: (status, reason, headers to pass on, body)."""
        conn = http.client.HTTPConnection('127.0.0.1', self.config.inner_port, timeout=10)
        try:
            conn.request('GET', path, headers={'Accept-Encoding': encoding} if encoding else {})
            answer = conn.getresponse()
            body = answer.read()
            kept = {k: v for k, v in answer.getheaders() if k.lower() in ('content-type', 'content-encoding')}
            return answer.status, answer.reason, {**kept, 'Content-Length': str(len(body))}, body
        except OSError as exc:
            return 502, 'Bad Gateway', {'Content-Type': 'text/plain'}, f'iguana view: {exc}\n'.encode()
        finally:
            conn.close()

    # ------------------------------------------------------------------------------------------ websocket
    async def _relay(self, page) -> None:
        """Relay one page's websocket to viser and back, checking what the page sends, until either side closes."""
        from websockets.asyncio.client import connect
        from websockets.exceptions import ConnectionClosed, WebSocketException

        peer = _Peer(_address(page), self._matches(self._presented(page.request)))
        protocols = [page.subprotocol] if page.subprotocol else None
        try:
            async with connect(f'ws://127.0.0.1:{self.config.inner_port}/', subprotocols=protocols,
                               compression=None, max_size=None, proxy=None) as viser:
                to_viser = asyncio.ensure_future(self._inbound(page, viser, peer))
                to_page = asyncio.ensure_future(_outbound(viser, page))
                done, pending = await asyncio.wait({to_viser, to_page}, return_when=asyncio.FIRST_COMPLETED)
                for task in pending:
                    task.cancel()
                await asyncio.gather(*pending, return_exceptions=True)
                if to_page in done and viser.close_code is not None:     # viser closed it: say why to the page
                    await page.close(viser.close_code, viser.close_reason or '')
        except (ConnectionClosed, WebSocketException, OSError) as exc:
            self.config.log(f'connection from {peer.address} ended: {type(exc).__name__}: {exc}')
        if peer.dropped > MAX_LINES_PER_CONNECTION:
            self.config.log(f'{peer.dropped - MAX_LINES_PER_CONNECTION} more messages from {peer.address} were '
                            'dropped without a line')

    async def _inbound(self, page, viser, peer: _Peer) -> None:
        """Pass the page's messages to viser: those `check_message` accepts, and only the camera without the token."""
        from websockets.exceptions import ConnectionClosed

        try:
            async for raw in page:
                try:
                    kind = check_message(raw, self.config.inputs)
                except BadMessage as exc:
                    self._dropped(peer, str(exc))
                    continue
                if not peer.allowed and kind not in READ_ONLY_TYPES:
                    if not peer.refused:
                        self.config.log(f'{peer.address} has not presented the token: its goals, pushes and '
                                        'controls are ignored (read-only)')
                        peer.refused = True
                    continue
                await viser.send(raw)
        except ConnectionClosed:
            pass

    def _dropped(self, peer: _Peer, why: str) -> None:
        """Log one dropped message of `peer` (up to MAX_LINES_PER_CONNECTION lines per connection)."""
        peer.dropped += 1
        if peer.dropped <= MAX_LINES_PER_CONNECTION:
            self.config.log(f'dropped a malformed message from {peer.address}: {why}')


async def _outbound(viser, page) -> None:
    """Pass viser's messages to the page as they are."""
    from websockets.exceptions import ConnectionClosed

    try:
        async for message in viser:
            await page.send(message)
    except ConnectionClosed:
        pass


def _viser_subprotocol(_connection, offered):
    """Return the first `viser-v...` subprotocol a page offers (as viser picks it), None if none."""
    return next((p for p in offered if p.startswith('viser-v')), None)


def _address(connection) -> str:
    """Return 'host:port' of a connection's remote end."""
    remote = connection.remote_address
    return f'{remote[0]}:{remote[1]}' if remote else 'an unknown address'


def _quiet_logger() -> logging.Logger:
    """Return the websockets server's logger: warnings and errors as one line each on stderr, no tracebacks."""
    logger = logging.getLogger('iguana_ros.view.gate')
    if not logger.handlers:
        logger.addHandler(_OneLine(logging.WARNING))
        logger.setLevel(logging.WARNING)
        logger.propagate = False
    return logger


class _OneLine(logging.Handler):
    """Say a log record as 'message (error type: error)', without its traceback."""

    def emit(self, record: logging.LogRecord) -> None:
        """Say the record's one line."""
        error = record.exc_info[1] if record.exc_info else None
        why = f' ({type(error).__name__}: {error})' if error is not None else ''
        say(f'{record.getMessage()}{why}')
