"""Replay benchmark: every default template plan exported for PX4 and ArduPilot, each mission replayed under its
autopilot's rules (sightplan.flight), on the bundled Duplex and on the Schependomlaan steel structure.

    python benchmarks/replay.py [--models steel duplex]

Prints and writes (benchmarks/replay.json) per model, template and autopilot: frames, missions, the largest
deviation of a photo from its frame (m, °), the photos taken while the gimbal moved, the longest mission from
take-off to landing in the replay against the flight checks' own estimate of it (minutes, at the export's 5 m/s and
the aircraft's cruise speed respectively), and the replay's processor time per photo.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
STEEL = HERE.parent.parent / "shared" / "data" / "schependomlaan" / "BERNTS-Staalconstructie.ifc"
TEMPLATES = (("facade", {}), ("orbit", {}), ("lawnmower", {"oblique_pitch_deg": -60.0}))


def main(argv: list[str] | None = None) -> int:
    import numpy as np

    from sightplan.camera.catalogue import get_camera
    from sightplan.flight.fidelity import flight_fidelity
    from sightplan.formats.flight import build_flight
    from sightplan.geo import Georeference
    from sightplan.model.load import load_model
    from sightplan.plan.checks.feasibility import FlightSettings
    from sightplan.plan.templates.registry import plan_from_template

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", nargs="+", default=["steel", "duplex"], choices=["steel", "duplex"])
    ap.add_argument("--out", default=str(HERE / "replay.json"))
    args = ap.parse_args(argv)
    rows = []
    for name in args.models:
        path = "sample" if name == "duplex" else str(STEEL)
        scene = load_model(path)[0]
        geo = Georeference.from_scene_metadata(scene.metadata)
        if geo is None:  # the steel structure has no georeference of its own: a site origin, as --origin gives
            geo = Georeference.from_origin(52.0, 5.0, 0.0, source="benchmark origin")
        for template, params in TEMPLATES:
            plan, report = plan_from_template(template, scene, get_camera("p4p"), params, FlightSettings())
            flight = build_flight(plan, geo, np.asarray(plan.parameters["takeoff_m"], float), fmt="qgc")
            for autopilot in ("px4", "ardupilot"):
                cpu = time.process_time()
                f = flight_fidelity(flight, autopilot)
                cpu = time.process_time() - cpu
                row = {"model": name, "triangles": len(scene.faces), "template": template, "autopilot": autopilot,
                       "frames": len(plan), "missions": len(plan.missions), "largest_deviation_m": round(f.position_m, 3),
                       "largest_deviation_deg": round(f.angle_deg, 2), "gimbal_moving": f.gimbal_moving,
                       "longest_mission_replay_min": round(max(f.mission_times_s) / 60, 2),
                       "longest_mission_check_min": round(max(m.time_s for m in report.missions) / 60, 2),
                       "replay_cpu_s": round(cpu, 3), "replay_ms_per_photo": round(1000 * cpu / max(f.taken, 1), 2)}
                rows.append(row)
                print(json.dumps(row), flush=True)
    Path(args.out).write_text(json.dumps(rows, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
