"""What an optimised plan must achieve, per element: the user's targets resolved on a scene.

A view *serves* element i when it sees it by at least Ω pixels (``omega_px``), at a surface sampling distance no
coarser than ``max_ssd_m_px`` and at an angle to the surface no wider than ``max_angle_deg``, each bound compared
with one relative tolerance (:data:`BOUND_RTOL`): a view placed on a bound (a template's 45° row) meets it, and
plans that differ only by rounding (6·10⁻¹² m) score the same. Element i is *met*
when at least ``k`` views serve it: then its VR_i ≥ k, and since R_i and O_i are means over the k best views, its
R_i ≤ max_ssd_m_px and O_i ≤ max_angle_deg too.

Targets come from defaults, the command line, or a TOML file::

    k = 3                      # every target element: at least 3 serving views
    max_ssd_m_px = 0.005       # default: the camera's SSD at the safety distance × 1.5
    max_angle_deg = 45

    [[rule]]                   # later rules override earlier ones, for the elements they match
    ifc_class = "IfcColumn"    # and/or storey = "…", discipline = "…", global_id = "…" (exact matches)
    k = 5
    weight = 2.0

    [[rule]]
    storey = "Roof"
    skip = true                # not a target of the optimisation
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import PlanError
from ..metrics import MetricParams
from ..model.scene import Scene
from ..observations.table import Observations

#: the default surface sampling distance bound is the camera's at the safety distance times this
SSD_SLACK = 1.5
#: a view's pixels, SSD and angle within this share of their bound meet it
BOUND_RTOL = 1e-9
_MATCH = ("ifc_class", "storey", "discipline", "global_id")
_VALUES = ("k", "max_ssd_m_px", "max_angle_deg", "weight", "skip")


@dataclass(frozen=True)
class Rule:
    """Values for the elements whose fields all equal ``match`` (an empty match: every element)."""

    match: tuple[tuple[str, str], ...] = ()
    k: int | None = None
    max_ssd_m_px: float | None = None
    max_angle_deg: float | None = None
    weight: float | None = None
    skip: bool | None = None


@dataclass(frozen=True)
class Targets:
    """The defaults for every target element, then ``rules`` in order. ``omega_px``: Ω. ``min_features``: Λ, the
    stability floor of a frame (features on tracks of ``min_track`` consecutive frames)."""

    k: int = 3
    max_ssd_m_px: float | None = None
    max_angle_deg: float = 45.0
    omega_px: float = 625.0
    min_track: int = 5
    min_features: int = 50
    rules: tuple[Rule, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        _check("k", self.k, integer=True, low=1)
        if self.max_ssd_m_px is not None:
            _check("max_ssd_m_px", self.max_ssd_m_px, low=0, strict=True)
        _check("max_angle_deg", self.max_angle_deg, low=0, high=90, strict=True)
        _check("omega_px", self.omega_px, low=1)
        _check("min_track", self.min_track, integer=True, low=1)
        _check("min_features", self.min_features, integer=True, low=0)
        for r in self.rules:
            for name in ("k", "max_ssd_m_px", "max_angle_deg", "weight"):
                v = getattr(r, name)
                if v is not None:
                    _check(f"a rule's {name}", v, integer=name == "k", low=1 if name == "k" else 0,
                           strict=name != "k", high=90 if name == "max_angle_deg" else None)

    @classmethod
    def read(cls, path: str | Path, **overrides) -> Targets:
        """Targets from a TOML file (see the module docstring); ``overrides`` (not None) replace its defaults."""
        path = Path(path)
        try:
            data = tomllib.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError) as exc:
            raise PlanError(f"cannot read the targets {path}: {exc}") from None
        except tomllib.TOMLDecodeError as exc:
            raise PlanError(f"{path.name} is not TOML: {exc}") from None
        known = {f.name for f in fields(cls)} - {"rules"}
        unknown = sorted(set(data) - known - {"rule"})
        if unknown:
            raise PlanError(f"{path.name}: unknown setting(s) {', '.join(unknown)}; use {', '.join(sorted(known))} "
                            "and [[rule]] tables")
        rules = []
        for n, r in enumerate(data.get("rule", []), start=1):
            if not isinstance(r, dict):
                raise PlanError(f"{path.name}: rule {n} must be a table")
            bad = sorted(set(r) - set(_MATCH) - set(_VALUES))
            if bad:
                raise PlanError(f"{path.name}: rule {n} has unknown key(s) {', '.join(bad)}; match on "
                                f"{', '.join(_MATCH)} and set {', '.join(_VALUES)}")
            rules.append(Rule(match=tuple((k, str(r[k])) for k in _MATCH if k in r),
                              **{k: r[k] for k in _VALUES if k in r}))
        base = {k: v for k, v in data.items() if k in known}
        return cls(**{**base, **{k: v for k, v in overrides.items() if v is not None}}, rules=tuple(rules))

    def metric(self) -> MetricParams:
        """The metric parameters these targets are counted with: Ω, k, Y and Λ."""
        return MetricParams(omega=self.omega_px, k=self.k, min_track=self.min_track, min_features=self.min_features)

    def record(self, et: ElementTargets) -> dict:
        """These targets as a plan's parameters record them, with the median SSD bound and the elements of ``et``."""
        active = et.active
        return {"k": self.k, "max_ssd_m_px": float(np.median(et.max_ssd_m_px[active])),
                "max_angle_deg": self.max_angle_deg, "omega_px": self.omega_px, "min_features": self.min_features,
                "rules": len(self.rules), "elements": int(active.sum())}

    def resolve(self, scene: Scene, default_ssd_m_px: float) -> ElementTargets:
        """Per-element arrays for ``scene`` (absent elements and occluders are no targets)."""
        z = scene.n_elements
        el = scene.elements
        k = np.full(z, self.k, np.int64)
        ssd = np.full(z, self.max_ssd_m_px if self.max_ssd_m_px is not None else default_ssd_m_px)
        angle = np.full(z, self.max_angle_deg)
        weight = np.ones(z)
        active = scene.targets.copy()
        for r in self.rules:
            sel = np.ones(z, bool)
            for name, value in r.match:
                sel &= np.asarray(getattr(el, name), dtype=object) == value
            if r.k is not None:
                k[sel] = r.k
            if r.max_ssd_m_px is not None:
                ssd[sel] = r.max_ssd_m_px
            if r.max_angle_deg is not None:
                angle[sel] = r.max_angle_deg
            if r.weight is not None:
                weight[sel] = r.weight
            if r.skip is not None:
                active[sel & scene.targets] = not r.skip
        active &= weight > 0
        return ElementTargets(k=k, max_ssd_m_px=ssd, max_angle_deg=angle, weight=weight * active, active=active,
                              omega_px=self.omega_px)

    def with_defaults(self, **values) -> Targets:
        return replace(self, **{k: v for k, v in values.items() if v is not None})


@dataclass(frozen=True)
class ElementTargets:
    """Per element (z,): views needed ``k``, bounds ``max_ssd_m_px`` and ``max_angle_deg``, ``weight`` (0 where not
    ``active``)."""

    k: NDArray[np.int64]
    max_ssd_m_px: NDArray[np.float64]
    max_angle_deg: NDArray[np.float64]
    weight: NDArray[np.float64]
    active: NDArray[np.bool_]
    omega_px: float

    @property
    def n_active(self) -> int:
        return int(self.active.sum())

    def sees(self, obs: Observations) -> NDArray[np.bool_]:
        """(rows,) whether each Observations row shows an active target by at least Ω pixels (within the tolerance)."""
        return self.active[obs.element] & (obs.pixels >= self.omega_px * (1 - BOUND_RTOL))

    def serves(self, obs: Observations) -> NDArray[np.bool_]:
        """(rows,) whether each Observations row serves its element: seen by Ω pixels, SSD and angle within their
        bounds, every bound with the one tolerance :data:`BOUND_RTOL`."""
        e = obs.element
        return (self.sees(obs) & (obs.ssd <= self.max_ssd_m_px[e] * (1 + BOUND_RTOL))
                & (obs.angle_mean <= self.max_angle_deg[e] * (1 + BOUND_RTOL)))


def _check(name: str, value, *, integer: bool = False, low: float | None = None, high: float | None = None,
           strict: bool = False) -> None:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if ok and integer:
        ok = float(value).is_integer()
    if ok and low is not None:
        ok = value > low if strict else value >= low
    if ok and high is not None:
        ok = value <= high
    if not ok:
        bound = "" if low is None else (f" > {low:g}" if strict else f" ≥ {low:g}")
        bound += "" if high is None else f", ≤ {high:g}"
        raise PlanError(f"{name} must be {'a whole number' if integer else 'a number'}{bound}, got {value!r}")
