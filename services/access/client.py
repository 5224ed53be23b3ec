"""Signing an HTTP client in to the web service (scripts, the demo stack, benchmarks, tests)."""

from __future__ import annotations

import httpx

DEMO_USER = "demo"
DEMO_ROLES = ("admin", "clinician", "engineer", "researcher")


def sign_in(client: httpx.Client, user: str, password: str) -> httpx.Client:
    """``POST /login``; the client then carries the session cookie. Raises naming the status on refusal."""
    res = client.post("/login", json={"user": user, "password": password})
    if res.status_code != 200:
        raise ValueError(f"sign-in as {user} refused: {res.status_code} {res.text[:200]}")
    return client
