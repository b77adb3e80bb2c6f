"""The headers every answer of ``lamech serve`` carries, as an ASGI middleware.

- ``Referrer-Policy: no-referrer``: the page's address holds its token until the page
  has loaded; no request it makes names it (:data:`lamech.present._policy.REFERRER`).
- ``Content-Security-Policy``: the page's own (its nonce, :func:`served_policy
  <lamech.present._policy.served_policy>`) is set by the route that answers with the
  page; every other answer (JSON, text, a refusal) gets :data:`DEFAULT_POLICY`, which
  lets it run and load nothing, were a browser to show it.
- ``X-Content-Type-Options: nosniff``: an answer is read as the type it says.
"""

from __future__ import annotations

from ..present._policy import REFERRER

__all__ = ["PageHeaders", "DEFAULT_POLICY"]

DEFAULT_POLICY = "default-src 'none'; frame-ancestors 'none'; base-uri 'none'; form-action 'none'"


class PageHeaders:
    """ASGI middleware: adds the headers above to each ``http.response.start`` of
    ``app``, keeping a Content-Security-Policy the route set."""

    def __init__(self, app) -> None:
        self.app = app

    async def __call__(self, scope, receive, send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def with_headers(message) -> None:
            if message["type"] == "http.response.start":
                headers = list(message.get("headers", []))
                names = {k.lower() for k, _ in headers}
                if b"content-security-policy" not in names:
                    headers.append((b"content-security-policy", DEFAULT_POLICY.encode()))
                headers.append((b"referrer-policy", REFERRER.encode()))
                headers.append((b"x-content-type-options", b"nosniff"))
                message = {**message, "headers": headers}
            await send(message)

        await self.app(scope, receive, with_headers)
