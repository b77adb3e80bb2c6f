"""Who may use ``lamech serve``: Jupyter server's checks, as an ASGI middleware.

- The Host header must name the address the server listens on (``127.0.0.1``,
  ``localhost`` or ``[::1]`` with its port, or the ``--host`` given): a DNS-rebinding
  page, whose requests carry its own host name, is refused (Jupyter's ``check_host``).
- A request from a page (an ``Origin`` header) must come from the server's own origin
  (Jupyter's ``check_origin``): another site's page cannot drive it.
- The token: ``Authorization: token TEXT`` (or ``Bearer TEXT``) or ``?token=TEXT``,
  compared in constant time (Jupyter's ``IdentityProvider``).
- A POST (work) takes ``application/json`` only: a cross-site "simple" form or
  ``text/plain`` request is refused before its body is read.

Each refusal is a 4xx with a message that says what to do, as JSON for ``/api/`` and
as text for the page.
"""

from __future__ import annotations

import hmac
import json
import re
from collections.abc import Iterable
from urllib.parse import parse_qs

from ..expr import printable

__all__ = ["Guard", "LOOPBACK"]

LOOPBACK = ("127.0.0.1", "localhost", "[::1]")
_HOST = re.compile(r"^(\[[0-9a-fA-F:.]*\]|[^:\[\]]*)(?::([0-9]{1,5}))?$")


def bracketed(host: str) -> str:
    """An IPv6 address as a Host header writes it: ``::1`` -> ``[::1]``."""
    return f"[{host}]" if ":" in host and not host.startswith("[") else host


class Guard:
    """ASGI middleware: Host, Origin, token and content type checked before ``app``."""

    def __init__(self, app, token: str, names: Iterable[str] = LOOPBACK, port: int | None = None):
        self.app = app
        self.token = token.encode("utf-8")
        self.names = {bracketed(n).lower() for n in names}
        self.port = port

    def _host_ok(self, host: str) -> bool:
        m = _HOST.match(host)
        if m is None or m.group(1).lower() not in self.names:
            return False
        return self.port is None or m.group(2) == str(self.port)

    def _where(self) -> str:
        port = f":{self.port}" if self.port is not None else ""
        return ", ".join(sorted(n + port for n in self.names))

    def _token_ok(self, headers: dict[bytes, bytes], query: bytes) -> bool:
        auth = headers.get(b"authorization", b"")
        scheme, _, given = auth.partition(b" ")
        if scheme.lower() in (b"token", b"bearer"):
            if hmac.compare_digest(given.strip(), self.token):
                return True
        values = parse_qs(query.decode("latin-1"), errors="replace").get("token", [])
        return any(hmac.compare_digest(v.encode("utf-8", "replace"), self.token) for v in values)

    def refusal(self, scope) -> tuple[int, str] | None:
        """(status, message) when the request may not go on; None when it may."""
        headers: dict[bytes, bytes] = {}
        for k, v in scope.get("headers", []):
            if k.lower() in headers and k.lower() in (b"host", b"origin", b"authorization"):
                return 400, f"the request has two {k.decode('latin-1')} headers"
            headers[k.lower()] = v
        host = headers.get(b"host", b"").decode("latin-1")
        if not self._host_ok(host):
            return 403, (
                f"Host `{printable(host[:100])}` is not this server's address "
                f"({self._where()}); open the URL the server printed when it started"
            )
        origin = headers.get(b"origin")
        if origin is not None and origin.decode("latin-1") != f"http://{host}":
            return 403, (
                f"a page from another origin (`{printable(origin.decode('latin-1')[:100])}`) "
                "may not use this server; open the page the server serves"
            )
        if not self._token_ok(headers, scope.get("query_string", b"")):
            return 403, (
                "this server needs its token: open the URL it printed when it started "
                "(…/?token=…), or send the header `Authorization: token TEXT`"
            )
        if scope.get("method") == "POST":
            kind = headers.get(b"content-type", b"").split(b";")[0].strip().lower()
            if kind != b"application/json":
                return 415, (
                    "a request to this server is JSON: send it with "
                    "`Content-Type: application/json`"
                )
        return None

    async def __call__(self, scope, receive, send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        refused = self.refusal(scope)
        if refused is None:
            await self.app(scope, receive, send)
            return
        status, message = refused
        if scope.get("path", "").startswith("/api/"):
            error = {"line": None, "where": "", "message": message, "text": None}
            body = json.dumps({"ok": False, "errors": [error]}, ensure_ascii=True).encode()
            kind = b"application/json"
        else:
            body, kind = (message + "\n").encode("utf-8"), b"text/plain; charset=utf-8"
        await send(
            {
                "type": "http.response.start",
                "status": status,
                "headers": [(b"content-type", kind), (b"content-length", str(len(body)).encode())],
            }
        )
        await send({"type": "http.response.body", "body": body})
