"""The Content-Security-Policy of lamech's two pages: defence in depth behind the escaping.

Every text of a problem file reaches the pages escaped (HTML by :func:`html.escape`, TeX
by :mod:`._plain`); the policies say what the browser may run even if some day it were
not. Neither page needs the network:

- the report file (``lamech report``, :func:`report_policy`) runs exactly its own
  inline scripts and styles, allowed by their SHA-256 hashes, and loads nothing but
  its embedded images and fonts (``data:``); everything else is ``'none'``. A file has
  no headers: the policy is a ``<meta http-equiv>`` at the top of its ``<head>``.
- the served page (``lamech serve``, :func:`served_policy`) runs the scripts and
  styles that carry the nonce drawn for that answer, talks to its own server only
  (``connect-src 'self'``), and may not be framed. The report it shows in its
  ``srcdoc`` frame inherits this policy, so the server writes that report's scripts
  and styles with the same nonce (the page sends it with its request).

Both pages send no ``Referer`` (:data:`REFERRER`): the served page's address holds its
token until the page removes it.
"""

from __future__ import annotations

import base64
import hashlib
import html
import re

__all__ = [
    "REFERRER",
    "source_hash",
    "report_policy",
    "served_policy",
    "tagged",
    "valid_nonce",
]

REFERRER = "no-referrer"
"""The ``Referrer-Policy`` of both pages."""
IMAGE_STYLE = "max-width:100%"
"""The one style attribute a served page shows (a sweep's plot, :func:`._notebook._png`),
allowed by its hash."""
_NONCE = re.compile(r"[A-Za-z0-9_-]{16,64}")


def source_hash(text: str) -> str:
    """The CSP source that allows the inline script or style ``text``:
    ``'sha256-<base64>'`` of its UTF-8 bytes, exactly as written between the tags."""
    digest = hashlib.sha256(text.encode("utf-8")).digest()
    return f"'sha256-{base64.b64encode(digest).decode('ascii')}'"


def report_policy(scripts: list[str], styles: list[str]) -> str:
    """The report file's policy: its ``scripts`` and ``styles`` (their texts) by hash,
    images and fonts from ``data:`` URIs, and nothing else (no request leaves it)."""
    return "; ".join(
        [
            "default-src 'none'",
            "script-src " + " ".join(source_hash(s) for s in scripts),
            "style-src " + " ".join(source_hash(s) for s in styles),
            "img-src data:",
            "font-src data:",
            "base-uri 'none'",
            "form-action 'none'",
        ]
    )


def served_policy(nonce: str) -> str:
    """The served page's policy for one answer: scripts and styles with ``nonce``, the
    sweep plot's one style attribute by hash, requests to its own server only, images
    and fonts from ``data:`` URIs, never framed."""
    return "; ".join(
        [
            "default-src 'none'",
            f"script-src 'nonce-{nonce}'",
            f"style-src 'nonce-{nonce}' 'unsafe-hashes' {source_hash(IMAGE_STYLE)}",
            "connect-src 'self'",
            "img-src data:",
            "font-src data:",
            "base-uri 'none'",
            "form-action 'none'",
            "frame-ancestors 'none'",
        ]
    )


def valid_nonce(nonce: object) -> bool:
    """Whether ``nonce`` has the form the server draws (16 to 64 URL-safe characters)."""
    return isinstance(nonce, str) and _NONCE.fullmatch(nonce) is not None


def tagged(tag: str, text: str, nonce: str | None = None) -> str:
    """``<tag>text</tag>``, with ``nonce="..."`` when given (a report in the served
    page's frame)."""
    attr = f' nonce="{html.escape(nonce)}"' if nonce else ""
    return f"<{tag}{attr}>{text}</{tag}>"
