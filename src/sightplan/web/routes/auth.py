"""``/api/auth``: log in and out (a session cookie), who am I, password change, API tokens for scripts (team mode)."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Request, Response
from sqlalchemy import select

from ..auth import AccountError, authenticate, issue_token, set_password
from ..auth import digest as secret_digest
from ..deps import SESSION_COOKIE, SessionDep, StateDep, User, UserDep, require_user
from ..models import Membership, Token
from ..schemas import ErrorOut, LoginIn, NewTokenOut, PasswordIn, TokenIn, TokenOut, UserOut

router = APIRouter(prefix="/api/auth", tags=["accounts"])
# 401 (not logged in) is documented on every route that needs a login: sightplan.web.openapi


def user_out(session, user: User) -> UserOut:
    rows = session.execute(select(Membership.project_id, Membership.role).where(Membership.user_id == user.id))
    return UserOut(username=user.username, projects={pid: role for pid, role in rows})


@router.post("/login", response_model=UserOut, summary="Log in: sets the session cookie (14 days)",
             responses={401: {"model": ErrorOut, "description": "A wrong user name or password"},
                        404: {"model": ErrorOut, "description": "Single-user mode has no accounts"}})
def login(body: LoginIn, request: Request, response: Response, session: SessionDep, state: StateDep) -> UserOut:
    if not state.config.team:
        raise HTTPException(404, "there are no accounts in single-user mode (start the server with --team)")
    user = authenticate(session, body.username, body.password)
    if user is None:
        raise HTTPException(401, "wrong user name or password")
    token, secret = issue_token(session, user, "session")
    session.commit()
    response.set_cookie(SESSION_COOKIE, secret, max_age=int((token.expires_at - token.created_at).total_seconds()),
                        **cookie_attributes(request))
    return user_out(session, user)


def cookie_attributes(request: Request) -> dict:
    """The session cookie's attributes, the same when it is set and when it is deleted."""
    return {"httponly": True, "samesite": "strict", "secure": request.url.scheme == "https", "path": "/"}


@router.post("/logout", status_code=204, response_class=Response, summary="Log out: ends this session")
def logout(request: Request, session: SessionDep) -> Response:
    secret = request.cookies.get(SESSION_COOKIE)
    if secret:
        token = session.scalars(select(Token).where(Token.digest == secret_digest(secret))).first()
        if token is not None:
            session.delete(token)
            session.commit()
    response = Response(status_code=204)
    response.delete_cookie(SESSION_COOKIE, **cookie_attributes(request))
    return response


@router.get("/me", response_model=UserOut, summary="The logged-in user and their projects")
def me(user: UserDep, session: SessionDep) -> UserOut:
    return user_out(session, require_user(user))


@router.post("/password", status_code=204, response_class=Response, summary="Change your password",
             description="Ends your login sessions (API tokens stay).",
             responses={403: {"model": ErrorOut, "description": "The current password is wrong"},
                        422: {"model": ErrorOut, "description": "The new password is too short"}})
def change_password(body: PasswordIn, request: Request, user: UserDep, session: SessionDep) -> Response:
    user = require_user(user)
    if authenticate(session, user.username, body.old_password) is None:
        raise HTTPException(403, "the current password is wrong")  # 403, not 401: the session itself is fine
    try:
        set_password(session, user, body.new_password)
    except AccountError as exc:
        raise HTTPException(422, str(exc)) from None
    session.commit()
    response = Response(status_code=204)
    response.delete_cookie(SESSION_COOKIE, **cookie_attributes(request))
    return response


@router.post("/tokens", response_model=NewTokenOut, status_code=201, summary="Create an API token for scripts")
def create_token(body: TokenIn, user: UserDep, session: SessionDep) -> NewTokenOut:
    token, secret = issue_token(session, require_user(user), "api", body.name)
    session.commit()
    return NewTokenOut(id=token.id, name=token.name, created_at=token.created_at, last_used_at=None, token=secret)


@router.get("/tokens", response_model=list[TokenOut], summary="Your API tokens (without their secrets)")
def list_tokens(user: UserDep, session: SessionDep) -> list[Token]:
    user = require_user(user)
    return list(session.scalars(select(Token).where(Token.user_id == user.id, Token.kind == "api").order_by(Token.id)))


@router.delete("/tokens/{token_id}", status_code=204, response_class=Response, summary="Revoke an API token",
               responses={404: {"model": ErrorOut, "description": "No such token of yours"}})
def revoke_token(token_id: int, user: UserDep, session: SessionDep) -> Response:
    user = require_user(user)
    token = session.get(Token, token_id)
    if token is None or token.user_id != user.id or token.kind != "api":
        raise HTTPException(404, f"you have no API token {token_id}")
    session.delete(token)
    session.commit()
    return Response(status_code=204)

