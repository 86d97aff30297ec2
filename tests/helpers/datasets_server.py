"""Test helpers for score4.runner.datasets: tiny tarballs and a loopback HTTP server."""

from __future__ import annotations

import hashlib
import io
import socket
import tarfile
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer


def make_tarball(members: dict[str, bytes | None]) -> bytes:
    """A .tar.gz holding ``members``: name -> file content, or None for a folder."""
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz") as tar:
        for name, content in members.items():
            info = tarfile.TarInfo(name)
            if content is None:
                info.type = tarfile.DIRTYPE
                info.mode = 0o755
                tar.addfile(info)
            else:
                info.size = len(content)
                info.mode = 0o644
                tar.addfile(info, io.BytesIO(content))
    return buf.getvalue()


def md5(data: bytes) -> str:
    return hashlib.md5(data).hexdigest()


@dataclass
class Route:
    """What the server sends for one path: the body, optionally cut short."""

    body: bytes
    truncate: bool = False  # announce the full length, send half, close
    # after sending half, wait this long (seconds; or until the server stops) before closing
    stall: float = 0.0


@dataclass
class Server:
    base_url: str
    routes: dict[str, Route]
    requests: list[str] = field(default_factory=list)
    stopped: threading.Event = field(default_factory=threading.Event)


def _handler(server_state: Server) -> type[BaseHTTPRequestHandler]:
    class Handler(BaseHTTPRequestHandler):
        def do_GET(self) -> None:  # name fixed by the http.server API
            server_state.requests.append(self.path)
            route = server_state.routes.get(self.path)
            if route is None:
                self.send_error(404, "Not Found")
                return
            self.send_response(200)
            self.send_header("Content-Type", "application/gzip")
            extra = 1000 if route.truncate else 0
            self.send_header("Content-Length", str(len(route.body) + extra))
            self.end_headers()
            cut = route.truncate or route.stall > 0
            self.wfile.write(route.body[: len(route.body) // 2] if cut else route.body)
            self.wfile.flush()
            server_state.stopped.wait(route.stall)
            self.close_connection = True

        def log_message(self, format: str, *args: object) -> None:  # http.server API
            pass  # keep test output clean

    return Handler


@contextmanager
def serve(routes: dict[str, Route]) -> Iterator[Server]:
    """Serve ``routes`` on 127.0.0.1 (a free port) in a thread."""
    state = Server("", routes)
    httpd = ThreadingHTTPServer(("127.0.0.1", 0), _handler(state))
    state.base_url = f"http://127.0.0.1:{httpd.server_address[1]}/datasets"
    thread = threading.Thread(target=httpd.serve_forever, args=(0.02,), daemon=True)
    thread.start()
    try:
        yield state
    finally:
        state.stopped.set()  # a stalled answer ends with the test
        httpd.shutdown()
        httpd.server_close()
        thread.join()


def closed_port() -> int:
    """A loopback port that nothing listens on (bound, then released)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]
