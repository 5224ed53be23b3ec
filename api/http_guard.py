"""The web service's outer guard (an ASGI middleware), before any route or body parsing:

1. a request body larger than ``max_body_bytes`` is refused (413) from its Content-Length, or as soon
   as a streamed body passes the limit;
2. a request to a non-public route without a valid session or token is refused (401) before its body
   is read, so nothing unauthenticated is ever parsed; wrong API tokens are audited and count as failed
   sign-ins of the client address (429 past the limit);
3. expensive routes (files, plots, streams) are rate limited per user (429);
4. a JSON body with NaN or Infinity is refused (422) before it reaches the routes;
5. every response carries the security headers (CSP without inline script, frame-ancestors none,
   no-referrer, nosniff; HSTS on HTTPS).
"""

from __future__ import annotations

import json
import re

from gaitcap.api.auth import is_public, principal_of
from starlette.requests import Request

EXPENSIVE = re.compile(r"^/trials/[^/]+/(recording|rerun\.rrd|trajectory|report\.png|steps)$|^/cameras/[^/]+/preview\.mjpg$")
CSP = ("default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' blob: data:; "
       "connect-src 'self'; object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'")


def security_headers(*, tls: bool) -> list[tuple[bytes, bytes]]:
    headers = [(b"content-security-policy", CSP.encode()), (b"x-frame-options", b"DENY"),
               (b"referrer-policy", b"no-referrer"), (b"x-content-type-options", b"nosniff"),
               (b"cache-control", b"no-store")]
    if tls:
        headers.append((b"strict-transport-security", b"max-age=31536000; includeSubDomains"))
    return headers


async def _reply(send, status: int, detail: str, extra: list[tuple[bytes, bytes]]) -> None:
    body = json.dumps({"detail": detail}).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
                            *extra]})
    await send({"type": "http.response.body", "body": body})


def _reject_constant(value: str) -> None:
    raise ValueError(f"{value} is not a number JSON allows")


class HttpGuard:
    def __init__(self, app, *, max_body_bytes: int, tls: bool, expensive_limiter) -> None:
        self.app, self.max_body_bytes, self.tls = app, max_body_bytes, tls
        self.limiter = expensive_limiter
        self.headers = security_headers(tls=tls)

    async def __call__(self, scope, receive, send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def send_with_headers(message) -> None:
            if message["type"] == "http.response.start":
                message = dict(message, headers=[*message.get("headers", []), *self.headers])
            await send(message)

        problem = self._check(scope)
        if problem is not None:
            await _reply(send, *problem, self.headers)
            return
        body, problem = await self._read_body(scope, receive)
        if problem is not None:
            await _reply(send, *problem, self.headers)
            return
        await self.app(scope, _replay(body, receive), send_with_headers)

    def _check(self, scope) -> tuple[int, str] | None:
        headers = dict(scope.get("headers", []))
        length = headers.get(b"content-length")
        if length is not None and (not length.isdigit() or int(length) > self.max_body_bytes):
            return 413, f"request body larger than {self.max_body_bytes} bytes"
        path = scope.get("path", "")
        if is_public(path):
            return None
        request = Request(scope)
        principal = principal_of(request)
        if principal is None:
            return self._refuse_unknown(request)
        if EXPENSIVE.match(path) and self.limiter.hit(principal.user):
            return 429, "too many requests for files and plots; wait a minute"
        return None

    @staticmethod
    def _refuse_unknown(request: Request) -> tuple[int, str]:
        """401; a wrong API token also counts as a failed sign-in of the client address (429 past the limit)."""
        if not request.headers.get("authorization"):
            return 401, "not signed in"
        state, ip = request.app.state, request.client.host if request.client else ""
        limiter = state.login_limiters["ip"]
        if limiter.hit(ip):
            return 429, "too many failed sign-ins; wait a few minutes"
        state.audit_chain.record(actor="-", action="token failed", target=request.url.path, ip=ip)
        return 401, "not signed in"

    async def _read_body(self, scope, receive) -> tuple[bytes | None, tuple[int, str] | None]:
        if scope.get("method") in ("GET", "HEAD", "OPTIONS", "DELETE"):
            return None, None
        chunks, size = [], 0
        while True:
            message = await receive()
            if message["type"] == "http.disconnect":
                return b"".join(chunks), None
            chunk = message.get("body", b"")
            size += len(chunk)
            if size > self.max_body_bytes:
                return None, (413, f"request body larger than {self.max_body_bytes} bytes")
            chunks.append(chunk)
            if not message.get("more_body", False):
                break
        body = b"".join(chunks)
        content_type = dict(scope.get("headers", [])).get(b"content-type", b"")
        if body and b"json" in content_type:
            try:
                json.loads(body, parse_constant=_reject_constant)
            except ValueError as exc:
                text = str(exc)
                if "JSON allows" in text:
                    return None, (422, f"body: {text[:80]}")
        return body, None


def _replay(body: bytes | None, receive):
    if body is None:
        return receive
    sent = False

    async def replay():
        nonlocal sent
        if not sent:
            sent = True
            return {"type": "http.request", "body": body, "more_body": False}
        return await receive()

    return replay
