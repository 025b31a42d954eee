"""The database tables (SQLAlchemy 2.0 ORM). Files live in the data folder under server-chosen names; rows hold
their relative paths and metadata only."""

from __future__ import annotations

import datetime as dt
from typing import Any

from sqlalchemy import JSON, DateTime, Float, ForeignKey, Integer, String, Text, UniqueConstraint
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, relationship


def utcnow() -> dt.datetime:
    return dt.datetime.now(dt.UTC)


class Base(DeclarativeBase):
    type_annotation_map = {dict[str, Any]: JSON, dt.datetime: DateTime(timezone=True)}


class Project(Base):
    __tablename__ = "projects"

    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(200))
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)

    models: Mapped[list[Model]] = relationship(back_populates="project", cascade="all, delete-orphan",
                                               passive_deletes=True, order_by="Model.id")
    plans: Mapped[list[Plan]] = relationship(back_populates="project", cascade="all, delete-orphan",
                                             passive_deletes=True, order_by="Plan.id")
    members: Mapped[list[Membership]] = relationship(back_populates="project", cascade="all, delete-orphan",
                                                     passive_deletes=True, order_by="Membership.id")


class Model(Base):
    """An uploaded IFC or mesh file. ``original_name`` is metadata only; the file is ``stored_name`` in the data
    folder's ``models/``."""

    __tablename__ = "models"

    id: Mapped[int] = mapped_column(primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), index=True)
    original_name: Mapped[str] = mapped_column(String(255))
    stored_name: Mapped[str] = mapped_column(String(64), unique=True)
    size_bytes: Mapped[int] = mapped_column(Integer)
    status: Mapped[str] = mapped_column(String(16), default="queued")  # queued, loading, ready, failed
    error: Mapped[str | None] = mapped_column(Text, default=None)
    elements: Mapped[int | None] = mapped_column(Integer, default=None)
    targets: Mapped[int | None] = mapped_column(Integer, default=None)
    triangles: Mapped[int | None] = mapped_column(Integer, default=None)
    skipped: Mapped[int | None] = mapped_column(Integer, default=None)
    load_report: Mapped[dict[str, Any] | None] = mapped_column(default=None)
    georeferenced: Mapped[bool | None] = mapped_column(default=None)
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)

    project: Mapped[Project] = relationship(back_populates="models")


class Plan(Base):
    """A capture plan: a sequence of versions, the latest the current one."""

    __tablename__ = "plans"

    id: Mapped[int] = mapped_column(primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), index=True)
    model_id: Mapped[int | None] = mapped_column(ForeignKey("models.id", ondelete="SET NULL"), default=None)
    name: Mapped[str] = mapped_column(String(200))
    source: Mapped[str] = mapped_column(String(255))  # "template facade", "upload mission.plan", ...
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)

    project: Mapped[Project] = relationship(back_populates="plans")
    versions: Mapped[list[PlanVersion]] = relationship(back_populates="plan", cascade="all, delete-orphan",
                                                       passive_deletes=True, order_by="PlanVersion.number")


class PlanVersion(Base):
    """One version of a plan: the sightplan plan JSON in the data folder's ``plans/``. Versions are never changed."""

    __tablename__ = "plan_versions"
    __table_args__ = (UniqueConstraint("plan_id", "number"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    plan_id: Mapped[int] = mapped_column(ForeignKey("plans.id", ondelete="CASCADE"), index=True)
    number: Mapped[int] = mapped_column(Integer)
    stored_name: Mapped[str] = mapped_column(String(64), unique=True)
    frames: Mapped[int] = mapped_column(Integer)
    missions: Mapped[int] = mapped_column(Integer)
    note: Mapped[str] = mapped_column(String(500), default="")
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)

    plan: Mapped[Plan] = relationship(back_populates="versions")


class Evaluation(Base):
    """A plan version evaluated against a model; results in the data folder's ``evaluations/<result_dir>/``."""

    __tablename__ = "evaluations"

    id: Mapped[int] = mapped_column(primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), index=True)
    plan_version_id: Mapped[int] = mapped_column(ForeignKey("plan_versions.id", ondelete="CASCADE"), index=True)
    model_id: Mapped[int] = mapped_column(ForeignKey("models.id", ondelete="CASCADE"), index=True)
    status: Mapped[str] = mapped_column(String(16), default="queued")  # queued, running, done, failed
    progress_done: Mapped[int] = mapped_column(Integer, default=0)
    progress_total: Mapped[int] = mapped_column(Integer, default=0)
    settings: Mapped[dict[str, Any]] = mapped_column()
    metrics: Mapped[dict[str, Any] | None] = mapped_column(default=None)
    result_dir: Mapped[str] = mapped_column(String(64), unique=True)
    error: Mapped[str | None] = mapped_column(Text, default=None)
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)
    started_at: Mapped[dt.datetime | None] = mapped_column(default=None)
    finished_at: Mapped[dt.datetime | None] = mapped_column(default=None)

    plan_version: Mapped[PlanVersion] = relationship()


class Job(Base):
    """Background work: loading a model or running an evaluation. Progress is written here as it goes."""

    __tablename__ = "jobs"

    id: Mapped[int] = mapped_column(primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), index=True)
    kind: Mapped[str] = mapped_column(String(16))  # load_model, evaluate, link_schedule, prep_reality, optimize
    model_id: Mapped[int | None] = mapped_column(ForeignKey("models.id", ondelete="CASCADE"), default=None)
    schedule_id: Mapped[int | None] = mapped_column(ForeignKey("schedules.id", ondelete="CASCADE"), default=None)
    reality_id: Mapped[int | None] = mapped_column(ForeignKey("reality.id", ondelete="CASCADE"), default=None)
    evaluation_id: Mapped[int | None] = mapped_column(ForeignKey("evaluations.id", ondelete="CASCADE"), default=None)
    plan_id: Mapped[int | None] = mapped_column(ForeignKey("plans.id", ondelete="SET NULL"), default=None)  # made by it
    params: Mapped[dict | None] = mapped_column(JSON, default=None)  # an optimisation's settings
    status: Mapped[str] = mapped_column(String(16), default="queued")  # queued, running, done, failed
    progress_done: Mapped[float] = mapped_column(Float, default=0.0)
    progress_total: Mapped[float] = mapped_column(Float, default=0.0)
    message: Mapped[str] = mapped_column(Text, default="")
    error: Mapped[str | None] = mapped_column(Text, default=None)
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)
    started_at: Mapped[dt.datetime | None] = mapped_column(default=None)
    finished_at: Mapped[dt.datetime | None] = mapped_column(default=None)


FINAL_STATES = ("done", "failed")
ROLES = ("viewer", "editor", "owner")  # each role can do what the ones before it can


class User(Base):
    """An account of a team server. Only an Argon2 hash of the password is stored."""

    __tablename__ = "users"

    id: Mapped[int] = mapped_column(primary_key=True)
    username: Mapped[str] = mapped_column(String(64), unique=True)
    password_hash: Mapped[str] = mapped_column(String(255))
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)


class Token(Base):
    """A login session (cookie, expires) or an API token (until revoked). Only a SHA-256 digest of the secret is
    stored; the secret is shown once."""

    __tablename__ = "tokens"

    id: Mapped[int] = mapped_column(primary_key=True)
    user_id: Mapped[int] = mapped_column(ForeignKey("users.id", ondelete="CASCADE"), index=True)
    kind: Mapped[str] = mapped_column(String(16))  # session, api
    name: Mapped[str] = mapped_column(String(200), default="")
    digest: Mapped[str] = mapped_column(String(64), unique=True)
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)
    expires_at: Mapped[dt.datetime | None] = mapped_column(default=None)
    last_used_at: Mapped[dt.datetime | None] = mapped_column(default=None)

    user: Mapped[User] = relationship()


class Membership(Base):
    """A user's role in a project: viewer (reads), editor (also uploads, plans, edits, evaluates, shares) or owner
    (also manages members, renames and deletes the project)."""

    __tablename__ = "memberships"
    __table_args__ = (UniqueConstraint("project_id", "user_id"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), index=True)
    user_id: Mapped[int] = mapped_column(ForeignKey("users.id", ondelete="CASCADE"), index=True)
    role: Mapped[str] = mapped_column(String(16))
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)

    project: Mapped[Project] = relationship(back_populates="members")
    user: Mapped[User] = relationship()


class Schedule(Base):
    """A construction schedule linked to one of the project's models (in the worker): the element dates are kept in
    the data folder's ``schedules/<dates_name>`` (start and finish per element), the link report here."""

    __tablename__ = "schedules"

    id: Mapped[int] = mapped_column(primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), index=True)
    model_id: Mapped[int] = mapped_column(ForeignKey("models.id", ondelete="CASCADE"), index=True)
    original_name: Mapped[str] = mapped_column(String(255))
    stored_name: Mapped[str | None] = mapped_column(String(64), default=None)  # None: the model's own IfcWorkSchedule
    rules_name: Mapped[str | None] = mapped_column(String(64), default=None)
    prefer_actual: Mapped[bool] = mapped_column(default=False)
    dates_name: Mapped[str] = mapped_column(String(64), unique=True)
    status: Mapped[str] = mapped_column(String(16), default="queued")  # queued, linking, ready, failed
    error: Mapped[str | None] = mapped_column(Text, default=None)
    report: Mapped[dict[str, Any] | None] = mapped_column(default=None)
    first_date: Mapped[str | None] = mapped_column(String(10), default=None)
    last_date: Mapped[str | None] = mapped_column(String(10), default=None)
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)


class Reality(Base):
    """A reality capture of the site (a point cloud or a reconstructed mesh) in the model's frame, prepared in the
    worker for the viewer: a point cloud as a 3D Tiles octree in ``reality/<view_name>/``, a mesh as one GLB
    ``reality/<view_name>.glb``. Evaluations may take it as occluders (the site as it stands)."""

    __tablename__ = "reality"

    id: Mapped[int] = mapped_column(primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), index=True)
    original_name: Mapped[str] = mapped_column(String(255))
    stored_name: Mapped[str] = mapped_column(String(64), unique=True)
    view_name: Mapped[str] = mapped_column(String(64), unique=True)
    kind: Mapped[str] = mapped_column(String(16))  # points, mesh
    size_bytes: Mapped[int] = mapped_column(Integer)
    status: Mapped[str] = mapped_column(String(16), default="queued")  # queued, preparing, ready, failed
    error: Mapped[str | None] = mapped_column(Text, default=None)
    points: Mapped[int | None] = mapped_column(Integer, default=None)
    triangles: Mapped[int | None] = mapped_column(Integer, default=None)
    bounds: Mapped[dict[str, Any] | None] = mapped_column(default=None)  # {"lo": [x, y, z], "hi": [x, y, z]}
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)


class ShareLink(Base):
    """A read-only link to one plan (its versions, exports and evaluations), valid until revoked."""

    __tablename__ = "share_links"

    id: Mapped[int] = mapped_column(primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), index=True)
    plan_id: Mapped[int] = mapped_column(ForeignKey("plans.id", ondelete="CASCADE"), index=True)
    digest: Mapped[str] = mapped_column(String(64), unique=True)
    created_by: Mapped[int | None] = mapped_column(ForeignKey("users.id", ondelete="SET NULL"), default=None)
    created_at: Mapped[dt.datetime] = mapped_column(default=utcnow)
    revoked_at: Mapped[dt.datetime | None] = mapped_column(default=None)
