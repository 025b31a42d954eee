"""``sightplan plan TEMPLATE MODEL``: make a capture plan from a template."""

from __future__ import annotations

import inspect
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import typer

from ..errors import PlanError
from ..plan.ground import with_ground_z
from ..plan.site import with_site
from ..plan.templates.base import ParamInfo, cli_name, unit_of
from ..plan.templates.registry import TEMPLATE_NAMES, TEMPLATES, WALKED, plan_from_template
from .base import app, console
from .camera_opts import CAMERA_FORMS, FocalOpt, cli_camera
from .errors import friendly_errors, writable_file
from .flight import (
    AltitudeOpt,
    GroundZOpt,
    MinHeightOpt,
    PositionErrorOpt,
    StationOpt,
    VlosOpt,
    default_flight_settings,
    parse_point,
    print_feasibility,
)
from .fourd import (
    ActualOpt,
    BasisOpt,
    DateOpt,
    RealityOpt,
    RulesOpt,
    ScheduleOpt,
    UnscheduledOpt,
    dated_scene,
    with_reality,
)
from .loading import georef_kwargs, load_with_progress, print_warnings, refuse_if_far

TemplateName = Literal[TEMPLATE_NAMES]  # type: ignore[valid-type]


@dataclass(frozen=True)
class TemplateOption:
    """A command-line option of ``sightplan plan``, shared by the template parameters that carry its name."""

    cli: str
    kind: str
    members: tuple[tuple[str, str, ParamInfo, Any], ...]  # (template, field, declaration, default)

    @property
    def pyname(self) -> str:
        return self.cli.replace("-", "_")

    def default(self) -> Any:
        """The parameters' shared default (so help can show it), else None: each template's own."""
        defaults = {repr(m[3]) for m in self.members}
        if self.kind == "flag":
            return self.members[0][3]
        return self.members[0][3] if len(defaults) == 1 and self.kind in ("number", "choice") else None

    def help(self) -> str:
        by_text: dict[str, list[str]] = {}
        for template, name, info, _ in self.members:
            text = info.help
            if info.kind == "choice" and not any(f"'{c}'" in info.help for c in info.choices):
                text += f": {' or '.join(info.choices)}"
            if info.kind in ("points2", "points3"):
                text = f"a point '{'x,y' if info.kind == 'points2' else 'x,y,z'}' of {text}"
            about = "; ".join(b for b in (unit_of(name), info.bounds_text()) if b)
            by_text.setdefault(text + (f" ({about})" if about else ""), []).append(template)
        return "; ".join(f"{', '.join(ts)}: {text}" for text, ts in by_text.items())

    def annotation(self) -> Any:
        tp = {"number": float | None, "numbers": list[float] | None, "choice": str | None, "flag": bool,
              "points2": list[str] | None, "points3": list[str] | None, "file": Path | None}[self.kind]
        decl = f"--{self.cli}/--no-{self.cli}" if self.kind == "flag" else f"--{self.cli}"
        return Annotated[tp, typer.Option(decl, help=self.help())]

    def value(self, template: str, given: Any) -> tuple[str, Any] | None:
        """(field, value) of ``template``'s parameter for the option's ``given`` value, or None when the template
        takes no such option or it was not given."""
        member = next((m for m in self.members if m[0] == template), None)
        if member is None or given is None or (self.kind == "numbers" and not given):
            return None

        _, name, info, _ = member
        if info.kind == "points2":
            given = tuple(tuple(parse_point(q if q.count(",") == 2 else q + ",0", "bridge axis point")[:2].tolist())
                          for q in given)
        elif info.kind == "points3":
            given = tuple(tuple(parse_point(q, "route point").tolist()) for q in given)
        elif info.kind == "numbers":
            given = tuple(given)
        elif self.kind == "numbers":  # a one-value parameter behind an option other templates repeat
            if len(given) != 1:
                raise PlanError(f"--{self.cli} takes one value for the {template} template, got {len(given)}")
            given = given[0]
        elif info.kind == "file":
            given = str(given)
        return name, given

    def stray(self, template: str, given: Any) -> bool:
        """Whether the option was given a value although ``template`` takes no such parameter."""
        if any(m[0] == template for m in self.members):
            return False
        return given not in (None, [], ()) and given != self.default()


def template_options() -> list[TemplateOption]:
    """One option per command-line name among every template's parameters, in declaration order."""
    groups: dict[str, list[tuple[str, str, ParamInfo, Any]]] = {}
    for t in TEMPLATES.values():
        for name, info, default in t.fields():
            groups.setdefault(cli_name(name, info), []).append((t.name, name, info, default))
    options = []
    for cli, members in groups.items():
        kinds = {"points" if m[2].kind.startswith("points") else m[2].kind for m in members}
        if kinds == {"number", "numbers"}:  # one template takes one value, another several: the option repeats
            kinds = {"numbers"}
        if len(kinds) != 1:
            raise RuntimeError(f"--{cli} means different kinds of value: {kinds}")
        kind = "numbers" if "numbers" in kinds else members[0][2].kind
        options.append(TemplateOption(cli, kind, tuple(members)))
    return options


TEMPLATE_OPTIONS = template_options()


def plan_command(
    template: Annotated[TemplateName, typer.Argument(
        help=", ".join(f"{t.name} ({t.summary})" for t in TEMPLATES.values()))],
    model: Annotated[str, typer.Argument(help="IFC or mesh file; 'sample' for the bundled Duplex model")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Plan file to write (sightplan JSON)")] = Path("plan.json"),
    camera: Annotated[str, typer.Option(help="Camera: " + CAMERA_FORMS)] = "p4p",
    focal_mm: FocalOpt = None,
    safety_distance: Annotated[float | None, typer.Option(
        "--safety-distance", help="Least distance g to the model (m); default 10, 0.3 for a route")] = None,
    vlos_radius: VlosOpt = 500.0,
    ground_station: StationOpt = None,
    aircraft: Annotated[str | None, typer.Option(
        help="Aircraft preset (p4p, m3e, m300), rover preset for a route (walker-360, spot, tracked), or a JSON file "
             "of its fields; 'none': no battery. Default p4p, walker-360 for a route")] = None,
    altitude_limit: AltitudeOpt = 120.0,
    min_height: MinHeightOpt = None,
    position_error: PositionErrorOpt = None,
    ground_z: GroundZOpt = None,
    split: Annotated[bool, typer.Option(help="Split missions to keep line of sight and fit the batteries")] = True,
    date: DateOpt = None,
    schedule: ScheduleOpt = None,
    rules: RulesOpt = None,
    reality: RealityOpt = None,
    prefer_actual: ActualOpt = False,
    date_basis: BasisOpt = "finish",
    unscheduled: UnscheduledOpt = "present",
    cache: Annotated[bool, typer.Option(help="Reuse the model cache")] = True,
    **template_values: Any,
) -> None:
    """Make a capture plan from a template around a model, check that it can be flown, and write it.

    The template's own options (listed below after the common ones) come from its parameter declarations."""
    from ..plan.format import write_plan

    stray = [f"--{o.cli}" for o in TEMPLATE_OPTIONS if o.stray(template, template_values.get(o.pyname))]
    if stray:
        takes = [f"--{o.cli}" for o in TEMPLATE_OPTIONS if any(m[0] == template for m in o.members)]
        raise PlanError(f"the {template} template takes no {', '.join(stray)}; its options are {', '.join(takes)}")
    values = dict(v for o in TEMPLATE_OPTIONS if (v := o.value(template, template_values.get(o.pyname))) is not None)
    try:
        params = TEMPLATES[template].make(values)  # checked before the model is loaded
    except PlanError as exc:  # name the option, not the parameter
        raise PlanError(_options_named(template, str(exc))) from None
    cam = cli_camera(camera, focal_mm)
    scene, _ = load_with_progress(console, model, cache)
    scene = with_ground_z(dated_scene(console, scene, model, schedule, rules, prefer_actual, date, date_basis,
                                      unscheduled), ground_z)
    obstacles = with_reality(console, scene, reality)  # templates go around the model; checks see everything
    walked = template in WALKED
    settings = default_flight_settings(walked, safety_distance, None if walked else vlos_radius,
                                       None if walked else ground_station, aircraft, None if walked else altitude_limit,
                                       min_height=min_height, position_error=position_error, scene=scene)
    try:
        plan, report = plan_from_template(template, scene, cam, params, settings, obstacles=obstacles, split=split)
    except PlanError as exc:
        raise PlanError(_options_named(template, str(exc))) from None
    write_plan(plan, output)
    print_feasibility(console, report, f"{template} plan around {Path(str(model)).name} — {cam.name or camera}")
    if "dropped_frames" in plan.parameters:
        dropped = int(plan.parameters["dropped_frames"])
        console.print(f"dropped {dropped} frame(s) of the template: {plan.parameters.get('dropped_reason')}" if dropped
                      else "dropped no frame: every frame of the template has a target of the model in view",
                      highlight=False)
    lengths = {k: v for k, v in plan.parameters.items() if k.endswith("_m") and isinstance(v, float)}
    if lengths:
        console.print(", ".join(f"{k.removesuffix('_m').replace('_', ' ')} {v:.3g} m" for k, v in lengths.items()))
    console.print(f"wrote {output} — evaluate it with `sightplan evaluate {model} {output}`")


def _options_named(template: str, message: str) -> str:
    """A template's message with its parameters named as the command line's options ("gsd_m_px" → "--gsd")."""
    import re

    names = {m[1]: f"--{o.cli}" for o in TEMPLATE_OPTIONS for m in o.members if m[0] == template}
    names |= {"safety_distance_m": "--safety-distance"}
    first, sep, rest = message.partition(" ")
    if first.rstrip(":") in names:  # "overlap must be …", "gsd_m_px: 0.0001 puts …"
        message = names[first.rstrip(":")] + first[len(first.rstrip(":")):] + sep + rest
    fields = [n for n in names if "_" in n]  # elsewhere only names no sentence has ("step_m", not "axis")
    return re.sub(r"\b(" + "|".join(map(re.escape, fields)) + r")\b", lambda m: names[m.group(1)], message)


def _with_template_options(command: Any) -> Any:
    """``command`` with the templates' options added to its signature, for the command line to parse."""
    sig = inspect.signature(plan_command, eval_str=True)
    fixed = [p for p in sig.parameters.values() if p.kind is not inspect.Parameter.VAR_KEYWORD]
    generated = [inspect.Parameter(o.pyname, inspect.Parameter.KEYWORD_ONLY, default=o.default(),
                                   annotation=o.annotation()) for o in TEMPLATE_OPTIONS]
    command.__signature__ = sig.replace(parameters=[*fixed, *generated])
    return command


app.command("plan")(_with_template_options(friendly_errors(plan_command)))


@app.command("check")
@friendly_errors
def check_command(
    plan_file: Annotated[str, typer.Argument(metavar="PLAN", help="Plan file (any format `sightplan evaluate` reads)")],
    model: Annotated[str, typer.Argument(help="IFC or mesh file; 'sample' for the bundled Duplex model")],
    safety_distance: Annotated[float | None, typer.Option(
        "--safety-distance", help="Least distance to the model (m); default 5, 0.3 for a walked route")] = None,
    vlos_radius: Annotated[float | None, typer.Option(
        "--vlos-radius", help="VLOS radius around the pilot (m); 0: no check. Default 500, none for a walked route")] = None,
    ground_station: StationOpt = None,
    aircraft: Annotated[str | None, typer.Option(
        help="Aircraft or rover preset, a JSON file, or 'none'. Default p4p, walker-360 for a walked route")] = None,
    altitude_limit: Annotated[float | None, typer.Option(
        "--altitude-limit", help="FAA §107.51 limit (m); 0: no check. Default 120, none for a walked route")] = None,
    min_height: MinHeightOpt = None,
    position_error: PositionErrorOpt = None,
    ground_z: GroundZOpt = None,
    split: Annotated[bool, typer.Option(help="Split the missions to keep line of sight and fit the batteries "
                                             "(write the result with -o)")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write the (split) plan here")] = None,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write every waypoint's and mission's result as JSON")] = None,
    camera: Annotated[str | None, typer.Option(
        help="Camera of a poses CSV or a flight-app mission: " + CAMERA_FORMS)] = None,
    focal_mm: FocalOpt = None,
    date: DateOpt = None,
    schedule: ScheduleOpt = None,
    rules: RulesOpt = None,
    reality: RealityOpt = None,
    prefer_actual: ActualOpt = False,
    date_basis: BasisOpt = "finish",
    unscheduled: UnscheduledOpt = "present",
    cache: Annotated[bool, typer.Option(help="Reuse the model cache")] = True,
) -> None:
    """Check that a plan can be flown: safety distance, line of sight, altitude limit, minimum height and batteries.

    Exits with status 1 when a check fails, so scripts can stop on it."""
    from ..plan.checks.feasibility import check_plan, plan_flights
    from ..plan.checks.gate import walked as walked_plan
    from ..plan.format import write_plan
    from ..plan.load import load_plan

    if json_out is not None:
        writable_file(json_out, "--json")  # before the checks run, not after
    scene, _ = load_with_progress(console, model, cache)
    scene = with_ground_z(dated_scene(console, scene, model, schedule, rules, prefer_actual, date, date_basis,
                                      unscheduled), ground_z)
    scene = with_reality(console, scene, reality)
    plan = load_plan(plan_file, camera=cli_camera(camera, focal_mm), **georef_kwargs(scene))
    refuse_if_far(scene, plan)
    print_warnings(console, plan.parameters.get("warnings", []))
    walked = walked_plan(plan)  # a rover or a walker: no sight line, no altitude limit
    settings = default_flight_settings(walked, safety_distance, vlos_radius, ground_station, aircraft, altitude_limit,
                                       drone_safety_m=5.0, min_height=min_height, position_error=position_error,
                                       scene=scene, georeference=plan.parameters.get("georeference"))
    report = (plan_flights if split else check_plan)(scene, plan, settings)
    print_feasibility(console, report, f"{Path(plan_file).name} against {Path(str(model)).name}")
    if output is not None:
        from ..plan.checks.gate import record_checks

        write_plan(record_checks(with_site(report.plan, scene, replace_takeoff=True), report, settings), output)
        console.print(f"wrote {output}")
    if json_out is not None:
        json_out.write_text(json.dumps(report.to_dict(), indent=1), encoding="utf-8")
        console.print(f"wrote {json_out}")
    if not report.ok:
        raise typer.Exit(1)
