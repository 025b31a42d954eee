"""``/api/projects/{project_id}/reality``: captures of the site as it stands (point clouds, reconstructed meshes) in
the model's frame, shown beside the BIM (a point cloud streamed as 3D Tiles with level of detail) and usable as
occluders in evaluations."""

from __future__ import annotations

import re
from typing import Annotated, Literal

from fastapi import APIRouter, File, HTTPException, Response, UploadFile
from fastapi.responses import FileResponse
from pydantic import BaseModel, Field
from sqlalchemy import select

from ..deps import PROJECT_ACCESS, ProjectEdit, SessionDep, StateDep, in_project
from ..models import Job, Reality
from ..scenes import evaluations_using
from ..schemas import ErrorOut, JobOut, Time
from ..services import REALITY_KEY
from ..storage import display_name
from ..uploads import queue_upload, receive_upload

router = APIRouter(prefix="/api/projects/{project_id}/reality", tags=["reality"], dependencies=PROJECT_ACCESS)
NOT_FOUND = {404: {"model": ErrorOut, "description": "No such project, capture or tile"}}
NOT_READY = {409: {"model": ErrorOut, "description": "The capture is not prepared (yet)"}}
REALITY_SUFFIXES = (".las", ".laz", ".ply", ".obj", ".stl", ".gltf", ".glb")
TILE_NAME = re.compile(r"^[A-Za-z0-9_-]{1,64}\.glb$")


class RealityOut(BaseModel):
    id: int
    project_id: int
    name: str
    kind: Literal["points", "mesh"]
    size_bytes: int
    status: Literal["queued", "preparing", "ready", "failed"]
    error: str | None
    points: int | None
    triangles: int | None
    bounds: dict | None = Field(description='{"lo": [x, y, z], "hi": [x, y, z]} in the model frame (m)')
    view_url: str | None = Field(description="tileset.json of a point cloud, or the GLB of a mesh (glTF's Y up: "
                                             "model (x, y, z) is (x, z, −y))")
    created_at: Time


class RealityUploadOut(BaseModel):
    reality: RealityOut
    job: JobOut


def reality_out(row: Reality) -> RealityOut:
    base = f"/api/projects/{row.project_id}/reality/{row.id}"
    url = (f"{base}/tileset.json" if row.kind == "points" else f"{base}/mesh.glb") if row.status == "ready" else None
    return RealityOut(id=row.id, project_id=row.project_id, name=row.original_name, kind=row.kind,  # type: ignore[arg-type]
                      size_bytes=row.size_bytes, status=row.status, error=row.error, points=row.points,  # type: ignore[arg-type]
                      triangles=row.triangles, bounds=row.bounds, view_url=url, created_at=row.created_at)


@router.post("", response_model=RealityUploadOut, status_code=202,
             summary="Upload a point cloud (LAS, LAZ, PLY) or a reconstructed mesh (OBJ, PLY, STL, glTF) of the site",
             description="In the model's frame (metres). Prepared in the background: a point cloud becomes an octree "
                         "of 3D Tiles, a mesh one GLB; follow the job.",
             responses={**NOT_FOUND, 400: {"model": ErrorOut, "description": "Empty file"},
                        413: {"model": ErrorOut, "description": "Over the upload limit"},
                        415: {"model": ErrorOut, "description": "Not a point cloud or mesh"}})
async def upload_reality(project: ProjectEdit, state: StateDep, session: SessionDep,
                         file: Annotated[UploadFile, File(description="The capture")]) -> RealityUploadOut:
    from ...model.pointcloud import is_point_cloud

    tmp, size = await receive_upload(state, file, REALITY_SUFFIXES, "point cloud or mesh")
    stored = state.storage.new_name(tmp.suffix)

    def rows() -> tuple[Reality, Job]:
        row = Reality(project_id=project.id, original_name=display_name(file.filename or ""), stored_name=stored,
                      view_name=state.storage.new_name(), kind="points" if is_point_cloud(tmp) else "mesh",
                      size_bytes=size)
        session.add(row)
        session.flush()
        job = Job(project_id=project.id, kind="prep_reality", reality_id=row.id, message="queued")
        session.add(job)
        return row, job

    row, job = queue_upload(state, session, [(tmp, state.storage.reality_path(stored))], rows)
    return RealityUploadOut(reality=reality_out(row), job=JobOut.model_validate(job))


@router.get("", response_model=list[RealityOut], summary="The project's reality captures", responses=NOT_FOUND)
def list_reality(project_id: int, session: SessionDep) -> list[RealityOut]:
    rows = session.scalars(select(Reality).where(Reality.project_id == project_id).order_by(Reality.id))
    return [reality_out(r) for r in rows]


@router.get("/{reality_id}", response_model=RealityOut, summary="A reality capture", responses=NOT_FOUND)
def read_reality(project_id: int, reality_id: int, session: SessionDep) -> RealityOut:
    return reality_out(in_project(session, Reality, reality_id, project_id, "reality capture"))


def _ready(session, project_id: int, reality_id: int, kind: str) -> Reality:
    row = in_project(session, Reality, reality_id, project_id, "reality capture")
    if row.status != "ready":
        raise HTTPException(409, f"reality capture {reality_id} is {row.status}" + (f": {row.error}" if row.error else ""))
    if row.kind != kind:
        raise HTTPException(404, f"reality capture {reality_id} is a {row.kind}, not a {kind} capture")
    return row


@router.get("/{reality_id}/tileset.json", response_class=FileResponse, summary="A point cloud's 3D Tiles tileset",
            responses={**NOT_FOUND, **NOT_READY})
def read_tileset(project_id: int, reality_id: int, session: SessionDep, state: StateDep) -> FileResponse:
    row = _ready(session, project_id, reality_id, "points")
    return FileResponse(state.storage.reality_path(row.view_name) / "tileset.json", media_type="application/json")


@router.get("/{reality_id}/tiles/{name}", response_class=FileResponse, summary="One tile of a point cloud (GLB)",
            responses={**NOT_FOUND, **NOT_READY})
def read_tile(project_id: int, reality_id: int, name: str, session: SessionDep, state: StateDep) -> FileResponse:
    row = _ready(session, project_id, reality_id, "points")
    path = state.storage.reality_path(row.view_name) / "tiles" / name
    if not TILE_NAME.match(name) or not path.is_file():
        raise HTTPException(404, f"no tile {name!r} in reality capture {reality_id}")
    return FileResponse(path, media_type="model/gltf-binary", headers={"Cache-Control": "private, max-age=86400"})


@router.get("/{reality_id}/mesh.glb", response_class=FileResponse, summary="A reconstructed mesh as GLB",
            responses={**NOT_FOUND, **NOT_READY})
def read_mesh(project_id: int, reality_id: int, session: SessionDep, state: StateDep) -> FileResponse:
    row = _ready(session, project_id, reality_id, "mesh")
    return FileResponse(state.storage.reality_path(row.view_name + ".glb"), media_type="model/gltf-binary")


@router.delete("/{reality_id}", status_code=204, response_class=Response, summary="Delete a reality capture",
               responses={**NOT_FOUND, 409: {"model": ErrorOut, "description": "It is being prepared"}})
def delete_reality(project_id: int, reality_id: int, session: SessionDep, state: StateDep) -> Response:
    row = in_project(session, Reality, reality_id, project_id, "reality capture")
    if row.status in ("queued", "preparing"):
        raise HTTPException(409, f"reality capture {reality_id} is being prepared; delete it when it is done")
    users = evaluations_using(session, project_id, REALITY_KEY, reality_id)
    if users:
        raise HTTPException(409, f"reality capture {reality_id} is the occluder of evaluation(s) "
                                 f"{', '.join(map(str, users))}: delete those first")
    files = [state.storage.reality_path(n) for n in (row.stored_name, row.view_name, row.view_name + ".glb")]
    session.delete(row)
    session.commit()
    state.storage.remove(*files)
    return Response(status_code=204)
