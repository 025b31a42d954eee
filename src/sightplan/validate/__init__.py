"""Validation of a plan against a reality model Ψ registered to the model Γ (METRICS.md §7).

Conventions: λ = 1.2·e with e the registration error (m). Every frame is cast at the
settings' resolution scale s, pixel-centre rays as in :mod:`sightplan.engines`. Per pixel p,
Γ gives the element I_p and d_p(Γ), the distance from the camera centre to the first hit
within D_max; Ψ gives d_p(Ψ) along the same ray at any distance (so a reality in another
unit still shows as one); d_p(Ψ) is undefined where Ψ is not hit. ω_p = VR_{I_p} (0 for
occluder-only elements), VR from an evaluation of the plan on Γ.

- A = Σ ω_p |d_p(Γ) − d_p(Ψ)| / Σ ω_p over pixels where both are defined; None when Σ ω_p = 0.
  A_i = mean |d_p(Γ) − d_p(Ψ)| over those pixels of element i (its weights are all equal).
- Pixel p is complete iff d_p(Ψ) is defined and |d_p(Γ) − d_p(Ψ)| ≤ λ.
  c_i = complete / back-projected pixels of i over all frames (0 if never back-projected);
  Ce = mean c_i over the z targets; Cv = mean c_i over the visible ones (VR_i > 0).
- Ct = recall: share of points sampled uniformly (probability ∝ area, seeded) on the surfaces
  of Γ's present target elements that have Ψ within λ, with n = clip(round(area · 100 m⁻²),
  20 000, 1 000 000) points (``ct_density_per_m2``). Distances to a mesh Ψ are exact
  point–triangle distances (:func:`points_near_mesh`); to a point cloud, the nearest point,
  within max(λ, s_pt): a cloud sparser than λ covers the surface within its own spacing.
- Precision: share of Ψ's points (a mesh Ψ: points sampled on it with the same rule) inside
  Γ's bounding box grown by λ (the evaluated region, as the crop of Tanks and Temples) that
  lie within λ of Γ's surfaces (targets and occluders: a reconstructed occluder is no error).
  F = 2PR / (P + R).

A point cloud Ψ is first measured against Γ (:mod:`.distances`): its points' exact distances
to Γ's triangles give ``A_median`` and ``A_p90`` (median and 90th percentile), and the points
beyond a robust bound (median + 5·1.4826·MAD, at least λ) are SfM outliers: counted
(``outliers``) and left out of A, Ce, Cv and Ct; precision still counts them. The warning
that Ψ looks badly registered or in another unit fires when the median distance exceeds λ
(for a mesh Ψ: when most pixels hit on both differ by more than λ).

A point cloud Ψ is splatted into each frame: every point projects to a pixel position
(pinhole: perspective projection, depth z along the optical axis; equirectangular: by
direction, depth = distance) and covers the pixels whose centres lie within its footprint,
a disc of radius r_px = max(1, s_pt / (depth · angular pixel size)) pixels, at most
:data:`MAX_SPLAT_PX` (pinhole: angular size 1/fx across, 1/fy down; equirectangular: π/H
down and 2π/W·cos(latitude) across). Each pixel keeps the nearest depth, converted to the
distance along the pixel's own ray (pinhole: z·‖((u+½−cx)/fx, (v+½−cy)/fy, 1)‖). The point
spacing s_pt = r₈ · √(π/8), r₈ the median distance to the 8th neighbour (1/√density for a
uniform sampling), unless given. A disc of that radius closes the gaps of a regular scan and
of all but ~4 % of a random sampling, so a sparse cloud still fills its surfaces (c_i stays
high) while Ct, which needs a point within λ, drops once s_pt approaches λ. A splat keeps its
point's depth over its footprint (a pinhole: a plane parallel to the image; equirectangular: a
sphere about the camera), so on a surface inclined by θ to that, d_p(Ψ) errs by up to about
(footprint radius in metres)·tan θ, and taking the nearest biases it toward the camera.
"""

from .caster import FrameCaster
from .distances import OUTLIER_MADS, CloudDistances, cloud_distances
from .run import FAR_SHARE_WARNING, LAMBDA_PER_E, OVERLAP_WARNING, Validation, validate
from .splat import MAX_SPLAT_PX, SPACING_NEIGHBOUR, point_spacing, splat_distances
from .surface import CT_DENSITY_PER_M2, CT_MAX_SAMPLES, CT_MIN_SAMPLES, nearest_faces, points_near_mesh, sample_surface
from .synthetic import outward_normal, synthetic_reality

__all__ = ["CT_DENSITY_PER_M2", "CT_MAX_SAMPLES", "CT_MIN_SAMPLES", "FAR_SHARE_WARNING", "LAMBDA_PER_E", "MAX_SPLAT_PX",
           "OUTLIER_MADS", "OVERLAP_WARNING", "SPACING_NEIGHBOUR", "CloudDistances", "FrameCaster", "Validation",
           "cloud_distances", "nearest_faces", "outward_normal", "point_spacing", "points_near_mesh", "sample_surface",
           "splat_distances", "synthetic_reality", "validate"]
