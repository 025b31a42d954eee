"""``/api/projects/{project_id}/members`` and ``.../links``: who may read or change a project (team mode), and
read-only share links to a plan that can be revoked."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Request, Response
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from ..auth import digest, find_user, new_secret
from ..deps import ProjectEdit, ProjectOwn, ProjectRead, SessionDep, User, UserDep, in_project, require_user
from ..models import Membership, Plan, ShareLink, utcnow
from ..schemas import ErrorOut, MemberIn, MemberOut, NewShareLinkOut, RoleIn, ShareLinkOut

router = APIRouter(prefix="/api/projects/{project_id}", tags=["members and sharing"])
NOT_FOUND = {404: {"model": ErrorOut, "description": "No such project (or not yours), member, plan or link"}}
FORBIDDEN = {403: {"model": ErrorOut, "description": "Your role does not allow it"}}


def _member_out(m: Membership) -> MemberOut:
    return MemberOut(user_id=m.user_id, username=m.user.username, role=m.role)  # type: ignore[arg-type]


def _membership(session: Session, project_id: int, user_id: int) -> Membership:
    m = session.scalars(select(Membership).where(Membership.project_id == project_id,
                                                 Membership.user_id == user_id)).first()
    if m is None:
        raise HTTPException(404, f"user {user_id} is not a member of project {project_id}")
    return m


def _keep_an_owner(session: Session, m: Membership, new_role: str | None) -> None:
    if m.role == "owner" and new_role != "owner":
        owners = session.scalar(select(func.count()).select_from(Membership).where(
            Membership.project_id == m.project_id, Membership.role == "owner"))
        if owners == 1:
            raise HTTPException(409, f"{m.user.username} is the project's only owner: make someone else owner first")


@router.get("/members", response_model=list[MemberOut], summary="The project's members and their roles",
            responses=NOT_FOUND)
def list_members(project: ProjectRead) -> list[MemberOut]:
    return [_member_out(m) for m in project.members]


@router.post("/members", response_model=MemberOut, status_code=201, summary="Add a member (owner only)",
             responses={**NOT_FOUND, **FORBIDDEN, 409: {"model": ErrorOut, "description": "Already a member"}})
def add_member(project: ProjectOwn, body: MemberIn, user: UserDep, session: SessionDep) -> MemberOut:
    require_user(user)
    other = find_user(session, body.username)
    if other is None:
        raise HTTPException(404, f"no user {body.username!r} (accounts are made with 'sightplan users add')")
    if any(m.user_id == other.id for m in project.members):
        raise HTTPException(409, f"{other.username} is a member of project {project.id} already: change the role")
    m = Membership(project_id=project.id, user_id=other.id, role=body.role)
    session.add(m)
    session.commit()
    return _member_out(m)


@router.patch("/members/{user_id}", response_model=MemberOut, summary="Change a member's role (owner only)",
              responses={**NOT_FOUND, **FORBIDDEN, 409: {"model": ErrorOut, "description": "The last owner"}})
def change_role(project: ProjectOwn, user_id: int, body: RoleIn, session: SessionDep) -> MemberOut:
    m = _membership(session, project.id, user_id)
    _keep_an_owner(session, m, body.role)
    m.role = body.role
    session.commit()
    return _member_out(m)


@router.delete("/members/{user_id}", status_code=204, response_class=Response,
               summary="Remove a member (owner), or leave the project yourself",
               responses={**NOT_FOUND, **FORBIDDEN, 409: {"model": ErrorOut, "description": "The last owner"}})
def remove_member(project: ProjectRead, user_id: int, user: UserDep, session: SessionDep) -> Response:
    me: User = require_user(user)
    if user_id != me.id and _membership(session, project.id, me.id).role != "owner":
        raise HTTPException(403, f"only an owner of project {project.id} can remove other members")
    m = _membership(session, project.id, user_id)
    _keep_an_owner(session, m, None)
    session.delete(m)
    session.commit()
    return Response(status_code=204)


@router.post("/plans/{plan_id}/links", response_model=NewShareLinkOut, status_code=201,
             summary="Share a plan read-only by a link (editor or owner)",
             description="Anyone with the link can see the plan's versions, its finished evaluations and reports, "
                         "and download its exports, without an account, until the link is revoked.",
             responses={**NOT_FOUND, **FORBIDDEN})
def create_link(project: ProjectEdit, plan_id: int, request: Request, user: UserDep, session: SessionDep
                ) -> NewShareLinkOut:
    in_project(session, Plan, plan_id, project.id, "plan")
    secret = new_secret("spl")
    link = ShareLink(project_id=project.id, plan_id=plan_id, digest=digest(secret),
                     created_by=user.id if user is not None else None)
    session.add(link)
    session.commit()
    base = str(request.base_url).rstrip("/")
    return NewShareLinkOut(id=link.id, plan_id=plan_id, created_at=link.created_at, revoked_at=None, token=secret,
                           url=f"{base}/shared/{secret}", api_url=f"{base}/api/shared/{secret}")


@router.get("/links", response_model=list[ShareLinkOut], summary="The project's share links (editor or owner)",
            responses={**NOT_FOUND, **FORBIDDEN})
def list_links(project: ProjectEdit, session: SessionDep) -> list[ShareLink]:
    return list(session.scalars(select(ShareLink).where(ShareLink.project_id == project.id).order_by(ShareLink.id)))


@router.delete("/links/{link_id}", status_code=204, response_class=Response,
               summary="Revoke a share link (editor or owner): it stops working at once",
               responses={**NOT_FOUND, **FORBIDDEN})
def revoke_link(project: ProjectEdit, link_id: int, session: SessionDep) -> Response:
    link = in_project(session, ShareLink, link_id, project.id, "share link")
    if link.revoked_at is None:
        link.revoked_at = utcnow()
        session.commit()
    return Response(status_code=204)
