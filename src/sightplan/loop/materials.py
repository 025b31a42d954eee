"""The materials of the photograph-like renders: what each element is made of, its colour and how its surface looks.

An element's **material class** (:data:`CLASSES`) comes from what the model says of it, first match wins:

1. glazing: the file's surface style over at least :data:`GLAZED_SHARE` of its area is at least half transparent,
   or its style or material is named as glass;
2. its material's name (a layer set's first layer: a wall's outside face), e.g. "Masonry - Brick" → brick;
3. its surface style's name;
4. its IFC class (:data:`BY_CLASS`: walls plaster, slabs and structure concrete, windows glass, doors wood, …).

Its **colour** is the style's diffuse colour where the file styles it (a style named "Default …", an authoring
tool's placeholder grey, does not count), else the class's. Its **reflectance** is the class's: ``diffuse``
(Lambert), ``glass`` (a dark pane that mirrors the sky and the ground by Schlick's Fresnel term, almost no texture
of its own) or ``metal`` (diffuse with a share of sky mirrored).

The **texture statistics** per class, in the world so a point looks the same from every view (see
:mod:`.texture` for the noise): plaster and concrete low-contrast mottling (concrete with its formwork joints and
tie holes), brick a running bond of bricks of varied tone in light mortar, wood grain, roofing coarse granules,
metal and glass nearly featureless, the ground grass and gravel. Every pattern finer than a pixel's footprint on the
surface fades to its mean (what a lens and sensor average), so far or oblique surfaces do not alias.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from . import texture

GLAZED_SHARE = 0.2


@dataclass(frozen=True)
class MaterialClass:
    """colour: sRGB 0..1 where the model gives none. reflectance: diffuse, glass or metal. contrast: the mottling's
    strength (times :func:`texture.noise_contrast`)."""

    name: str
    colour: tuple[float, float, float]
    reflectance: str
    contrast: float


CLASSES: dict[str, MaterialClass] = {m.name: m for m in (
    MaterialClass("plaster", (0.86, 0.83, 0.77), "diffuse", 0.55),
    MaterialClass("concrete", (0.63, 0.62, 0.59), "diffuse", 0.8),
    MaterialClass("brick", (0.58, 0.30, 0.21), "diffuse", 0.5),
    MaterialClass("glass", (0.07, 0.09, 0.10), "glass", 0.05),
    MaterialClass("metal", (0.62, 0.64, 0.66), "metal", 0.25),
    MaterialClass("wood", (0.56, 0.39, 0.24), "diffuse", 0.9),
    MaterialClass("roofing", (0.33, 0.31, 0.30), "diffuse", 1.4),
    MaterialClass("ground", (0.36, 0.40, 0.24), "diffuse", 1.6),
    MaterialClass("generic", (0.72, 0.72, 0.70), "diffuse", 1.2),
)}

#: Words in a material's or a style's name, first match wins.
KEYWORDS: tuple[tuple[str, str], ...] = (
    (r"glass|glazing|glazed|\bpanes?\b", "glass"),
    (r"brick|klinker|clinker", "brick"),
    (r"concrete|cement|cast.in|precast|block|masonry|stone|screed", "concrete"),
    (r"plaster|stucco|render|gypsum|drywall|paint", "plaster"),
    (r"metal|steel|alumin|chrome|zinc|copper|iron|stud", "metal"),
    (r"wood|timber|lumber|plywood|teak|oak|pine|door|sash|trim|floor", "wood"),
    (r"roof|shingle|membrane|epdm|bitumen|slate", "roofing"),
    (r"grass|soil|site|earth|gravel|terrain", "ground"),
)
#: IFC classes (prefix match, subtypes by name) and their material class when nothing else says.
BY_CLASS: tuple[tuple[str, str], ...] = (
    ("IfcWindow", "glass"), ("IfcCurtainWall", "glass"), ("IfcDoor", "wood"), ("IfcRoof", "roofing"),
    ("IfcWall", "plaster"), ("IfcCovering", "plaster"), ("IfcSlab", "concrete"), ("IfcFooting", "concrete"),
    ("IfcColumn", "concrete"), ("IfcBeam", "concrete"), ("IfcStair", "concrete"), ("IfcRamp", "concrete"),
    ("IfcPile", "concrete"), ("IfcMember", "metal"), ("IfcRailing", "metal"), ("IfcPlate", "metal"),
    ("IfcSite", "ground"), ("IfcGeographicElement", "ground"),
)


def _keyword_class(text: str) -> str | None:
    for pattern, name in KEYWORDS:
        if re.search(pattern, text, re.I):
            return name
    return None


def classify(ifc_class: str, style: dict | None, glazed: float, material: str) -> str:
    """The material class of one element (module docstring's order)."""
    style_name = str((style or {}).get("name") or "")
    transparency = float((style or {}).get("transparency") or 0.0)
    if glazed >= GLAZED_SHARE or transparency >= 0.5 or re.search(r"glass|glazing", style_name + " " + material,
                                                                   re.I):
        return "glass"
    for text in (material, style_name):
        found = _keyword_class(text) if text else None
        if found:
            return found
    for prefix, name in BY_CLASS:
        if str(ifc_class).startswith(prefix):
            return name
    return "generic"


@dataclass(frozen=True)
class ElementMaterials:
    """Per element of a scene: the material class (index into ``names``), the sRGB colour and where it came from."""

    names: tuple[str, ...]
    klass: NDArray[np.int32]
    colour: NDArray[np.float64]
    styled: NDArray[np.bool_]

    def summary(self) -> dict:
        """{class: elements} and the number of elements coloured by the file's styles."""
        counts = np.bincount(self.klass, minlength=len(self.names))
        return {"classes": {n: int(c) for n, c in zip(self.names, counts, strict=True) if c},
                "styled_colours": int(self.styled.sum())}


def element_materials(scene) -> ElementMaterials:
    """The material class and colour of every element of ``scene`` (from ``scene.metadata["styles"]`` where the
    loader kept the file's surface styles, else by IFC class)."""
    styles = (scene.metadata or {}).get("styles") or {}
    table = styles.get("styles") or []
    per_element = styles.get("elements") or {}
    names = tuple(CLASSES)
    n = scene.n_elements
    klass = np.zeros(n, np.int32)
    colour = np.zeros((n, 3))
    styled = np.zeros(n, bool)
    for i, (gid, cls) in enumerate(zip(scene.elements.global_id, scene.elements.ifc_class, strict=True)):
        entry = per_element.get(str(gid))
        style, glazed, material = None, 0.0, ""
        if entry:
            k, glazed, material = int(entry[0]), float(entry[1]), str(entry[2] or "")
            style = table[k] if 0 <= k < len(table) else None
        name = classify(str(cls), style, glazed, material)
        klass[i] = names.index(name)
        rgb = (style or {}).get("rgb")
        placeholder = str((style or {}).get("name") or "").lower().startswith("default")
        if rgb and all(c is not None for c in rgb) and not placeholder and name != "glass":
            colour[i] = np.clip(np.asarray(rgb, float), 0.0, 1.0)
            styled[i] = True
        else:
            colour[i] = CLASSES[name].colour
    return ElementMaterials(names, klass, colour, styled)


# =========================================================================== patterns
def _soft_line(distance: NDArray, width: float, footprint: NDArray) -> NDArray:
    """Coverage 0..1 of a line ``width`` wide at ``distance`` from its axis, as a pixel of ``footprint`` sees it:
    a line finer than the pixel widens and fades, so its mean over the surface stays the same."""
    w = np.maximum(width, footprint)
    return np.clip((0.5 * w - np.abs(distance)) / np.maximum(0.5 * footprint, 1e-9) + 0.5, 0, 1) * (width / w)


def surface_axes(points: NDArray, normals: NDArray) -> tuple[NDArray, NDArray]:
    """(n,) u, v coordinates in metres on each point's surface: along the wall and up on steep surfaces (|n_z| <
    0.7), x and y on flat ones."""
    up = np.array([0.0, 0.0, 1.0])
    steep = np.abs(normals[:, 2]) < 0.7
    t = np.cross(up, normals)
    norm = np.linalg.norm(t, axis=1, keepdims=True)
    t = np.divide(t, norm, out=np.zeros_like(t), where=norm > 1e-9)
    u = np.where(steep, np.einsum("ij,ij->i", points, t), points[:, 0])
    v = np.where(steep, points[:, 2], points[:, 1])
    return u, v


def _hash01(a: NDArray, b: NDArray, seed: NDArray) -> NDArray:
    """A uniform 0..1 per integer pair and seed (for per-brick tones)."""
    z = np.zeros_like(a)
    return texture.lattice(a.astype(np.int64), b.astype(np.int64), z.astype(np.int64), seed)


BRICK_M = (0.24, 0.0775)  # a brick with its mortar joint: 215 × 65 mm bricks, 10 mm joints
MORTAR_M = 0.01
FORMWORK_M = (2.4, 1.2)  # concrete formwork panels, and tie holes on a 0.6 m grid inside them


def class_albedo(name: str, points: NDArray, normals: NDArray, seeds: NDArray[np.uint64], colours: NDArray,
                 cell_m: float, footprint: NDArray, textured: bool = True) -> NDArray[np.float64]:
    """(n, 3) sRGB albedo of points of one material class (module docstring); ``textured`` False: the colour."""
    if not textured or len(points) == 0:
        return np.asarray(colours, float).copy()
    m = CLASSES[name]
    c = texture.noise_contrast(points, seeds, cell_m, footprint)
    tone = 1.0 + m.contrast * c
    if name == "generic":
        return np.clip(colours * np.clip(0.7 + 2.4 * c, 0.25, 1.15)[:, None], 0, 1)
    u, v = surface_axes(points, normals)
    out = colours * tone[:, None]
    if name == "brick":
        bw, bh = BRICK_M
        row = np.floor(v / bh)
        shifted = u / bw + 0.5 * (row % 2)
        col = np.floor(shifted)
        resolved = np.clip((bh / np.maximum(footprint, 1e-9) - 2.0) / 2.0, 0, 1)  # bricks ≥ 4 px tall: full tone
        brick_tone = 1.0 + 0.28 * (_hash01(col, row, seeds) - 0.5) * resolved
        dv = (v - row * bh) - 0.5 * MORTAR_M  # the bed joint at the bottom of each course
        dv = np.minimum(np.abs(dv), np.abs(dv - bh))
        du = (shifted - col) * bw
        du = np.minimum(du, bw - du)
        mortar = np.clip(_soft_line(dv, MORTAR_M, footprint) + _soft_line(du, MORTAR_M, footprint), 0, 1)
        mortar_colour = np.array([0.72, 0.70, 0.66])
        out = (1 - mortar)[:, None] * out * brick_tone[:, None] + mortar[:, None] * mortar_colour * tone[:, None]
    elif name == "concrete":
        pw, ph = FORMWORK_M
        du = u - pw * np.round(u / pw)
        dv = v - ph * np.round(v / ph)
        joint = np.clip(_soft_line(du, 0.006, footprint) + _soft_line(dv, 0.006, footprint), 0, 1)
        hu, hv = u - 0.3 - 0.6 * np.round((u - 0.3) / 0.6), v - 0.3 - 0.6 * np.round((v - 0.3) / 0.6)
        r = np.hypot(hu, hv)
        hole = np.clip((0.0125 + 0.5 * footprint - r) / np.maximum(footprint, 1e-9), 0, 1) * \
            np.minimum(1.0, (0.025 / np.maximum(footprint, 0.025)) ** 2)
        out = out * (1 - 0.25 * joint - 0.45 * hole)[:, None]
    elif name == "wood":
        grain = texture.noise_contrast(np.stack([u * 8.0, v * 0.4, np.zeros_like(u)], axis=1), seeds, cell_m,
                                       footprint * 8.0, octaves=3)
        out = out * (1 + 0.8 * grain)[:, None]
    return np.clip(out, 0.0, 1.0)


def ground_albedo(points: NDArray, cell_m: float, footprint: NDArray) -> NDArray[np.float64]:
    """(n, 3) sRGB albedo of the ground: grass and gravel mixed by a coarse noise, each mottled at every scale."""
    seed = np.full(len(points), np.uint64(0x5EED6A0D))
    fine = texture.noise_contrast(points, seed, cell_m, footprint)
    coarse = texture.noise_contrast(points, seed + np.uint64(7), max(cell_m * 40, 1.0), footprint, octaves=2)
    mix = np.clip(0.5 + 3.0 * coarse, 0, 1)[:, None]
    grass = np.array(CLASSES["ground"].colour)
    gravel = np.array([0.55, 0.52, 0.47])
    return np.clip((mix * grass + (1 - mix) * gravel) * (1 + 1.6 * fine)[:, None], 0, 1)
