"""Visibility by rasterisation with OpenGL (moderngl on a headless EGL context).

One frame is one draw call into an integer primitive-id attachment with a depth test on
the exact ray distance, then one compute pass that reduces the image on the GPU to the
same sparse per-element sums as the ray-casting engines (pixel count, distance, angle),
so only a few numbers per seen element come back to the host. It runs on any OpenGL 4.3
driver: an NVIDIA or AMD card through EGL, or Mesa's software rasteriser (llvmpipe) on a
machine without one.

The rules match :mod:`sightplan.engines.kernels` exactly:

* the fragment at each pixel centre is the first triangle along that pixel's ray: the
  depth written is the distance from the camera centre along the ray to the triangle's
  plane, not the projective depth, so occlusion is decided as a ray caster decides it;
* the reduction recomputes, per pixel, the distance t along the pixel's ray to the hit
  triangle's plane and the angle θ between the camera-facing normal and the optical axis
  (or the axis of the cube face the ray falls in, for 360° frames); pixels whose first
  hit lies beyond d_max count nothing;
* sums are kept as 64-bit fixed-point integers (built from 32-bit atomics with a
  carry), so a frame's result does not depend on the order the GPU runs in: two runs
  are bit-identical.

Equirectangular frames are rendered as the six 90° faces of a cube around the camera,
as in the source paper; the reduction walks the equirectangular pixel grid and takes
each pixel's triangle from the face its ray falls in (nearest face pixel), so pixel
counts mean the same as in the ray casters.

Features (METRICS.md §5.2) are defined by exact rays: a corner feature sits 1 mm off a
corner, and whether its ray grazes the next face is decided at a scale far below one
pixel. By default (``feature_test="rays"``) the engine casts those few thousand rays per
frame through Embree, so the stability metrics are the ray casters'. With
``feature_test="depth"`` they are tested on the GPU against the rendered id image
instead: hidden when the plane of the triangle drawn at the feature's pixel, or any
triangle drawn within ``feature_reach`` pixels, meets the feature's own ray before it.
That needs no CPU ray caster; on the Duplex it disagrees with exact rays on about 2 % of
the feature sightings, at corners.

Arbitrary rays (sight lines, the validation's reprojection) are not frames; for those
:meth:`GLEngine.first_hit` hands over to the Embree engine, built on first use.
"""

from __future__ import annotations

import contextlib
import functools
import math
import threading
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..camera.models import Camera, EquirectangularCamera
from ..errors import EngineError
from ..extras import install_hint
from ..model.ties import TIE_TOL_M
from ..observations.table import FrameObservation
from . import kernels
from .base import OCCLUSION_TOLERANCE_M, Engine

FeatureTest = Literal["rays", "depth"]

NEAR_M = 1e-3  # surfaces closer than this to the camera centre are clipped
DEFAULT_TILE_PX = 8192  # frames larger than this in either direction are drawn in tiles
CUBE_OVERSAMPLE = 1.6  # cube-face pixels per equirectangular pixel at the equator (≥ π/2 samples every pixel)
CUBE_REACH_PX = 1  # 360° frames: triangles drawn within this many face pixels are tested with the exact ray
FEATURE_REACH_PX = 1  # depth-buffer feature test: triangles drawn within this many pixels are tested exactly
_REDUCE_GROUP = 16  # the reduction's work groups are 16 × 16 pixels
_LINEAR_GROUP = 64  # work-group size of the one-dimensional passes (feature test, compaction)
_FIX = float(1 << 31)  # per-pixel fixed point: the largest value maps to 2³¹
_ANGLE_MAX_DEG = 90.0
_SOFTWARE = ("llvmpipe", "softpipe", "swrast", "software", "lavapipe")

_VERTEX = """
#version 430
in vec3 in_pos;
uniform mat3 R;          // camera -> world (columns: camera axes in world)
uniform vec3 C;          // camera centre, engine frame
uniform vec4 K;          // fx, fy, cx - u0, cy - v0 of this tile
uniform vec2 tile;       // tile width, height in pixels
uniform vec2 clip;       // near, far (camera z)
void main() {
    vec3 q = transpose(R) * (in_pos - C);   // x right, y down, z forward
    float n = clip.x, f = clip.y;
    gl_Position = vec4((2.0 * K.x / tile.x) * q.x + (2.0 * K.z / tile.x - 1.0) * q.z,
                       (2.0 * K.y / tile.y) * q.y + (2.0 * K.w / tile.y - 1.0) * q.z,
                       q.z * (f + n) / (f - n) - 2.0 * f * n / (f - n),
                       q.z);
}
"""

_FRAGMENT = """
#version 430
layout(std430, binding = 1) readonly buffer Planes { vec4 plane[]; };
uniform mat3 R;
uniform vec3 C;
uniform vec4 K;
uniform vec2 trange;     // t0, 1 / (t1 - t0): the depth written is (t - t0) / (t1 - t0)
layout(location = 0) out int out_id;
void main() {
    vec4 pl = plane[gl_PrimitiveID];
    vec3 d = R * normalize(vec3((gl_FragCoord.x - K.z) / K.x, (gl_FragCoord.y - K.w) / K.y, 1.0));
    float dn = dot(pl.xyz, d);
    float t = (pl.w - dot(pl.xyz, C)) / dn;
    float z = (abs(dn) > 0.0 && t >= 0.0) ? (t - trange.x) * trange.y : 1.0;
    gl_FragDepth = clamp(z, 0.0, 1.0);
    out_id = gl_PrimitiveID + 1;
}
"""

# Shared by the reduction and the feature test: ray direction and cube-face selection.
_COMMON = """
#version 430
layout(local_size_x = %(LX)d, local_size_y = %(LY)d) in;
layout(binding = 0) uniform isampler2D ids0;   // the pinhole tile, or cube face 0 (+x)
layout(binding = 1) uniform isampler2D ids1;   // cube faces −x, +y, −y, +z, −z
layout(binding = 2) uniform isampler2D ids2;
layout(binding = 3) uniform isampler2D ids3;
layout(binding = 4) uniform isampler2D ids4;
layout(binding = 5) uniform isampler2D ids5;
layout(std430, binding = 1) readonly buffer Planes { vec4 plane[]; };
uniform int mode;        // 0 pinhole tile, 1 the six cube faces of an equirectangular frame
uniform mat3 R;          // camera -> world
uniform vec3 C;
uniform vec4 K;          // pinhole: fx, fy, cx - u0, cy - v0; cube face: S/2, S/2, S/2, S/2
uniform ivec2 tile;      // pixels of the id image (pinhole tile or cube face)
uniform ivec2 img;       // pinhole: tile size; equirect: the W x H grid
uniform mat3 M[6];       // cube face -> camera, in the order of the samplers
uniform float dmax;

// primitive id + 1 drawn at texel q of id image f (0 for the pinhole tile)
int fetch_id(int f, ivec2 q) {
    switch (f) {
        case 0: return texelFetch(ids0, q, 0).r;
        case 1: return texelFetch(ids1, q, 0).r;
        case 2: return texelFetch(ids2, q, 0).r;
        case 3: return texelFetch(ids3, q, 0).r;
        case 4: return texelFetch(ids4, q, 0).r;
        default: return texelFetch(ids5, q, 0).r;
    }
}
layout(std430, binding = 10) readonly buffer Vertices { float vtx[]; };
layout(std430, binding = 11) readonly buffer Triangles { uint tri[]; };

vec3 vertex(uint k) { return vec3(vtx[3u * k], vtx[3u * k + 1u], vtx[3u * k + 2u]); }

// distance along the ray (o, d) to triangle p (Möller–Trumbore), +inf on a miss
float ray_triangle(int p, vec3 o, vec3 d) {
    vec3 a = vertex(tri[3 * p]);
    vec3 e1 = vertex(tri[3 * p + 1]) - a;
    vec3 e2 = vertex(tri[3 * p + 2]) - a;
    vec3 pv = cross(d, e2);
    float det = dot(e1, pv);
    if (det == 0.0) return 1.0 / 0.0;
    float inv = 1.0 / det;
    vec3 tv = o - a;
    float u = dot(tv, pv) * inv;
    if (u < 0.0 || u > 1.0) return 1.0 / 0.0;
    vec3 qv = cross(tv, e1);
    float v = dot(d, qv) * inv;
    if (v < 0.0 || u + v > 1.0) return 1.0 / 0.0;
    float t = dot(e2, qv) * inv;
    return (t >= 0.0) ? t : 1.0 / 0.0;
}

int dominant(vec3 c, out float s) {
    vec3 a = abs(c);
    int j = (a.x >= a.y && a.x >= a.z) ? 0 : ((a.y >= a.z) ? 1 : 2);
    s = (c[j] > 0.0) ? 1.0 : -1.0;
    return j;
}

// the cube face f a camera-frame direction falls in, the texel on it, and the face's axis (camera frame)
int face_texel(vec3 c, out ivec2 tex, out vec3 axis) {
    float s;
    int j = dominant(c, s);
    int f = 2 * j + ((s > 0.0) ? 0 : 1);
    vec3 q = transpose(M[f]) * c;
    vec2 uv = vec2(K.x * q.x / q.z + K.z, K.y * q.y / q.z + K.w);
    tex = clamp(ivec2(floor(uv)), ivec2(0), tile - 1);
    axis = vec3(0.0);
    axis[j] = s;
    return f;
}
"""

_REDUCE = _COMMON + """
layout(std430, binding = 2) readonly buffer FaceInfo { ivec2 face_info[]; };  // element, first tie entry
// 7 per entry (kernels.tie_table): 3 inward edges, (lo, hi, element bits, 0), 3 vertices with the normal in w;
// a face's header: (axis u, 0), (axis v, rows), (u0, v0, 1/cell u, 1/cell v), (columns, ...), then its cells' directory
layout(std430, binding = 12) readonly buffer Ties { vec4 tie[]; };
layout(std430, binding = 3) coherent buffer Acc { uint acc[]; };          // 5 per element
layout(std430, binding = 4) coherent buffer Touched { uint n_touched; uint touched[]; };
layout(std430, binding = 5) writeonly buffer Map { uint map[]; };        // 3 per pixel when mapping
uniform int write_map;
uniform ivec3 map_at;    // u0, v0 of this id image in the mapped frame, and the frame's width
uniform int cube_reach;  // face pixels around the nearest one whose triangles are tested exactly
uniform float t_unit;    // metres per fixed-point step
uniform float a_unit;    // degrees per fixed-point step
uniform float tie_tol;   // metres a hit may lie outside a tied triangle's edges
shared int s_el[%(LN)d];
shared uint s_t[%(LN)d];
shared uint s_a[%(LN)d];

// tie entry j's triangle holds x (x in its plane within tie_tol of the triangle), s = x along the hit face's axis
bool holds(int j, float s, vec3 x) {
    if (tie[7 * j + 3].y < s) return false;
    vec3 sk = vec3(dot(tie[7 * j].xyz, x) - tie[7 * j].w, dot(tie[7 * j + 1].xyz, x) - tie[7 * j + 1].w,
                   dot(tie[7 * j + 2].xyz, x) - tie[7 * j + 2].w);
    if (min(sk.x, min(sk.y, sk.z)) < -tie_tol) return false;
    if (min(sk.x, min(sk.y, sk.z)) >= 0.0) return true;
    vec3 n = vec3(tie[7 * j + 4].w, tie[7 * j + 5].w, tie[7 * j + 6].w);
    float best = 1.0 / 0.0;
    for (int k = 0; k < 3; k++) {  // near a corner: the distance to the nearest edge x lies outside of
        if (sk[k] >= 0.0) continue;
        vec3 a = tie[7 * j + 4 + k].xyz;
        vec3 e = tie[7 * j + 4 + ((k == 2) ? 0 : k + 1)].xyz - a;
        vec3 w = x - a;
        w -= dot(n, w) * n;
        float t = clamp(dot(w, e) / max(dot(e, e), 1e-30), 0.0, 1.0);
        best = min(best, length(w - t * e));
    }
    return best <= tie_tol;
}

// the cell (0..n - 1) of coordinate q along a grid axis (kernels._cell); beyond the grid, its border cell
int grid_cell(float q, float origin, float inverse, int n) {
    float k = (q - origin) * inverse;
    if (!(k > 0.0)) return 0;
    if (k >= float(n - 1)) return n - 1;
    return int(k);
}

// entry j's element when it holds x and no earlier entry of the window of the same element does; else -1
int tied_owner(int j, int start, float s, vec3 x) {
    if (!holds(j, s, x)) return -1;
    int eg = floatBitsToInt(tie[7 * j + 3].z);
    for (int i = start; i < j; i++) {
        if (floatBitsToInt(tie[7 * i + 3].z) == eg && holds(i, s, x)) return -1;
    }
    return eg;
}

void add64(uint i, uint lo, uint hi) {
    uint old = atomicAdd(acc[i], lo);
    atomicAdd(acc[i + 1u], hi + ((old + lo < old) ? 1u : 0u));
}

void main() {
    uvec2 gid = gl_GlobalInvocationID.xy;
    uint li = gl_LocalInvocationIndex;
    int e = -1, owner = -1;
    uint tq = 0u, aq = 0u;
    float t_out = 1.0 / 0.0, c_out = 0.0;
    bool inside = gid.x < uint(img.x) && gid.y < uint(img.y);
    if (inside) {
        vec3 c;
        ivec2 tex;
        vec3 axis;
        int f = 0;
        if (mode == 0) {
            c = normalize(vec3((float(gid.x) + 0.5 - K.z) / K.x, (float(gid.y) + 0.5 - K.w) / K.y, 1.0));
            tex = ivec2(gid);
            axis = R[2];
        } else {
            float lon = 6.283185307179586 * (float(gid.x) + 0.5) / float(img.x) - 3.141592653589793;
            float lat = 1.5707963267948966 - 3.141592653589793 * (float(gid.y) + 0.5) / float(img.y);
            float cl = cos(lat);
            c = vec3(cl * sin(lon), -sin(lat), cl * cos(lon));
            vec3 a;
            f = face_texel(c, tex, a);
            axis = R * a;
        }
        vec3 d = R * c;  // the pixel's ray, world frame
        int p = fetch_id(f, tex) - 1;
        if (mode == 1) {
            // the face texel is the nearest face pixel, not this ray: take the nearest
            // triangle this exact ray meets among those drawn around it, unless the
            // triangle drawn at the texel lies nearer still
            float best = 1.0 / 0.0;
            if (p >= 0) {  // the drawn triangle, by its plane: a nearer exact hit replaces it, a farther one not
                vec4 pc = plane[p];
                float tc = (pc.w - dot(pc.xyz, C)) / dot(pc.xyz, d);
                if (tc >= 0.0) best = tc;
            }
            int last = p;
            for (int dy = -cube_reach; dy <= cube_reach; dy++) {
                for (int dx = -cube_reach; dx <= cube_reach; dx++) {
                    ivec2 q = tex + ivec2(dx, dy);
                    if (q.x < 0 || q.y < 0 || q.x >= tile.x || q.y >= tile.y) continue;
                    int pq = fetch_id(f, q) - 1;
                    if (pq < 0 || pq == last) continue;
                    last = pq;
                    float tq_ = ray_triangle(pq, C, d);
                    if (tq_ < best) { best = tq_; p = pq; }
                }
            }
        }
        if (p >= 0) {
            vec4 pl = plane[p];
            float dn = dot(pl.xyz, d);
            float t = (pl.w - dot(pl.xyz, C)) / dn;
            if (dn != 0.0 && t >= 0.0 && t <= dmax) {
                vec3 nrm = (dn > 0.0) ? -pl.xyz : pl.xyz;
                float cosv = -dot(nrm, axis);
                // θ = atan2(|n × a|, n·a): accurate near 0°, where acos is not
                float ang = (cosv <= 0.0) ? 90.0 : degrees(atan(length(cross(nrm, axis)), cosv));
                e = face_info[p].x;
                owner = e;
                tq = uint(min(round(t / t_unit), 2147483648.0));
                aq = uint(min(round(ang / a_unit), 2147483648.0));
                t_out = t;
                c_out = abs(dn);
                // coincident surfaces: the pixel counts for every element whose tied face holds the hit too
                int h = face_info[p].y, j1 = face_info[p + 1].y;
                vec3 x = C + t * d;
                float s = 0.0;
                int a = h, b = h;
                if (h < j1) {  // the entries of x's cell (kernels.tie_window)
                    s = dot(tie[7 * h].xyz, x);
                    int nu = int(tie[7 * h + 3].x), nv = int(tie[7 * h + 1].w), c = 0;
                    if (nu > 1) c = grid_cell(s, tie[7 * h + 2].x, tie[7 * h + 2].z, nu);
                    if (nv > 1) c += nu * grid_cell(dot(tie[7 * h + 1].xyz, x), tie[7 * h + 2].y, tie[7 * h + 2].w, nv);
                    int i = 28 * h + 16 + 2 * c;
                    a = h + int(tie[i >> 2][i & 3]);
                    j1 = h + int(tie[(i + 2) >> 2][(i + 2) & 3]);
                    float lo_bound = s - tie[(i + 1) >> 2][(i + 1) & 3];
                    b = j1;
                    while (a < b) {  // the first entry starting at or after s - span
                        int mid = (a + b) / 2;
                        if (tie[7 * mid + 3].x < lo_bound) a = mid + 1; else b = mid;
                    }
                }
                for (int j = a; j < j1 && tie[7 * j + 3].x <= s; j++) {
                    int eg = tied_owner(j, a, s, x);
                    if (eg < 0 || eg == e) continue;
                    owner = min(owner, eg);
                    if (write_map == 0) {
                        uint base = 5u * uint(eg);
                        if (atomicAdd(acc[base], 1u) == 0u) {
                            touched[atomicAdd(n_touched, 1u)] = uint(eg);
                        }
                        add64(base + 1u, tq, 0u);
                        add64(base + 3u, aq, 0u);
                    }
                }
            }
        }
    }
    if (write_map != 0 && inside) {
        uint k = 3u * ((gid.y + uint(map_at.y)) * uint(map_at.z) + gid.x + uint(map_at.x));
        map[k] = uint(owner);  // the smallest owner, as the ray-casting engines' maps
        map[k + 1u] = floatBitsToUint(t_out);
        map[k + 2u] = floatBitsToUint(c_out);
    }
    s_el[li] = e;
    s_t[li] = tq;
    s_a[li] = aq;
    barrier();
    if (write_map == 0 && e >= 0) {
        bool leader = true;
        for (uint k = 0u; k < li; k++) {
            if (s_el[k] == e) { leader = false; break; }
        }
        if (leader) {
            uint cnt = 0u, tlo = 0u, thi = 0u, alo = 0u, ahi = 0u;
            for (uint k = li; k < %(LN)du; k++) {
                if (s_el[k] == e) {
                    cnt += 1u;
                    tlo += s_t[k]; if (tlo < s_t[k]) thi += 1u;
                    alo += s_a[k]; if (alo < s_a[k]) ahi += 1u;
                }
            }
            uint base = 5u * uint(e);
            if (atomicAdd(acc[base], cnt) == 0u) {
                touched[atomicAdd(n_touched, 1u)] = uint(e);
            }
            add64(base + 1u, tlo, thi);
            add64(base + 3u, alo, ahi);
        }
    }
}
"""

_COMPACT = """
#version 430
layout(local_size_x = %(LX)d) in;
layout(std430, binding = 3) buffer Acc { uint acc[]; };
layout(std430, binding = 4) readonly buffer Touched { uint n_touched; uint touched[]; };
layout(std430, binding = 6) writeonly buffer Out { uint outv[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= n_touched) return;
    uint e = touched[i];
    uint b = 5u * e;
    outv[6u * i] = e;
    for (uint k = 0u; k < 5u; k++) {
        outv[6u * i + 1u + k] = acc[b + k];
        acc[b + k] = 0u;
    }
}
"""

_FEATURES = _COMMON + """
layout(std430, binding = 7) readonly buffer FeatPoints { vec4 fpoint[]; };
layout(std430, binding = 8) readonly buffer FeatNormals { vec4 fnormal[]; };
layout(std430, binding = 9) coherent buffer Visible { uint n_visible; uint visible[]; };
uniform int n_features;
uniform vec4 window;     // pinhole: u0, v0, u1, v1 of this tile in full-frame pixels (scaled camera)
uniform vec4 Kfull;      // pinhole: fx, fy, cx, cy of the (scaled) camera
uniform float tol;
uniform int reach;       // pixels around the feature's pixel whose triangles are tested exactly
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= uint(n_features)) return;
    vec3 rel = fpoint[i].xyz - C;
    float dist = length(rel);
    if (!(dot(fnormal[i].xyz, rel) < 0.0 && dist <= dmax && dist > 0.0)) return;
    vec3 c = transpose(R) * rel;
    ivec2 tex;
    int f = 0;
    if (mode == 0) {
        if (c.z <= 0.0) return;
        float x = Kfull.x * c.x / c.z + Kfull.z;
        float y = Kfull.y * c.y / c.z + Kfull.w;
        if (!(x >= window.x && x < window.z && y >= window.y && y < window.w)) return;
        tex = clamp(ivec2(floor(vec2(x - window.x, y - window.y))), ivec2(0), tile - 1);
    } else {
        vec3 a;
        f = face_texel(c, tex, a);
    }
    // hidden when the feature's own ray meets, before it, a triangle drawn near its pixel
    vec3 d = rel / dist;
    bool seen = true;
    int p0 = fetch_id(f, tex) - 1;
    if (p0 >= 0) {  // the plane of the triangle drawn at the feature's pixel
        vec4 pl = plane[p0];
        float dn = dot(pl.xyz, d);
        float t = (pl.w - dot(pl.xyz, C)) / dn;
        seen = !(dn != 0.0 && t >= 0.0) || t >= dist - tol;
    }
    int last = -1;
    for (int dy = -reach; dy <= reach && seen; dy++) {
        for (int dx = -reach; dx <= reach && seen; dx++) {
            ivec2 q = tex + ivec2(dx, dy);
            if (q.x < 0 || q.y < 0 || q.x >= tile.x || q.y >= tile.y) continue;
            int p = fetch_id(f, q) - 1;
            if (p < 0 || p == last) continue;
            last = p;
            seen = ray_triangle(p, C, d) >= dist - tol;
        }
    }
    if (seen) visible[atomicAdd(n_visible, 1u)] = i;
}
"""


def _face_matrices() -> list[NDArray[np.float64]]:
    """The six cube faces (+x, −x, +y, −y, +z, −z): M with columns the face camera's x, y, z in camera axes."""
    out = []
    for j in range(3):
        for s in (1.0, -1.0):
            z = np.zeros(3)
            z[j] = s
            helper = np.array([0.0, 1.0, 0.0]) if j != 1 else np.array([0.0, 0.0, 1.0])
            x = np.cross(helper, z)
            x /= np.linalg.norm(x)
            y = np.cross(z, x)
            out.append(np.column_stack([x, y, z]))
    return out


_FACES = _face_matrices()
# the six face matrices as the shaders' `uniform mat3 M[6]`: column-major float32
_FACE_MATRICES_GL = b"".join(np.asarray(M, np.float32).T.tobytes() for M in _FACES)


def _renderer(ctx) -> str:
    return str(ctx.info.get("GL_RENDERER", "unknown"))


def create_context():
    """A headless OpenGL ≥ 4.3 context through EGL; :class:`EngineError` naming what is missing otherwise."""
    try:
        import moderngl
    except ImportError as exc:
        raise EngineError(f"the gl engine needs moderngl ({exc}): {install_hint('gl')}") from None
    try:
        ctx = moderngl.create_context(standalone=True, backend="egl")
    except Exception as exc:  # noqa: BLE001 - glcontext raises bare Exceptions naming the EGL call
        raise EngineError(
            f"no headless OpenGL context could be created through EGL ({exc}); install the GPU's EGL driver, "
            "or Mesa's (Debian: libegl1 libegl-mesa0 libgl1-mesa-dri) to render on the CPU") from None
    if ctx.version_code < 430:
        renderer = _renderer(ctx)
        ctx.release()
        raise EngineError(f"the gl engine needs OpenGL 4.3 compute shaders; {renderer} offers only "
                          f"{ctx.version_code // 100}.{ctx.version_code % 100 // 10}")
    return ctx


@functools.lru_cache(maxsize=1)
def probe() -> dict:
    """What OpenGL this process can get: {'available', 'renderer', 'hardware', 'error'}; computed once."""
    try:
        ctx = create_context()
    except EngineError as exc:
        return {"available": False, "renderer": "", "hardware": False, "error": str(exc)}
    renderer = _renderer(ctx)
    ctx.release()
    hardware = not any(word in renderer.lower() for word in _SOFTWARE)
    return {"available": True, "renderer": renderer, "hardware": hardware, "error": ""}


def available() -> bool:
    return probe()["available"]


def _gpu_device_nodes() -> bool:
    """Whether the kernel exposes a GPU at all (NVIDIA's or a DRM render node): a cheap
    check that spares machines without one the cost of starting an OpenGL driver."""
    import glob

    return bool(glob.glob("/dev/nvidia[0-9]*") or glob.glob("/dev/dri/renderD*"))


def hardware_available() -> bool:
    """True when the OpenGL driver is a GPU's, not a software rasteriser."""
    return _gpu_device_nodes() and probe()["hardware"]


class GLEngine(Engine):
    """Frames rasterised with OpenGL; per-element sums reduced on the GPU.

    tile_px: frames wider or taller than this are drawn in tiles (bounds GPU memory).
    cube_oversample: cube-face resolution for 360° frames, in face pixels per
    equirectangular pixel at the equator (the paper's cube-map approach).
    """

    name = "gl"

    def __init__(self, scene, features=None, *, tile_px: int = DEFAULT_TILE_PX,
                 cube_oversample: float = CUBE_OVERSAMPLE, feature_test: FeatureTest | None = None,
                 feature_reach: int = FEATURE_REACH_PX, cube_reach: int = CUBE_REACH_PX, **kwargs) -> None:
        kwargs["threads"] = 1  # one context; its work is ordered on the GPU, not split over threads
        super().__init__(scene, features, **kwargs)
        if not cube_oversample >= 1:
            raise EngineError(f"cube_oversample must be ≥ 1, got {cube_oversample}")
        self._lock = threading.RLock()
        self._ray_engine: Engine | None = None
        self.cube_oversample = float(cube_oversample)
        self.feature_reach = int(feature_reach)
        self.cube_reach = int(cube_reach)
        if feature_test is None:
            from . import embree

            feature_test = "rays" if embree.available() else "depth"
        if feature_test not in ("rays", "depth"):
            raise EngineError(f"feature_test must be 'rays' or 'depth', got {feature_test!r}")
        self.feature_test = feature_test
        self._targets: dict[tuple[int, int], tuple] = {}
        self.ctx = create_context()
        self.renderer = _renderer(self.ctx)
        try:
            with self._gpu(f"loading {len(scene.faces):,} triangles"):
                max_tex = int(self.ctx.info.get("GL_MAX_TEXTURE_SIZE", 8192))
                self.tile_px = max(16, min(int(tile_px), max_tex))
                self._build_programs()
                self._upload_scene()
                self._upload_features()
                self._fix_state()
        except EngineError:
            self.close()
            raise

    @contextlib.contextmanager
    def _gpu(self, doing: str):
        """Hold the context on this thread; an OpenGL failure becomes one EngineError naming it."""
        import moderngl

        with self._lock, self.ctx:
            try:
                yield
            except moderngl.Error as exc:
                raise EngineError(f"OpenGL on {self.renderer} failed while {doing}: {str(exc).strip()}; "
                                  "a smaller --scale, or --engine embree, avoids it") from None

    # ----------------------------------------------------------------- set-up
    def _build_programs(self) -> None:
        ctx = self.ctx
        self._prog = ctx.program(vertex_shader=_VERTEX, fragment_shader=_FRAGMENT)
        g = _REDUCE_GROUP
        self._reduce = ctx.compute_shader(_REDUCE % {"LX": g, "LY": g, "LN": g * g})
        self._compact = ctx.compute_shader(_COMPACT % {"LX": _LINEAR_GROUP})
        self._feat = ctx.compute_shader(_FEATURES % {"LX": _LINEAR_GROUP, "LY": 1})

    def _upload_scene(self) -> None:
        ctx, scene = self.ctx, self.scene
        self._n_faces = len(scene.faces)
        planes = np.zeros((max(1, self._n_faces), 4), np.float32)
        if self._n_faces:
            planes[:, :3] = self._face_normal
            planes[:, 3] = self._face_offset
        self._planes = ctx.buffer(planes.tobytes())
        tie_ptr, tie_elem, tie_edge = self._ties
        info = np.zeros((self._n_faces + 1, 2), np.int32)
        info[:-1, 0] = self._face_element
        info[:, 1] = tie_ptr
        self._face_el = ctx.buffer(info.tobytes())
        ties = np.zeros((max(1, len(tie_elem)), kernels.TIE_ROWS, 4), np.float32)
        ties[: len(tie_elem)] = tie_edge
        entry = tie_elem >= 0  # headers and cell directories keep their values
        ties[: len(tie_elem)][entry, 3, 2] = tie_elem[entry].view(np.float32)  # the element's bits: floatBitsToInt
        self._ties_buf = ctx.buffer(ties.tobytes())
        self._acc = ctx.buffer(reserve=max(1, self.n_elements) * 5 * 4)
        self._acc.clear()
        self._touched = ctx.buffer(reserve=(max(1, self.n_elements) + 1) * 4)
        self._touched.clear()
        self._out = ctx.buffer(reserve=max(1, self.n_elements) * 6 * 4)
        if self._n_faces:
            self._vbo = ctx.buffer(np.ascontiguousarray(self.local_vertices, np.float32).tobytes())
            self._ibo = ctx.buffer(np.ascontiguousarray(scene.faces, np.uint32).tobytes())
            self._vao = ctx.vertex_array(self._prog, [(self._vbo, "3f", "in_pos")], index_buffer=self._ibo,
                                         index_element_size=4)
        v = self.local_vertices if len(self.local_vertices) else np.zeros((1, 3))
        self._box = (v.min(axis=0), v.max(axis=0))

    def _upload_features(self) -> None:
        fs = self.features
        self._n_features = 0 if fs is None else len(fs)
        n = max(1, self._n_features)
        pts = np.zeros((n, 4), np.float32)
        nrm = np.zeros((n, 4), np.float32)
        if self._n_features:
            pts[:, :3] = fs.points - self.centre
            nrm[:, :3] = fs.normals
        self._fpoints = self.ctx.buffer(pts.tobytes())
        self._fnormals = self.ctx.buffer(nrm.tobytes())
        self._visible = self.ctx.buffer(reserve=(n + 1) * 4)
        self._visible.clear()

    def _fix_state(self) -> None:
        """What no frame changes, set once: depth test, storage-buffer bindings, constant uniforms."""
        import moderngl

        ctx = self.ctx
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE)
        ctx.depth_func = "<"
        for binding, buf in ((1, self._planes), (2, self._face_el), (3, self._acc), (4, self._touched),
                             (6, self._out), (7, self._fpoints), (8, self._fnormals), (9, self._visible),
                             (12, self._ties_buf)):
            buf.bind_to_storage_buffer(binding)
        if self._n_faces:
            self._vbo.bind_to_storage_buffer(10)
            self._ibo.bind_to_storage_buffer(11)
        for prog in (self._reduce, self._feat):
            if "M" in prog:
                prog["M"].write(_FACE_MATRICES_GL)
            self._set(prog, "dmax", self.d_max)
        self._set(self._reduce, "t_unit", self.d_max / _FIX)
        self._set(self._reduce, "tie_tol", TIE_TOL_M)
        self._set(self._reduce, "a_unit", _ANGLE_MAX_DEG / _FIX)
        self._set(self._reduce, "cube_reach", self.cube_reach)
        self._set(self._feat, "n_features", self._n_features)
        self._set(self._feat, "tol", OCCLUSION_TOLERANCE_M)
        self._set(self._feat, "reach", self.feature_reach)

    def _target(self, w: int, h: int, slot: int = 0):
        """Framebuffer ``slot`` of w × h (id + depth), kept for reuse: the six cube faces of a
        360° frame are slots 0–5 of one size; a size not used in the last seven draws is freed."""
        import moderngl

        key = (w, h, slot)
        if key not in self._targets:
            while len(self._targets) >= 7:  # free the least recently used size, all its slots
                size = next(iter(self._targets))[:2]
                released: set[int] = set()
                for k in [k for k in self._targets if k[:2] == size]:
                    for item in self._targets.pop(k):
                        if id(item) not in released:  # a shared depth buffer is released once
                            released.add(id(item))
                            item.release()
            ids = self.ctx.texture((w, h), 1, dtype="i4")
            ids.filter = (moderngl.NEAREST, moderngl.NEAREST)  # an integer texture must not be filtered
            shared = self._targets.get((w, h, 0)) if slot else None  # the faces share slot 0's depth buffer
            depth = shared[2] if shared is not None else self.ctx.depth_texture((w, h))
            fbo = self.ctx.framebuffer(color_attachments=[ids], depth_attachment=depth)
            self._targets[key] = (fbo, ids, depth)
        else:
            self._targets[key] = self._targets.pop(key)  # most recently used last
        return self._targets[key]

    def close(self) -> None:
        with self._lock:
            if getattr(self, "ctx", None) is not None:
                self._targets.clear()
                self.ctx.release()
                self.ctx = None
            if self._ray_engine is not None:
                self._ray_engine.close()
                self._ray_engine = None
        super().close()

    # ------------------------------------------------------------ arbitrary rays
    def _rays(self):
        """The Embree engine that casts this engine's arbitrary rays (built once, on first use)."""
        with self._lock:
            if self._ray_engine is None:
                from .embree import EmbreeEngine

                self._ray_engine = EmbreeEngine(self.scene, None, d_max=self.d_max, threads=self.threads)
            return self._ray_engine

    def first_hit(self, origins: NDArray[np.float32], directions: NDArray[np.float32]) -> NDArray[np.int32]:
        """Arbitrary rays are not frames: they go to the Embree engine."""
        return self._rays().first_hit(origins, directions)

    def unoccluded_rays(self, origin32, directions, tfar, tnear=None):
        """Feature sight lines go to the Embree engine too (its occlusion query)."""
        return self._rays().unoccluded_rays(origin32, directions, tfar, tnear)

    # ------------------------------------------------------------------ views
    def _views(self, cam: Camera, R: NDArray):
        """Every draw of this frame: {mode, R (the view's camera -> world), K, tile size, framebuffer slot,
        window (u0, v0, u1, v1 in frame pixels)}."""
        if isinstance(cam, EquirectangularCamera):
            s = min(self.tile_px, max(8, math.ceil(self.cube_oversample * cam.width / math.pi)))
            half = s / 2.0
            for slot, M in enumerate(_FACES):
                yield {"mode": 1, "R": R @ M, "K": (half, half, half, half), "tile": (s, s), "slot": slot,
                       "window": (0, 0, s, s)}
            return
        T = self.tile_px
        for v0 in range(0, cam.height, T):
            for u0 in range(0, cam.width, T):
                tw, th = min(T, cam.width - u0), min(T, cam.height - v0)
                yield {"mode": 0, "R": R, "K": (cam.fx, cam.fy, cam.cx - u0, cam.cy - v0), "tile": (tw, th),
                       "slot": 0, "window": (u0, v0, u0 + tw, v0 + th)}

    def _t_range(self, C: NDArray) -> tuple[float, float]:
        """Distances from C between which surfaces can lie (the depth buffer's range)."""
        lo, hi = self._box
        nearest = float(np.linalg.norm(np.maximum(0.0, np.maximum(lo - C, C - hi))))
        farthest = float(np.linalg.norm(np.maximum(np.abs(C - lo), np.abs(hi - C))))  # the farthest corner
        t0 = max(0.0, nearest * (1 - 1e-6) - 1e-3)
        t1 = min(self.d_max, farthest) * (1 + 1e-6) + 1e-3
        return t0, max(t1, t0 + 1e-3)

    def _draw(self, view: dict, C: NDArray, t0: float, t1: float):
        """Render one view into its framebuffer; its id texture."""
        import moderngl

        fbo, ids, _ = self._target(*view["tile"], view["slot"])
        fbo.use()
        fbo.clear(0.0, depth=1.0)
        if self._n_faces:
            p = self._prog
            p["R"].write(np.asarray(view["R"], np.float32).T.tobytes())  # column-major
            p["C"].value = tuple(float(x) for x in C)
            p["K"].value = tuple(float(x) for x in view["K"])
            p["tile"].value = tuple(float(x) for x in view["tile"])
            # the far clip must not cut what lies within t1 anywhere in a 90°-or-narrower view
            p["clip"].value = (NEAR_M, max(2.0 * t1, NEAR_M * 10))
            p["trange"].value = (t0, 1.0 / (t1 - t0))
            self._vao.render(moderngl.TRIANGLES)
        return ids

    @staticmethod
    def _set(prog, name: str, value) -> None:
        """Set a uniform the compiler kept (unused ones are optimised away)."""
        if name in prog:
            prog[name].value = value

    def _set_view(self, prog, view: dict, img: tuple[int, int], R: NDArray, C: NDArray) -> None:
        """The uniforms the reduction and the feature test share that change with the view."""
        self._set(prog, "mode", view["mode"])
        prog["R"].write(np.asarray(R, np.float32).T.tobytes())  # column-major: R's columns
        self._set(prog, "C", tuple(float(x) for x in C))
        self._set(prog, "K", tuple(float(x) for x in view["K"]))
        self._set(prog, "tile", tuple(int(x) for x in view["tile"]))
        self._set(prog, "img", img)

    def _frame(self, cam: Camera, R: NDArray, C: NDArray, map_buffer=None, features: bool = True) -> None:
        """Draw and reduce every view of one frame: into the accumulators, or, given ``map_buffer``
        (W × H × 3 uint32), into a per-pixel map of element id, distance and |cos|."""
        t0, t1 = self._t_range(C)
        equirect = isinstance(cam, EquirectangularCamera)
        red, feat = self._reduce, self._feat
        views = list(self._views(cam, R))
        passes = [views] if equirect else [[v] for v in views]  # six faces reduce in one pass
        (map_buffer if map_buffer is not None else self._out).bind_to_storage_buffer(5)
        self._set(red, "write_map", int(map_buffer is not None))
        for group in passes:
            for unit, v in enumerate(group):
                ids = self._draw(v, C, t0, t1)
                ids.use(location=unit)
            for unit in range(len(group), 6):  # every sampler needs a texture; unused ones repeat the last
                ids.use(location=unit)
            self.ctx.memory_barrier()
            view = group[0]
            img = (cam.width, cam.height) if equirect else view["tile"]
            self._set_view(red, view, img, R, C)
            u0, v0 = view["window"][:2]  # (0, 0) for the cube faces
            self._set(red, "map_at", (int(u0), int(v0), int(cam.width)))
            red.run((img[0] + _REDUCE_GROUP - 1) // _REDUCE_GROUP, (img[1] + _REDUCE_GROUP - 1) // _REDUCE_GROUP, 1)
            self.ctx.memory_barrier()
            if features and self._n_features and self._n_faces:
                self._set_view(feat, view, view["tile"], R, C)
                self._set(feat, "window", tuple(float(x) for x in view["window"]))
                self._set(feat, "Kfull", (cam.fx, cam.fy, cam.cx, cam.cy) if not equirect else (1.0, 1.0, 0.0, 0.0))
                feat.run((self._n_features + _LINEAR_GROUP - 1) // _LINEAR_GROUP, 1, 1)
                self.ctx.memory_barrier()

    def _collect(self) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """Sorted (elements, counts, depth sums m, angle sums °) of the frame just reduced; resets the accumulators."""
        n = int(np.frombuffer(self._touched.read(4), np.uint32)[0])
        if n == 0:
            return np.zeros(0, np.int32), np.zeros(0, np.int64), np.zeros(0), np.zeros(0)
        self._compact.run((n + _LINEAR_GROUP - 1) // _LINEAR_GROUP, 1, 1)
        self.ctx.memory_barrier()
        rows = np.frombuffer(self._out.read(n * 24), np.uint32).reshape(n, 6).astype(np.uint64)
        self._touched.write(np.zeros(1, np.uint32).tobytes())
        order = np.argsort(rows[:, 0], kind="stable")
        rows = rows[order]
        depth = (rows[:, 2] + (rows[:, 3] << np.uint64(32))).astype(np.float64) * (self.d_max / _FIX)
        angle = (rows[:, 4] + (rows[:, 5] << np.uint64(32))).astype(np.float64) * (_ANGLE_MAX_DEG / _FIX)
        return rows[:, 0].astype(np.int32), rows[:, 1].astype(np.int64), depth, angle

    def _collect_features(self) -> NDArray[np.int32]:
        if not self._n_features:
            return np.zeros(0, np.int32)
        n = int(np.frombuffer(self._visible.read(4), np.uint32)[0])
        idx = np.frombuffer(self._visible.read(n * 4, offset=4), np.uint32) if n else np.zeros(0, np.uint32)
        self._visible.write(np.zeros(1, np.uint32).tobytes())
        return np.sort(idx.astype(np.int32))

    # ------------------------------------------------------------ per frame
    def observe(self, camera: Camera, R_world_camera: NDArray, C_world: NDArray, scale: float = 1.0) -> FrameObservation:
        if not 0 < scale <= 1:
            raise EngineError(f"resolution scale must be in (0, 1], got {scale}")
        cam = camera.scaled(scale) if scale != 1 else camera
        R = np.asarray(R_world_camera, dtype=np.float64)
        C = np.asarray(C_world, dtype=np.float64) - self.centre
        depth_test = self.feature_test == "depth"
        with self._gpu(f"drawing a {cam.width}×{cam.height} frame"):
            self._frame(cam, R, C, features=depth_test)
            element, count, depth, angle = self._collect()
            features = self._collect_features() if depth_test else None
        if features is None:
            features = Engine.visible_features(self, camera, R, C_world)
        return FrameObservation(
            element=element,
            count=count,
            depth_mean=depth / np.maximum(count, 1),
            angle_mean=angle / np.maximum(count, 1),
            features=features,
            pixel_scale=(camera.width * camera.height) / (cam.width * cam.height),
            sampling_focal_px=camera.sampling_focal_px,
        )

    def visible_features(self, camera: Camera, R_world_camera: NDArray, C_world: NDArray) -> NDArray[np.int32]:
        """Features seen from this pose: by exact rays (``feature_test='rays'``), or against the
        id image rendered at the camera's full resolution (``'depth'``)."""
        if self.feature_test == "rays":
            return Engine.visible_features(self, camera, R_world_camera, C_world)
        with self._gpu("testing features"):
            R = np.asarray(R_world_camera, dtype=np.float64)
            self._frame(camera, R, np.asarray(C_world, np.float64) - self.centre)
            self._collect()
            return self._collect_features()

    def shaded_view(self, camera: Camera, R_world_camera: NDArray, C_world: NDArray, scale: float = 1.0
                    ) -> tuple[NDArray[np.int32], NDArray[np.float64], NDArray[np.float64]]:
        cam = camera.scaled(scale) if scale != 1 else camera
        R = np.asarray(R_world_camera, dtype=np.float64)
        C = np.asarray(C_world, dtype=np.float64) - self.centre
        W, H = cam.width, cam.height
        with self._gpu(f"drawing a {W}×{H} view"):
            buf = self.ctx.buffer(reserve=W * H * 12)
            try:
                self._frame(cam, R, C, map_buffer=buf, features=False)
                out = np.frombuffer(buf.read(), np.uint32).reshape(H, W, 3)
            finally:
                buf.release()
        ids = out[:, :, 0].view(np.int32).copy()
        t = out[:, :, 1].view(np.float32).astype(np.float64)
        cos = out[:, :, 2].view(np.float32).astype(np.float64)
        hit = ids >= 0
        return ids, np.where(hit, t, np.inf), np.where(hit, cos, 0.0)
