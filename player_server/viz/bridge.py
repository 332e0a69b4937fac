"""meshcat's web/ZeroMQ bridge, listening on loopback only.

Stock meshcat 0.3.2 (``meshcat.servers.zmqserver``) binds its ZeroMQ socket to the host it is
given but calls tornado's ``Application.listen(port)`` without an address, so the web viewer
(port 7000 and up) listens on every interface. Here the tornado application binds its sockets
on 127.0.0.1 explicitly, both ports may be 0 (the OS picks free ones), and the URLs printed are
the real ones. Its page is our own (`player_server.viz.page`): meshcat's viewer with the
overlay of robot labels, clock and legend.

Run as a process: ``python -m player_server.viz.bridge [--web-port P] [--zmq-port Q]``; it
prints ``zmq_url=...`` and ``web_url=...`` on two lines, then serves until killed.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import sys
import warnings
from typing import Any

import tornado.httpserver
import tornado.ioloop
import tornado.netutil
import tornado.web
import zmq
from zmq.eventloop.zmqstream import ZMQStream

with warnings.catch_warnings():
    # meshcat 0.3.2 imports pyzmq's deprecated zmq.eventloop.ioloop shim
    warnings.simplefilter("ignore", DeprecationWarning)
    from meshcat.servers.zmqserver import (
        VIEWER_HTML,
        VIEWER_ROOT,
        StaticFileHandlerNoCache,
        WebSocketHandler,
        ZMQWebSocketBridge,
    )

from player_server.viz.page import live_page_html

LOOPBACK = "127.0.0.1"


class LivePageHandler(tornado.web.RequestHandler):
    """The live view's page (meshcat's viewer with our overlay) in place of meshcat's own."""

    def get(self) -> None:
        self.set_header("Content-Type", "text/html; charset=utf-8")
        self.set_header("Cache-Control", "no-store")
        self.write(live_page_html())


class LoopbackApplication(tornado.web.Application):
    """A tornado application whose `listen` only ever binds 127.0.0.1."""

    bound_port: int = 0

    def listen(
        self, port: int, address: str | None = None, **kwargs: Any
    ) -> tornado.httpserver.HTTPServer:
        if address not in (None, "", LOOPBACK):
            raise ValueError(f"the viewer only listens on {LOOPBACK}, not {address!r}")
        sockets = tornado.netutil.bind_sockets(port, address=LOOPBACK)
        server = tornado.httpserver.HTTPServer(self, **kwargs)
        server.add_sockets(sockets)
        self.bound_port = sockets[0].getsockname()[1]
        return server


class LoopbackBridge(ZMQWebSocketBridge):
    """meshcat's bridge with both of its sockets on 127.0.0.1 and OS-chosen ports allowed."""

    def __init__(self, web_port: int = 0, zmq_port: int = 0) -> None:
        zmq_url = f"tcp://{LOOPBACK}:{zmq_port or '*'}"
        super().__init__(zmq_url=zmq_url, host=LOOPBACK, port=web_port)
        self.fileserver_port = self.app.bound_port
        self.web_url = f"http://{LOOPBACK}:{self.fileserver_port}/static/"

    def make_app(self) -> LoopbackApplication:
        return LoopbackApplication(
            [
                (r"/static/(?:index\.html)?", LivePageHandler),
                (
                    r"/static/(.*)",
                    StaticFileHandlerNoCache,
                    {"path": VIEWER_ROOT, "default_filename": VIEWER_HTML},
                ),
                (r"/", WebSocketHandler, {"bridge": self}),
            ]
        )

    def setup_zmq(self, url: str) -> tuple[Any, ZMQStream, str]:
        if not url.startswith(f"tcp://{LOOPBACK}:"):
            raise ValueError(f"the viewer's ZeroMQ socket only binds {LOOPBACK}, not {url!r}")
        sock = self.context.socket(zmq.REP)
        sock.bind(url)
        endpoint = sock.getsockopt(zmq.LAST_ENDPOINT).decode("ascii")
        stream = ZMQStream(sock)
        stream.on_recv(self.handle_zmq)
        return sock, stream, endpoint


def watch_parent(parent_pid: int, period_s: float = 0.5) -> tornado.ioloop.PeriodicCallback:
    """Stop the bridge's loop once `parent_pid` is no longer this process's parent (it died,
    however it died, and the process was re-parented): an orphaned viewer would hold its ports
    for ever."""

    def check() -> None:
        if os.getppid() != parent_pid:
            tornado.ioloop.IOLoop.current().stop()

    callback = tornado.ioloop.PeriodicCallback(check, period_s * 1000.0)
    callback.start()
    return callback


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="meshcat viewer server on 127.0.0.1 only")
    parser.add_argument("--web-port", type=int, default=0, help="0 = any free port")
    parser.add_argument("--zmq-port", type=int, default=0, help="0 = any free port")
    parser.add_argument("--parent-pid", type=int, default=0,
                        help="exit when this process (the owner) is gone (0 = never)")
    args = parser.parse_args(argv)
    bridge = LoopbackBridge(web_port=args.web_port, zmq_port=args.zmq_port)
    if args.parent_pid:
        watch_parent(args.parent_pid)
    # SIGTERM ends the loop like Ctrl-C, so the sockets are closed on the way out
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    sys.stdout.write(f"zmq_url={bridge.zmq_url}\nweb_url={bridge.web_url}\n")
    sys.stdout.flush()
    with contextlib.suppress(KeyboardInterrupt):
        bridge.run()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
