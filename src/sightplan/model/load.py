"""One entry point for every model file: :func:`load_model` dispatches by extension and caches.

``"sample"`` as a path means the bundled buildingSMART Duplex (IFC2X3, CC BY 4.0).
"""

from __future__ import annotations

import time
from dataclasses import replace
from importlib import resources
from pathlib import Path

from ..errors import ModelError
from . import cache as _cache
from .formats import IFC_EXTENSIONS, MESH_EXTENSIONS, POINT_CLOUD_EXTENSIONS, SUPPORTED_EXTENSIONS
from .scene import Scene
from .summary import LoadProgress, LoadReport, peak_rss_mb
from .ties import tie_summary

SAMPLE = "sample"


def sample_model_path() -> Path:
    """Path of the bundled Duplex IFC (buildingSMART Duplex_A_20110907, CC BY 4.0)."""
    return Path(str(resources.files("sightplan") / "data" / "duplex.ifc"))


def resolve_model_path(path: str | Path) -> Path:
    """``path`` as a Path, with the literal ``"sample"`` meaning :func:`sample_model_path`."""
    return sample_model_path() if str(path) == SAMPLE else Path(path).expanduser()


def _options_and_loader(path: Path, options: dict):
    ext = path.suffix.lower()
    if ext in IFC_EXTENSIONS:
        from .ifc import ifc_options, load_ifc

        hashed = ifc_options(**{k: v for k, v in options.items() if k not in ("num_threads", "progress", "status")})
        return hashed, load_ifc
    if ext in POINT_CLOUD_EXTENSIONS or ext == ".ply":
        from .pointcloud import is_point_cloud, load_point_cloud, reality_options

        if is_point_cloud(path):
            options.pop("progress", None)
            options.pop("status", None)
            options.pop("up", None)  # a point cloud is Z up
            return reality_options(path, **options), load_point_cloud
    if ext in MESH_EXTENSIONS:
        from .mesh import load_mesh, mesh_options

        options.pop("progress", None)  # meshes load in one step
        options.pop("status", None)
        return mesh_options(path, **options), load_mesh
    supported = ", ".join(SUPPORTED_EXTENSIONS)
    raise ModelError(f"{path.name}: unsupported model format {ext or '(no extension)'!r}; supported: {supported}")


def load_model(
    path: str | Path, *, cache: bool = True, cache_dir: str | Path | None = None, **options
) -> tuple[Scene, LoadReport]:
    """Load an IFC, mesh or point cloud file (or ``"sample"``) as a :class:`Scene` in metres, with its load report.

    ``options`` go to :func:`~sightplan.model.ifc.load_ifc` (occluders,
    include_occluders_as_targets, num_threads, max_triangles, oversize, and the callbacks
    progress and status), :func:`~sightplan.model.mesh.load_mesh`
    (elements, scale, up, and patch_area_m2, normal_angle_deg for elements='patches') or, for
    .las/.laz and .ply files without faces, :func:`~sightplan.model.pointcloud.load_point_cloud`
    (patch_area_m2, normal_angle_deg, spacing_m, method, solid, scale). With ``cache``, the
    tessellated scene and its tie pairs are stored under ``cache_dir`` (default ``scenes`` under
    ``$SIGHTPLAN_CACHE`` or ``~/.cache/sightplan``) keyed by the file's content and the options, and
    read back on the next load; without it nothing is read or written. ``status`` (any format) also
    hears the 'ties' phase after the loader's own, then 'done'.
    """
    t0 = time.perf_counter()
    path = resolve_model_path(path)
    if not path.is_file():
        raise ModelError(f"model file not found: {path}")
    status = options.get("status")
    if status is not None and path.suffix.lower() in IFC_EXTENSIONS:
        options["status"] = lambda s: None if s.phase == "done" else status(s)  # 'done' comes after the tie pairs
    try:
        hashed, loader = _options_and_loader(path, options)
    except TypeError as exc:
        raise ModelError(f"{path.name}: invalid loader option: {exc}") from exc
    if cache:
        key = _cache.content_hash(path, hashed)
        hit = _cache.load_scene(key, cache_dir, source=str(path))
        if hit is not None:
            scene, report = hit
            return scene, replace(report, elapsed_s=time.perf_counter() - t0, from_cache=True,
                                  peak_rss_mb=round(peak_rss_mb(), 1))
    if status is not None and path.suffix.lower() not in IFC_EXTENSIONS:  # the IFC loader tells its own phases
        status(LoadProgress("reading", 0, 0, 0.0, time.perf_counter() - t0, None,
                            f"{path.name}, {path.stat().st_size / 2**20:,.1f} MB"))
    scene, report = loader(path, **options)
    if status is not None:
        status(LoadProgress("ties", 0, len(scene.faces), 1.0, time.perf_counter() - t0, None,
                            f"{len(scene.faces):,} triangles"))
    tied_faces, tied_elements = tie_summary(scene.tie_pairs(), scene.face_element)
    report = replace(report, tied_faces=tied_faces, tied_elements=tied_elements)
    if cache:
        try:
            _cache.save_scene(scene, report, cache_dir)
        except OSError as exc:  # a read-only or full cache directory must not fail the load
            report = replace(report, warnings=report.warnings + (f"scene cache not written: {exc}",))
    report = replace(report, elapsed_s=time.perf_counter() - t0, peak_rss_mb=round(peak_rss_mb(), 1))
    if status is not None:
        status(LoadProgress("done", report.n_elements, report.n_elements, 1.0, report.elapsed_s, None,
                            f"{report.n_elements:,} elements, {len(scene.faces):,} triangles"))
    return scene, report
