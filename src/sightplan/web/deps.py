"""What every route needs: the server's state, a database session, and lookups that answer 404."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Annotated, TypeVar

from fastapi import Depends, HTTPException, Request
from sqlalchemy.orm import Session

from .auth import at_least, role_of, user_for_secret
from .config import ServerConfig
from .db import Database
from .models import Base, Project, User
from .storage import Storage
from .worker import Worker

if TYPE_CHECKING:
    from .cluster import ServerCluster
    from .models import Model


@dataclass
class ServerState:
    config: ServerConfig
    db: Database
    storage: Storage
    worker: Worker
    cluster: ServerCluster | None = None


def get_state(request: Request) -> ServerState:
    return request.app.state.sightplan


def get_session(state: Annotated[ServerState, Depends(get_state)]) -> Iterator[Session]:
    with state.db.session() as s:
        yield s


StateDep = Annotated[ServerState, Depends(get_state)]
SessionDep = Annotated[Session, Depends(get_session)]

T = TypeVar("T", bound=Base)


def found(row: T | None, what: str, ident: int) -> T:
    if row is None:
        raise HTTPException(404, f"{what} {ident} not found")
    return row


def get_project(session: Session, project_id: int) -> Project:
    return found(session.get(Project, project_id), "project", project_id)


SESSION_COOKIE = "sightplan_session"
LOGIN_HINT = ("log in first: POST /api/auth/login with your user name and password, or send an API token as "
              "'Authorization: Bearer <token>'")


def current_user(request: Request, state: StateDep, session: SessionDep) -> User | None:
    """The logged-in user of a team server (from a bearer token or the session cookie), else 401. In single-user
    mode there are no accounts: None."""
    if not state.config.team:
        return None
    header = request.headers.get("authorization", "")
    secret = header[7:].strip() if header[:7].lower() == "bearer " else request.cookies.get(SESSION_COOKIE, "")
    user = user_for_secret(session, secret) if secret else None
    if user is None:
        raise HTTPException(401, LOGIN_HINT if not secret else "the session or token is unknown, revoked or expired: "
                                                                "log in again", headers={"WWW-Authenticate": "Bearer"})
    # The token's last use is written now: left pending, it would hold SQLite's write lock for as long as the request
    # runs, and a job's event stream runs until the job ends, which the worker could then never record.
    session.commit()
    return user


UserDep = Annotated[User | None, Depends(current_user)]


def require_user(user: UserDep) -> User:
    """Routes that only make sense with an account (tokens, memberships)."""
    if user is None:
        raise HTTPException(404, "there are no accounts in single-user mode (start the server with --team)")
    return user


def project_for(session: Session, project_id: int, user: User | None, needed: str) -> Project:
    """Project ``project_id`` if ``user`` holds at least the role ``needed`` in it. A project the user is not a
    member of answers 404 as one that does not exist; a member without the role gets 403."""
    project = get_project(session, project_id)
    if user is None:
        return project
    role = role_of(session, project_id, user.id)
    if role is None:
        raise HTTPException(404, f"project {project_id} not found")
    if not at_least(role, needed):
        raise HTTPException(403, f"you are a {role} of project {project_id}: this needs the {needed} role")
    return project


def readable_project(project_id: int, user: UserDep, session: SessionDep) -> Project:
    """The project of the route, if the caller may read it (any member, or anyone in single-user mode)."""
    return project_for(session, project_id, user, "viewer")


def editable_project(project_id: int, user: UserDep, session: SessionDep) -> Project:
    """The project of the route, if the caller may change it (editor or owner)."""
    return project_for(session, project_id, user, "editor")


def owned_project(project_id: int, user: UserDep, session: SessionDep) -> Project:
    """The project of the route, if the caller owns it."""
    return project_for(session, project_id, user, "owner")


def project_access(request: Request, project_id: int, user: UserDep, session: SessionDep) -> Project:
    """Router-wide check: reading (GET, HEAD) needs a viewer, anything else an editor."""
    return project_for(session, project_id, user, "viewer" if request.method in ("GET", "HEAD") else "editor")


ProjectRead = Annotated[Project, Depends(readable_project)]
ProjectEdit = Annotated[Project, Depends(editable_project)]
ProjectOwn = Annotated[Project, Depends(owned_project)]
PROJECT_ACCESS = [Depends(project_access)]


def ready_model(session: Session, project_id: int, model_id: int) -> Model:
    """The project's model ``model_id`` once it is tessellated; 409 before (with the loader's message if it failed)."""
    from .models import Model

    model = in_project(session, Model, model_id, project_id, "model")
    if model.status != "ready":
        raise HTTPException(409, f"model {model_id} is {model.status}, not ready" + (f": {model.error}" if model.error else ""))
    return model


def in_project(session: Session, cls: type[T], ident: int, project_id: int, what: str) -> T:
    """Row ``ident`` of ``cls`` that belongs to project ``project_id``, else 404."""
    get_project(session, project_id)
    row = session.get(cls, ident)
    if row is None or getattr(row, "project_id", None) != project_id:
        raise HTTPException(404, f"{what} {ident} not found in project {project_id}")
    return row
