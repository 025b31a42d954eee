"""What every route needs: the server's state, a database session, and lookups that answer 404."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Annotated, TypeVar

from fastapi import Depends, HTTPException, Request
from sqlalchemy.orm import Session

from .config import ServerConfig
from .db import Database
from .models import Base, Project
from .storage import Storage
from .worker import Worker


@dataclass
class ServerState:
    config: ServerConfig
    db: Database
    storage: Storage
    worker: Worker


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


def in_project(session: Session, cls: type[T], ident: int, project_id: int, what: str) -> T:
    """Row ``ident`` of ``cls`` that belongs to project ``project_id``, else 404."""
    get_project(session, project_id)
    row = session.get(cls, ident)
    if row is None or getattr(row, "project_id", None) != project_id:
        raise HTTPException(404, f"{what} {ident} not found in project {project_id}")
    return row
