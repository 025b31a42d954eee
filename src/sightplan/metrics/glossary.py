"""What each metric means, with its unit and the threshold in force: the one text that the command line's tables,
the web page's labels, the HTML report and the README share (:func:`explain`, :data:`GLOSSARY`)."""

from __future__ import annotations

from dataclasses import dataclass

from .params import MetricParams


@dataclass(frozen=True)
class Definition:
    """key: the report's name (``report.json``'s metrics, the web API's); label: as shown; unit; text: one sentence,
    with ``{omega}``, ``{k}``, ``{min_track}``, ``{min_features}`` standing for the thresholds in force."""

    key: str
    label: str
    unit: str
    text: str


GLOSSARY: tuple[Definition, ...] = (
    Definition("VC_pct", "VC", "%", "Visual coverage: the share of the z target elements that some frame sees by at "
                                    "least Ω = {omega:g} px."),
    Definition("VC_bar_pct", "V̄C", "%", "Relative visual coverage: the share of the elements observed at all (by "
                                        "at least 1 px) that some frame sees by at least Ω = {omega:g} px."),
    Definition("VR", "VR", "frames", "Redundant visibility: how many frames see a visible element by at least "
                                     "Ω = {omega:g} px, averaged over the visible elements."),
    Definition("R_m_per_px", "R", "m/px", "Back-projection resolution: metres of surface per pixel (surface sampling "
                                          "distance), the mean of each visible element's k = {k} best frames, then "
                                          "over the elements; smaller is sharper."),
    Definition("O_deg", "O", "°", "Viewpoint orientation: the angle between the view and the surface's normal, the "
                                  "mean of each visible element's k = {k} best frames, then over the elements; 0° is "
                                  "head-on."),
    Definition("T", "T", "features", "Stability of reconstruction: stable features per frame; a feature is stable in "
                                     "a frame on a run of at least Y = {min_track} consecutive frames that see it."),
    Definition("stable_frames_pct", "stable", "%", "Stable frames: the share of frames with at least "
                                                   "Λ = {min_features} stable features, enough to register them."),
    Definition("visible", "visible / z", "elements", "Visible elements (seen by at least Ω = {omega:g} px in some "
                                                     "frame) of the z target elements; occluders do not count."),
    Definition("VR_i", "VR_i", "frames", "An element's redundant visibility: the frames that see it by at least "
                                         "Ω = {omega:g} px."),
    Definition("R_i", "R_i", "m/px", "An element's resolution: metres of surface per pixel in its k = {k} best "
                                     "frames."),
    Definition("O_i", "O_i", "°", "An element's orientation: the view's angle to its surface in its k = {k} best "
                                  "frames; 0° is head-on."),
    Definition("nu_f", "ν_f", "features", "A frame's stable features; the frame is stable with at least "
                                          "Λ = {min_features}."),
)
BY_KEY = {d.key: d for d in GLOSSARY}


def explain(key: str, params: MetricParams | None = None) -> str:
    """The definition of metric ``key`` (a :data:`GLOSSARY` key) with the thresholds of ``params`` (default
    :class:`MetricParams`)."""
    p = params or MetricParams()
    return BY_KEY[key].text.format(omega=p.omega, k=p.k, min_track=p.min_track, min_features=p.min_features)


def glossary(params: MetricParams | None = None) -> dict[str, dict[str, str]]:
    """Every definition as JSON: key → {label, unit, text}."""
    return {d.key: {"label": d.label, "unit": d.unit, "text": explain(d.key, params)} for d in GLOSSARY}
