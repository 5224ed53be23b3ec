"""Sign-in, sign-out, who am I, and the accounts (admin): ``/login``, ``/logout``, ``/me``, ``/users``.

Failed sign-ins are throttled (per user name and per client address) and audited with the name tried.
"""

from __future__ import annotations

from fastapi import APIRouter, Depends, HTTPException, Request, Response
from gaitcap.api.auth import client_ip, principal_of, require_user
from gaitcap.api.sessions import COOKIE
from gaitcap.services.access.accounts import ROLES, check_user_name
from pydantic import BaseModel, Field

router = APIRouter(tags=["accounts"])


class LoginIn(BaseModel):
    user: str = Field(min_length=1, max_length=64)
    password: str = Field(min_length=1, max_length=256)


class UserIn(BaseModel):
    name: str = Field(min_length=1, max_length=64)
    password: str = Field(min_length=12, max_length=256)
    roles: list[str] = Field(min_length=1, max_length=len(ROLES))


def _me(principal) -> dict:
    return {"user": principal.user, "roles": list(principal.roles), "permissions": sorted(principal.permissions)}


@router.post("/login", summary="Sign in (user + password); sets the session cookie")
def login(body: LoginIn, request: Request, response: Response) -> dict:
    state, ip = request.app.state, client_ip(request)
    name = body.user.strip().lower()
    limits = state.login_limiters
    keys = {"user": name, "ip": ip}
    if any(limits[kind].blocked(key) for kind, key in keys.items()):
        state.audit_chain.record(actor="-", action="login throttled", detail=f"user {name[:64]!r}", ip=ip)
        raise HTTPException(status_code=429, detail="too many failed sign-ins; wait a few minutes",
                            headers={"Retry-After": str(int(limits["user"].window_s))})
    account = state.accounts.verify(name, body.password)
    if account is None:
        for kind, key in keys.items():
            limits[kind].hit(key)
        state.audit_chain.record(actor="-", action="login failed", detail=f"user {name[:64]!r}", ip=ip)
        raise HTTPException(status_code=401, detail="wrong user name or password")
    limits["user"].clear(name)
    sid = state.sessions.create(account.name, account.roles, account.permissions)
    settings = state.settings
    response.set_cookie(COOKIE, sid, httponly=True, secure=settings.tls_enabled, samesite="strict", path="/",
                        max_age=int(settings.session_max_s))
    state.audit_chain.record(actor=account.name, action="login", ip=ip)
    return {"user": account.name, "roles": list(account.roles), "permissions": sorted(account.permissions)}


@router.post("/logout", summary="Sign out (ends the session)")
def logout(request: Request, response: Response) -> dict:
    principal = principal_of(request)
    request.app.state.sessions.end(request.cookies.get(COOKIE))
    response.delete_cookie(COOKIE, path="/")
    if principal is not None:
        request.app.state.audit_chain.record(actor=principal.user, action="logout", ip=client_ip(request))
    return {"signed_out": True}


@router.get("/me", summary="The signed-in user and their roles (401 when not signed in)")
def me(request: Request) -> dict:
    principal = principal_of(request)
    if principal is None:
        raise HTTPException(status_code=401, detail="not signed in")
    return _me(principal)


@router.get("/users", summary="Accounts and their roles (admin)")
def users(request: Request, user: str = Depends(require_user)) -> list[dict]:
    return [{"name": a.name, "roles": list(a.roles)} for a in request.app.state.accounts.list()]


@router.post("/users", status_code=201, summary="Create or replace an account (admin)")
def add_user(body: UserIn, request: Request, user: str = Depends(require_user)) -> dict:
    try:
        account = request.app.state.accounts.set(check_user_name(body.name), password=body.password, roles=body.roles)
    except ValueError as exc:
        raise HTTPException(status_code=422, detail=str(exc)) from None
    request.app.state.sessions.end_user(account.name)
    request.app.state.audit_chain.record(actor=user, action="user set", target=account.name,
                                         detail=",".join(account.roles), ip=client_ip(request))
    return {"name": account.name, "roles": list(account.roles)}


@router.delete("/users/{name}", summary="Remove an account (admin); its sessions end")
def remove_user(name: str, request: Request, user: str = Depends(require_user)) -> dict:
    if not request.app.state.accounts.remove(name):
        raise HTTPException(status_code=404, detail=f"user {name[:64]!r} does not exist")
    request.app.state.sessions.end_user(name)
    request.app.state.audit_chain.record(actor=user, action="user removed", target=name, ip=client_ip(request))
    return {"removed": name}
