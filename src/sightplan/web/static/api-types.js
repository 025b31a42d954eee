// The request and response types of sightplan's REST API, generated from its OpenAPI document by
// `python -m sightplan.web.jstypes`; do not edit by hand. Modules name them in JSDoc comments, e.g.
//   /** @param {import('./api-types.js').PlanOut} plan */


/**
 * @typedef {object} BasemapOut
 * @property {string} url XYZ tile URL template ({z}, {x}, {y} or {-y})
 * @property {string} attribution The credit to show on the map
 */

/**
 * @typedef {object} BestFrameOut
 * @property {number} frame Frame
 * @property {string} name Name
 * @property {number} pixels Pixels of the element in the frame
 * @property {number} ssd_m_per_px Ssd M Per Px
 * @property {number} angle_deg Angle Deg
 * @property {number} depth_m Depth M
 * @property {boolean} counts Whether the frame sees the element by ≥ Ω px
 */

/**
 * @typedef {object} Body_add_schedule_api_projects__project_id__schedules_post
 * @property {number} model_id The project's model the schedule builds
 * @property {(string|null)} [file] The schedule; none: the model's own IfcWorkSchedule
 * @property {(string|null)} [rules] TOML link rules
 * @property {boolean} [prefer_actual] Actual dates win over planned ones
 */

/**
 * @typedef {object} Body_upload_basemap_api_projects__project_id__basemap_post
 * @property {string} file GeoTIFF orthomosaic or MBTiles
 */

/**
 * @typedef {object} Body_upload_model_api_projects__project_id__models_post
 * @property {string} file IFC (.ifc, .ifczip) or mesh (.obj, .ply, .stl, .gltf, .glb) file
 */

/**
 * @typedef {object} Body_upload_plan_api_projects__project_id__plans_upload_post
 * @property {string} file The plan file
 * @property {string} [name] Default: the file's name
 * @property {(number|null)} [model_id] The project's model the plan is for
 * @property {(string|null)} [camera] Camera of a poses CSV or a flight-app mission
 */

/**
 * @typedef {object} Body_upload_reality_api_projects__project_id__reality_post
 * @property {string} file The capture
 */

/**
 * A plan from the bridge template (passes along an axis).
 * @typedef {object} BridgePlanIn
 * @property {(string|null)} [aircraft] Aircraft preset (p4p, m3e, m300), rover preset for a route (walker-360, spot, tracked), or 'none' for no battery check. Default p4p, walker-360 for a route
 * @property {(number|null)} [vlos_radius_m] Visual line-of-sight radius around the pilot (m); 0: no check. Default 500, none for a route
 * @property {Array<Array<number>>} [ground_station] Pilot positions [x, y, z] to choose from (default: the corners of the plan's region)
 * @property {Array<Array<number>>} [ground_station_geo] Pilot positions [latitude, longitude] (WGS 84 degrees), placed on the ground of the model's georeference, 1.5 m up; with ground_station, candidates to choose from
 * @property {(string|null)} [position_error] How far the aircraft may stray from its planned point: 'gnss' (±1.5 m horizontal, ±0.5 m vertical), 'rtk' (±0.1 m), 'none' or 'H,V' metres. The checks hold at its worst and the frames are placed by it. Default: the aircraft's
 * @property {(number|null)} [altitude_limit_m] Altitude limit (m); 0: no check. Default 120, none for a route
 * @property {(number|null)} [min_height_m] Least height of a waypoint above the ground under it (m). Default 2, none for a route
 * @property {string} [name] Default: the template's name
 * @property {number} model_id Model Id
 * @property {string} [camera] A camera of the catalogue (GET /api/cameras)
 * @property {(number|null)} [safety_distance_m] Distance to the model the facade and bridge templates keep (m); also the flight check's least distance. Default 10, 0.3 for a route
 * @property {boolean} [split] Split into missions that keep line of sight and fit a battery
 * @property {'bridge'} template passes along an axis
 * @property {Array<Array<number>>} [axis] points [x, y] of the axis, in order
 * @property {number} [overlap] image overlap l between neighbouring frames
 * @property {Array<number>} [height_m] height of a side pass, once per pass (default: layers by overlap) (m)
 * @property {boolean} [under_deck] add a pass under the deck, looking up
 * @property {(number|null)} [deck_z_m] height of the deck's underside (default: found) (m)
 */

/**
 * @typedef {object} CameraOut
 * @property {string} id Id
 * @property {string} name Name
 * @property {'pinhole'|'equirectangular'} model Model
 * @property {number} width Width
 * @property {number} height Height
 */

/**
 * @typedef {object} ElementDetailOut
 * @property {number} evaluation_id Evaluation Id
 * @property {ElementRowOut} element
 * @property {boolean} target Target
 * @property {number} omega_px Omega Px
 * @property {Array<BestFrameOut>} best_frames Best Frames
 */

/**
 * An element's row of the per-element metrics (the columns of elements.csv); null values for an occluder.
 * @typedef {object} ElementRowOut
 * @property {number} index Index
 * @property {string} global_id Global Id
 * @property {string} name Name
 * @property {string} ifc_class Ifc Class
 * @property {string} storey Storey
 * @property {string} visibility Visibility
 * @property {(number|null)} VR_i Vr I
 * @property {(number|null)} R_i_m_per_px R I M Per Px
 * @property {(number|null)} O_i_deg O I Deg
 * @property {(number|null)} frames_observed Frames Observed
 * @property {(number|null)} pixels_total Pixels Total
 */

/**
 * A model's element table, one list per column, indexed by element.
 * @typedef {object} ElementTableOut
 * @property {number} model_id Model Id
 * @property {number} count Number of elements
 * @property {Array<string>} global_id Global Id
 * @property {Array<string>} name Name
 * @property {Array<string>} ifc_class Ifc Class
 * @property {Array<string>} discipline Discipline
 * @property {Array<string>} storey Storey
 * @property {Array<boolean>} target Whether the element counts in the metrics (else an occluder)
 * @property {Array<number>} triangles Triangles of each element
 */

/**
 * @typedef {object} ElementsOut
 * @property {number} evaluation_id Evaluation Id
 * @property {Array<Object<string, *>>} elements One row per target element, the columns of elements.csv
 */

/**
 * Every error answer: one message, and with an export refused for its flight checks the violations.
 * @typedef {object} ErrorOut
 * @property {string} detail One readable message
 * @property {Array<string>} [violations] An export refused for its flight checks (409): each violation; absent otherwise
 */

/**
 * @typedef {object} EvaluationIn
 * @property {number} plan_id Plan Id
 * @property {(number|null)} [version] Default: the plan's latest version
 * @property {(number|null)} [model_id] Default: the plan's model
 * @property {SettingsIn} [settings]
 * @property {(string|null)} [date] Capture date YYYY-MM-DD: only the elements built by the end of it exist (needs a linked schedule)
 * @property {(number|null)} [schedule_id] Schedule dating the elements (default: the model's latest)
 * @property {'finish'|'start'} [date_basis] Which schedule date builds an element
 * @property {'present'|'absent'} [unscheduled] Elements no schedule dates
 * @property {(number|null)} [reality_id] A reality capture of the site (scaffolding, neighbours, what stands): it hides what is behind it, and is not scored
 * @property {('px4'|'ardupilot'|null)} [as_flown] Evaluate the photos where this autopilot takes them: the version's MAVLink export replayed under its rules (as `sightplan evaluate --as-flown`)
 * @property {(string|null)} [position_error] Also evaluate draws with every frame moved by a normal error whose 95 % bounds are 'H,V' metres (and ',YAW' degrees), or 'gnss' / 'rtk' (as `sightplan evaluate --position-error`): each metric's 5th-95th percentile band goes into metrics.robustness
 * @property {(number|null)} [draws] With position_error: the number of draws (default 32)
 */

/**
 * @typedef {object} EvaluationOut
 * @property {number} id Id
 * @property {number} project_id Project Id
 * @property {number} plan_id Plan Id
 * @property {number} plan_version Plan Version
 * @property {number} model_id Model Id
 * @property {'queued'|'running'|'done'|'failed'} status Status
 * @property {number} progress_done Progress Done
 * @property {number} progress_total Progress Total
 * @property {Object<string, *>} settings Settings
 * @property {(Object<string, *>|null)} metrics The plan metrics (as report.json's 'metrics') once done
 * @property {(string|null)} error Error
 * @property {string} created_at Created At
 * @property {(string|null)} started_at Started At
 * @property {(string|null)} finished_at Finished At
 */

/**
 * @typedef {object} EvaluationStartOut
 * @property {EvaluationOut} evaluation
 * @property {JobOut} job
 */

/**
 * A plan from the facade template (grids around the sides).
 * @typedef {object} FacadePlanIn
 * @property {(string|null)} [aircraft] Aircraft preset (p4p, m3e, m300), rover preset for a route (walker-360, spot, tracked), or 'none' for no battery check. Default p4p, walker-360 for a route
 * @property {(number|null)} [vlos_radius_m] Visual line-of-sight radius around the pilot (m); 0: no check. Default 500, none for a route
 * @property {Array<Array<number>>} [ground_station] Pilot positions [x, y, z] to choose from (default: the corners of the plan's region)
 * @property {Array<Array<number>>} [ground_station_geo] Pilot positions [latitude, longitude] (WGS 84 degrees), placed on the ground of the model's georeference, 1.5 m up; with ground_station, candidates to choose from
 * @property {(string|null)} [position_error] How far the aircraft may stray from its planned point: 'gnss' (±1.5 m horizontal, ±0.5 m vertical), 'rtk' (±0.1 m), 'none' or 'H,V' metres. The checks hold at its worst and the frames are placed by it. Default: the aircraft's
 * @property {(number|null)} [altitude_limit_m] Altitude limit (m); 0: no check. Default 120, none for a route
 * @property {(number|null)} [min_height_m] Least height of a waypoint above the ground under it (m). Default 2, none for a route
 * @property {string} [name] Default: the template's name
 * @property {number} model_id Model Id
 * @property {string} [camera] A camera of the catalogue (GET /api/cameras)
 * @property {(number|null)} [safety_distance_m] Distance to the model the facade and bridge templates keep (m); also the flight check's least distance. Default 10, 0.3 for a route
 * @property {boolean} [split] Split into missions that keep line of sight and fit a battery
 * @property {'facade'} template grids around the sides
 * @property {number} [overlap] image overlap l between neighbouring frames
 * @property {'box'|'outline'} [footprint] grids on the sides of the bounding 'box', or around the model's real 'outline'
 */

/**
 * @typedef {object} FeedbackColoursOut
 * @property {Array<string>} gradient Traffic-light gradient, worst to best, as #rrggbb
 * @property {string} unseen Unseen
 * @property {string} occluder Occluder
 * @property {Array<string>} classes Classes
 * @property {Array<Array<number>>} gradient_rgb The same colours as sRGB floats 0–1
 * @property {Array<number>} unseen_rgb Unseen Rgb
 * @property {Array<number>} occluder_rgb Occluder Rgb
 * @property {Array<Array<number>>} classes_rgb Classes Rgb
 */

/**
 * @typedef {object} FeedbackElementsOut
 * @property {Array<string>} global_id Global Id
 * @property {Array<string>} name Name
 * @property {Array<string>} ifc_class Ifc Class
 * @property {Array<string>} storey Storey
 * @property {Array<boolean>} target Target
 */

/**
 * @typedef {object} FeedbackFramesOut
 * @property {Array<string>} name Name
 * @property {Array<number>} nu ν_f: the frame's stability (share of its features on stable tracks)
 * @property {Array<boolean>} stable ν_f ≥ Λ
 * @property {Array<number>} features_observed Features Observed
 * @property {Array<number>} elements_visible Elements Visible
 * @property {Array<(number|null)>} pixels_on_targets Pixels On Targets
 */

/**
 * @typedef {object} FeedbackMetricsOut
 * @property {Array<number>} visibility 0 visible (≥ Ω px), 1 observed only, 2 unseen, 3 occluder
 * @property {Array<(number|null)>} vr VR_i: frames that see the element by ≥ Ω px
 * @property {Array<(number|null)>} ssd R_i: surface sampling distance (m/px)
 * @property {Array<(number|null)>} orientation O_i: mean angle to the surface (°)
 * @property {Array<number>} frames_observed Frames Observed
 * @property {Array<(number|null)>} pixels_total Pixels on the element over all frames
 */

/**
 * @typedef {object} FeedbackMissionOut
 * @property {string} name Name
 * @property {number} start Start
 * @property {number} stop Stop
 */

/**
 * Everything the viewer colours from: per-element and per-frame values of an evaluation.
 * @typedef {object} FeedbackOut
 * @property {string} colour_by Colour By
 * @property {FeedbackElementsOut} elements
 * @property {FeedbackMetricsOut} metrics
 * @property {Object<string, MetricLabelOut>} labels Per colour metric: label, unit, direction, bounds
 * @property {FeedbackColoursOut} colours
 * @property {Array<Array<number>>} cameras Camera centres in the viewer's frame (Y up, m)
 * @property {FeedbackFramesOut} frames
 * @property {FeedbackParamsOut} params
 * @property {Object<string, Object<string, string>>} [metric_help] What each metric means with this evaluation's thresholds (Ω, k, Y, Λ): label, unit and one sentence
 * @property {(Object<string, *>|null)} plan_metrics The plan metrics, as report.json's 'metrics'
 * @property {Array<FeedbackMissionOut>} missions Missions
 * @property {number} evaluation_id Evaluation Id
 * @property {number} plan_id Plan Id
 * @property {number} plan_version Plan Version
 * @property {(number|null)} model_id Model Id
 */

/**
 * @typedef {object} FeedbackParamsOut
 * @property {number} omega Visibility threshold Ω (px)
 * @property {number} k K
 * @property {number} min_track Min Track
 * @property {number} min_features Min Features
 */

/**
 * The flight checks of a plan version's missions as they are, for drawing.
 * @typedef {object} FlightChecksOut
 * @property {number} plan_id Plan Id
 * @property {number} version Version
 * @property {number} model_id Model Id
 * @property {boolean} ok Every check passed
 * @property {number} safety_distance_m Safety Distance M
 * @property {(number|null)} vlos_radius_m Vlos Radius M
 * @property {(number|null)} total_time_s Flight time of all missions (s)
 * @property {Array<(number|null)>} clearance_m Each waypoint's distance to the model (m)
 * @property {Array<(number|null)>} segment_clearance_m Each leg's distance to the model (m)
 * @property {Array<number>} unsafe_frames Waypoints closer than the safety distance
 * @property {Array<number>} unsafe_segments Legs closer than the safety distance
 * @property {Array<boolean>} in_sight Each waypoint within the VLOS radius of its mission's ground station
 * @property {Array<Object<string, *>>} missions Per mission: ground station, time, distance and verdicts, as `sightplan check --json`
 * @property {Array<string>} violations Every violation, one sentence each
 * @property {(Object<string, *>|null)} [ground] The site's ground the checks used: its level (model frame, m), where it comes from and why
 * @property {Array<number>} [position_error_m] The position error the checks hold at: horizontal, vertical (m)
 * @property {Array<Object<string, *>>} [trajectory] Per mission: its take-off point, climb and return heights, and the checked flight out (take-off, climb, over the first waypoint, the first waypoint) and home (the last waypoint, up, over the take-off, landing) as [x, y, z] polylines (model frame, m)
 */

/**
 * @typedef {object} InfoOut
 * @property {string} [name] Name
 * @property {string} version Version
 * @property {'single-user'|'team'} [mode] Mode
 * @property {boolean} [login] Whether requests need a login (never in single-user mode, always in team mode)
 * @property {string} message Message
 * @property {string} database 'embedded SQLite' or the database's dialect
 * @property {string} data_dir Data Dir
 * @property {number} max_upload_bytes Max Upload Bytes
 * @property {Array<string>} templates Templates
 * @property {Array<string>} export_formats Export Formats
 * @property {Object<string, string>} [export_format_help] What each export format is for: name → a few words (the page's menu)
 * @property {Object<string, Object<string, string>>} [metric_help] What each metric means (label, unit, one sentence with the default thresholds): the page's labels
 * @property {Object<string, string>} [aircraft] Aircraft and rover presets of the plan form: id → name
 * @property {(BasemapOut|null)} [basemap] The map's background tiles set by whoever runs the server; none: a plain grid
 */

/**
 * @typedef {object} JobOut
 * @property {number} id Id
 * @property {number} project_id Project Id
 * @property {'load_model'|'evaluate'|'link_schedule'|'prep_reality'|'optimize'} kind Kind
 * @property {(number|null)} model_id Model Id
 * @property {(number|null)} evaluation_id Evaluation Id
 * @property {(number|null)} [plan_id] The plan an optimisation made, once done
 * @property {(number|null)} [schedule_id] Schedule Id
 * @property {(number|null)} [reality_id] Reality Id
 * @property {'queued'|'running'|'done'|'failed'} status Status
 * @property {number} progress_done Progress Done
 * @property {number} progress_total Progress Total
 * @property {string} message Message
 * @property {(string|null)} error Error
 * @property {string} created_at Created At
 * @property {(string|null)} started_at Started At
 * @property {(string|null)} finished_at Finished At
 */

/**
 * lat, lon = origin_lat_lon + matrix · ([x, y] − origin_xy), within max_error_m of the exact transform.
 * @typedef {object} LatLonFitOut
 * @property {Array<number>} origin_xy Model x, y (m) the fit is centred on
 * @property {Array<number>} origin_lat_lon Latitude, longitude (°) there
 * @property {Array<Array<number>>} matrix [[dlat/dx, dlat/dy], [dlon/dx, dlon/dy]] (° per m)
 * @property {number} max_error_m Largest distance between the fit and the exact transform over the site (m)
 */

/**
 * A plan from the lawnmower template (nadir grid).
 * @typedef {object} LawnmowerPlanIn
 * @property {(string|null)} [aircraft] Aircraft preset (p4p, m3e, m300), rover preset for a route (walker-360, spot, tracked), or 'none' for no battery check. Default p4p, walker-360 for a route
 * @property {(number|null)} [vlos_radius_m] Visual line-of-sight radius around the pilot (m); 0: no check. Default 500, none for a route
 * @property {Array<Array<number>>} [ground_station] Pilot positions [x, y, z] to choose from (default: the corners of the plan's region)
 * @property {Array<Array<number>>} [ground_station_geo] Pilot positions [latitude, longitude] (WGS 84 degrees), placed on the ground of the model's georeference, 1.5 m up; with ground_station, candidates to choose from
 * @property {(string|null)} [position_error] How far the aircraft may stray from its planned point: 'gnss' (±1.5 m horizontal, ±0.5 m vertical), 'rtk' (±0.1 m), 'none' or 'H,V' metres. The checks hold at its worst and the frames are placed by it. Default: the aircraft's
 * @property {(number|null)} [altitude_limit_m] Altitude limit (m); 0: no check. Default 120, none for a route
 * @property {(number|null)} [min_height_m] Least height of a waypoint above the ground under it (m). Default 2, none for a route
 * @property {string} [name] Default: the template's name
 * @property {number} model_id Model Id
 * @property {string} [camera] A camera of the catalogue (GET /api/cameras)
 * @property {(number|null)} [safety_distance_m] Distance to the model the facade and bridge templates keep (m); also the flight check's least distance. Default 10, 0.3 for a route
 * @property {boolean} [split] Split into missions that keep line of sight and fit a battery
 * @property {'lawnmower'} template nadir grid
 * @property {number} [overlap] image overlap along a line
 * @property {(number|null)} [altitude_m] camera height above the model's base (default: the safety distance above its top) (m)
 * @property {(number|null)} [gsd_m_px] ground sampling distance on the model's top (instead of the altitude) (m/px)
 * @property {number} [side_overlap] overlap between lines
 * @property {(number|null)} [oblique_pitch_deg] add crossed east–west lines with the gimbal at this pitch (e.g. -60): a double grid (°)
 */

/**
 * @typedef {object} LoginIn
 * @property {string} username Username
 * @property {string} password Password
 */

/**
 * @typedef {object} MemberIn
 * @property {string} username Username
 * @property {'viewer'|'editor'|'owner'} role Role
 */

/**
 * @typedef {object} MemberOut
 * @property {number} user_id User Id
 * @property {string} username Username
 * @property {'viewer'|'editor'|'owner'} role Role
 */

/**
 * @typedef {object} MetricLabelOut
 * @property {string} label Label
 * @property {string} unit Unit
 * @property {boolean} higher_better Higher Better
 * @property {(Array<number>|null)} bounds Default colour bounds [low, high] in the metric's unit
 * @property {(Array<string>|null)} [classes] Classes
 */

/**
 * @typedef {object} MissionGeometryOut
 * @property {string} name Name
 * @property {number} start First frame (index)
 * @property {number} stop One past the last frame
 * @property {(Array<number>|null)} ground_station Pilot position [x, y, z] (model frame, m), if chosen
 */

/**
 * @typedef {object} ModelDetailOut
 * @property {number} id Id
 * @property {number} project_id Project Id
 * @property {string} original_name The uploaded file's name, kept as metadata only
 * @property {number} size_bytes Size Bytes
 * @property {'queued'|'loading'|'ready'|'failed'} status Status
 * @property {(string|null)} error Error
 * @property {(number|null)} elements Elements
 * @property {(number|null)} targets Targets
 * @property {(number|null)} triangles Triangles
 * @property {(number|null)} skipped Products without usable geometry (see load_report)
 * @property {(boolean|null)} georeferenced Georeferenced
 * @property {string} created_at Created At
 * @property {(Object<string, *>|null)} load_report Load Report
 */

/**
 * @typedef {object} ModelOut
 * @property {number} id Id
 * @property {number} project_id Project Id
 * @property {string} original_name The uploaded file's name, kept as metadata only
 * @property {number} size_bytes Size Bytes
 * @property {'queued'|'loading'|'ready'|'failed'} status Status
 * @property {(string|null)} error Error
 * @property {(number|null)} elements Elements
 * @property {(number|null)} targets Targets
 * @property {(number|null)} triangles Triangles
 * @property {(number|null)} skipped Products without usable geometry (see load_report)
 * @property {(boolean|null)} georeferenced Georeferenced
 * @property {string} created_at Created At
 */

/**
 * @typedef {object} ModelUploadOut
 * @property {ModelOut} model
 * @property {JobOut} job
 */

/**
 * @typedef {object} NewShareLinkOut
 * @property {number} id Id
 * @property {number} plan_id Plan Id
 * @property {string} created_at Created At
 * @property {(string|null)} revoked_at Revoked At
 * @property {string} token The link's secret, shown once
 * @property {string} url The share view: a read-only page of the plan (its model, map, metrics, feedback and checks), no login needed
 * @property {string} api_url The same plan as JSON (GET), with its versions and evaluations below it
 */

/**
 * @typedef {object} NewTokenOut
 * @property {number} id Id
 * @property {string} name Name
 * @property {string} created_at Created At
 * @property {(string|null)} last_used_at Last Used At
 * @property {string} token The secret: shown once, send it as 'Authorization: Bearer <token>'
 */

/**
 * An optimised plan around one of the project's models (as ``sightplan optimize``): the fewest views that give every target element k serving views (≥ Ω px, SSD and angle within bounds), within a budget, routed and checked.
 * @typedef {object} OptimizeIn
 * @property {(string|null)} [aircraft] Aircraft preset (p4p, m3e, m300), rover preset for a route (walker-360, spot, tracked), or 'none' for no battery check. Default p4p, walker-360 for a route
 * @property {(number|null)} [vlos_radius_m] Visual line-of-sight radius around the pilot (m); 0: no check. Default 500, none for a route
 * @property {Array<Array<number>>} [ground_station] Pilot positions [x, y, z] to choose from (default: the corners of the plan's region)
 * @property {Array<Array<number>>} [ground_station_geo] Pilot positions [latitude, longitude] (WGS 84 degrees), placed on the ground of the model's georeference, 1.5 m up; with ground_station, candidates to choose from
 * @property {(string|null)} [position_error] How far the aircraft may stray from its planned point: 'gnss' (±1.5 m horizontal, ±0.5 m vertical), 'rtk' (±0.1 m), 'none' or 'H,V' metres. The checks hold at its worst and the frames are placed by it. Default: the aircraft's
 * @property {(number|null)} [altitude_limit_m] Altitude limit (m); 0: no check. Default 120, none for a route
 * @property {(number|null)} [min_height_m] Least height of a waypoint above the ground under it (m). Default 2, none for a route
 * @property {string} [name] Default: 'optimised (k = …)'
 * @property {number} model_id Model Id
 * @property {string} [camera] A perspective camera of the catalogue (GET /api/cameras)
 * @property {number} [safety_distance_m] Least distance to the model (m)
 * @property {number} [k] Views each target element needs
 * @property {(number|null)} [max_ssd_m_px] Coarsest surface sampling distance a view may have (m/px); default: the camera's at the safety distance × 1.5
 * @property {number} [max_angle_deg] Widest angle to the surface (°)
 * @property {(number|null)} [budget_frames] At most this many frames
 * @property {(number|null)} [budget_minutes] At most this many minutes of flight
 * @property {(number|null)} [batteries] At most this many battery charges
 * @property {number} [scale] Resolution scale the candidates are cast at
 */

/**
 * A plan from the orbit template (rings).
 * @typedef {object} OrbitPlanIn
 * @property {(string|null)} [aircraft] Aircraft preset (p4p, m3e, m300), rover preset for a route (walker-360, spot, tracked), or 'none' for no battery check. Default p4p, walker-360 for a route
 * @property {(number|null)} [vlos_radius_m] Visual line-of-sight radius around the pilot (m); 0: no check. Default 500, none for a route
 * @property {Array<Array<number>>} [ground_station] Pilot positions [x, y, z] to choose from (default: the corners of the plan's region)
 * @property {Array<Array<number>>} [ground_station_geo] Pilot positions [latitude, longitude] (WGS 84 degrees), placed on the ground of the model's georeference, 1.5 m up; with ground_station, candidates to choose from
 * @property {(string|null)} [position_error] How far the aircraft may stray from its planned point: 'gnss' (±1.5 m horizontal, ±0.5 m vertical), 'rtk' (±0.1 m), 'none' or 'H,V' metres. The checks hold at its worst and the frames are placed by it. Default: the aircraft's
 * @property {(number|null)} [altitude_limit_m] Altitude limit (m); 0: no check. Default 120, none for a route
 * @property {(number|null)} [min_height_m] Least height of a waypoint above the ground under it (m). Default 2, none for a route
 * @property {string} [name] Default: the template's name
 * @property {number} model_id Model Id
 * @property {string} [camera] A camera of the catalogue (GET /api/cameras)
 * @property {(number|null)} [safety_distance_m] Distance to the model the facade and bridge templates keep (m); also the flight check's least distance. Default 10, 0.3 for a route
 * @property {boolean} [split] Split into missions that keep line of sight and fit a battery
 * @property {'orbit'} template rings
 * @property {number} [overlap] image overlap l between neighbouring frames
 * @property {Array<number>} [radius_m] ring radius, once per ring (default: the targets' half-diagonal + the safety distance) (m)
 * @property {Array<number>} [height_m] ring height, once per ring (default: layers by overlap from the minimum height to the safety distance above the top) (m)
 * @property {(number|null)} [step_deg] degrees between frames (default: by overlap) (°)
 * @property {'centre'|'surface'} [aim] aim at the model's 'centre' or its nearest 'surface'
 */

/**
 * @typedef {object} PasswordIn
 * @property {string} old_password Old Password
 * @property {string} new_password New Password
 */

/**
 * @typedef {object} PlanCameraOut
 * @property {'pinhole'|'equirectangular'} model Model
 * @property {string} [name] Name
 * @property {number} width Image width (px)
 * @property {number} height Image height (px)
 * @property {(number|null)} [fx] Focal length (px), pinhole only
 * @property {(number|null)} [fy] Focal length (px), pinhole only
 * @property {(number|null)} [cx] Principal point (px), pinhole only
 * @property {(number|null)} [cy] Principal point (px), pinhole only
 */

/**
 * A plan in sightplan's JSON plan format, version 1 (as ``sightplan plan`` writes it).
 * @typedef {object} PlanFileOut
 * @property {string} format Format
 * @property {number} version Version
 * @property {'m'} units Units
 * @property {string} frame_convention Frame Convention
 * @property {Object<string, PlanCameraOut>} cameras Cameras
 * @property {Array<PlanMissionOut>} missions Missions
 * @property {Array<PlanFrameOut>} frames Frames
 * @property {Array<Array<number>>} waypoints Flight waypoints [x, y, z] (model frame, m)
 * @property {Object<string, *>} parameters The template's settings, the checks, the take-off point; keys carry their unit
 * @property {(Object<string, *>|null)} [georeference] Georeference
 */

/**
 * @typedef {object} PlanFrameOut
 * @property {string} name Name
 * @property {string} camera Id of the frame's camera in 'cameras'
 * @property {Array<number>} position Camera centre [x, y, z] (model frame, m)
 * @property {Array<Array<number>>} rotation World-from-camera rotation, 3 × 3, OpenCV camera axes
 * @property {(number|null)} [time] Capture time (s, POSIX), when known
 */

/**
 * A plan version's frames and missions, in the model's frame (metres, Z up).
 * @typedef {object} PlanGeometryOut
 * @property {number} plan_id Plan Id
 * @property {number} version Version
 * @property {number} frames Number of frames
 * @property {(number|null)} model_id Model Id
 * @property {Array<string>} name Frame names
 * @property {Array<string>} camera Each frame's camera id (a key of `cameras`)
 * @property {Array<Array<number>>} position Camera centres [x, y, z] (m)
 * @property {Array<Array<number>>} rotation R_world_camera per frame, row-major (9 numbers): columns are the camera's right, down and forward axes
 * @property {Object<string, Object<string, *>>} cameras Camera models by id, with hfov_deg and vfov_deg for a pinhole
 * @property {Array<MissionGeometryOut>} missions Missions
 * @property {Array<Array<number>>} waypoints Flight waypoints [x, y, z] (m), when they differ from frames
 * @property {Object<string, *>} parameters The plan's parameters (template settings, checks, take-off)
 * @property {(number|null)} [north_offset_deg] Degrees to add to a model heading (clockwise from model +Y) to get the true heading, at the frames' centre, from the plan's georeference (map grid convergence included); null without one
 */

/**
 * @typedef {object} PlanMissionOut
 * @property {string} name Name
 * @property {Array<number>} frames [start, stop): the mission's frames
 * @property {(Array<number>|null)} [ground_station] Pilot position [x, y, z] (model frame, m)
 */

/**
 * @typedef {object} PlanOut
 * @property {number} id Id
 * @property {number} project_id Project Id
 * @property {(number|null)} model_id Model Id
 * @property {string} name Name
 * @property {string} source Source
 * @property {string} created_at Created At
 * @property {number} latest_version Latest Version
 * @property {Array<PlanVersionOut>} versions Versions
 */

/**
 * @typedef {object} PlanVersionOut
 * @property {number} number Number
 * @property {number} frames Frames
 * @property {number} missions Missions
 * @property {string} note Note
 * @property {string} created_at Created At
 */

/**
 * @typedef {object} ProjectBackgroundOut
 * @property {(ProjectBasemapOut|null)} basemap The project's own map background; null when it has none
 */

/**
 * A project's own map background.
 * @typedef {object} ProjectBasemapOut
 * @property {'image'|'tiles'} kind image: an orthomosaic stretched over its corners; tiles: MBTiles served tile by tile
 * @property {string} name The uploaded file's name (or the MBTiles' own)
 * @property {string} url The image, or the tile URL template ({z}/{x}/{y})
 * @property {(Array<Array<number>>|null)} [corners] image: [lon, lat] of its top-left, top-right, bottom-right and bottom-left corners
 * @property {(number|null)} [width_px] image: the orthomosaic's width (px)
 * @property {(number|null)} [height_px] image: the orthomosaic's height (px)
 * @property {(Array<number>|null)} [bounds] tiles: [west, south, east, north] (°), when the file says
 * @property {(number|null)} [min_zoom] Min Zoom
 * @property {(number|null)} [max_zoom] Max Zoom
 * @property {(string|null)} [format] tiles: png, jpg or webp
 * @property {string} [attribution] Attribution
 */

/**
 * @typedef {object} ProjectIn
 * @property {string} name Name
 */

/**
 * @typedef {object} ProjectOut
 * @property {number} id Id
 * @property {string} name Name
 * @property {string} created_at Created At
 * @property {('viewer'|'editor'|'owner'|null)} [role] Your role (team mode)
 */

/**
 * @typedef {object} RealityOut
 * @property {number} id Id
 * @property {number} project_id Project Id
 * @property {string} name Name
 * @property {'points'|'mesh'} kind Kind
 * @property {number} size_bytes Size Bytes
 * @property {'queued'|'preparing'|'ready'|'failed'} status Status
 * @property {(string|null)} error Error
 * @property {(number|null)} points Points
 * @property {(number|null)} triangles Triangles
 * @property {(Object<string, *>|null)} bounds {"lo": [x, y, z], "hi": [x, y, z]} in the model frame (m)
 * @property {(string|null)} view_url tileset.json of a point cloud, or the GLB of a mesh (glTF's Y up: model (x, y, z) is (x, z, −y))
 * @property {string} created_at Created At
 */

/**
 * @typedef {object} RealityUploadOut
 * @property {RealityOut} reality
 * @property {JobOut} job
 */

/**
 * @typedef {object} RoleIn
 * @property {'viewer'|'editor'|'owner'} role Role
 */

/**
 * A plan from the route template (indoor polyline, walked or driven).
 * @typedef {object} RoutePlanIn
 * @property {(string|null)} [aircraft] Aircraft preset (p4p, m3e, m300), rover preset for a route (walker-360, spot, tracked), or 'none' for no battery check. Default p4p, walker-360 for a route
 * @property {(number|null)} [vlos_radius_m] Visual line-of-sight radius around the pilot (m); 0: no check. Default 500, none for a route
 * @property {Array<Array<number>>} [ground_station] Pilot positions [x, y, z] to choose from (default: the corners of the plan's region)
 * @property {Array<Array<number>>} [ground_station_geo] Pilot positions [latitude, longitude] (WGS 84 degrees), placed on the ground of the model's georeference, 1.5 m up; with ground_station, candidates to choose from
 * @property {(string|null)} [position_error] How far the aircraft may stray from its planned point: 'gnss' (±1.5 m horizontal, ±0.5 m vertical), 'rtk' (±0.1 m), 'none' or 'H,V' metres. The checks hold at its worst and the frames are placed by it. Default: the aircraft's
 * @property {(number|null)} [altitude_limit_m] Altitude limit (m); 0: no check. Default 120, none for a route
 * @property {(number|null)} [min_height_m] Least height of a waypoint above the ground under it (m). Default 2, none for a route
 * @property {string} [name] Default: the template's name
 * @property {number} model_id Model Id
 * @property {string} [camera] A camera of the catalogue (GET /api/cameras)
 * @property {(number|null)} [safety_distance_m] Distance to the model the facade and bridge templates keep (m); also the flight check's least distance. Default 10, 0.3 for a route
 * @property {boolean} [split] Split into missions that keep line of sight and fit a battery
 * @property {'route'} template indoor polyline, walked or driven
 * @property {Array<Array<number>>} [points] points [x, y, z] of the walked polyline, in order
 * @property {(number|null)} [step_m] metres between frames (m)
 */

/**
 * @typedef {object} ScheduleOut
 * @property {number} id Id
 * @property {number} project_id Project Id
 * @property {number} model_id Model Id
 * @property {string} name The uploaded file's name, or 'model' for the model's own IfcWorkSchedule
 * @property {'queued'|'linking'|'ready'|'failed'} status Status
 * @property {(string|null)} error Error
 * @property {boolean} prefer_actual Prefer Actual
 * @property {(string|null)} first_date Earliest start of a linked element (YYYY-MM-DD)
 * @property {(string|null)} last_date Latest finish of a linked element
 * @property {(Object<string, *>|null)} report The link report: lines as `sightplan evaluate --schedule` prints them, tasks, linked, unlinked, targets, dated, warnings
 * @property {string} created_at Created At
 */

/**
 * @typedef {object} ScheduleUploadOut
 * @property {ScheduleOut} schedule
 * @property {JobOut} job
 */

/**
 * Evaluation settings (``sightplan evaluate``'s options of the same names).
 * @typedef {object} SettingsIn
 * @property {'auto'|'embree'|'gl'|'trimesh'} [engine] Engine
 * @property {number} [scale] Resolution scale s
 * @property {number} [omega] Visibility threshold Ω (px)
 * @property {number} [k] K
 * @property {number} [min_track] Min Track
 * @property {number} [min_features] Min Features
 * @property {number} [feature_density] Simulated features per m² of surface
 * @property {number} [seed] Seed
 * @property {number} [d_max] Farthest distance a frame sees (m)
 */

/**
 * @typedef {object} ShareLinkOut
 * @property {number} id Id
 * @property {number} plan_id Plan Id
 * @property {string} created_at Created At
 * @property {(string|null)} revoked_at Revoked At
 */

/**
 * @typedef {object} SharedPlanOut
 * @property {PlanOut} plan
 * @property {Array<EvaluationOut>} evaluations Evaluations
 * @property {(ModelOut|null)} [model] The plan's model, if it has one
 */

/**
 * Where a model stands on the earth, for the map.
 * @typedef {object} SiteOut
 * @property {number} model_id Model Id
 * @property {boolean} georeferenced Whether the model carries its own georeference; if not, the map is drawn about 0° N 0° E with model +Y as north
 * @property {string} source Where the georeference comes from (IfcMapConversion, the site's latitude)
 * @property {string} note Why the model counts as not georeferenced, if it does
 * @property {Array<number>} centre_lat_lon Latitude, longitude (°) of the model's centre
 * @property {number} north_offset_deg True heading of model +Y at the centre (°)
 * @property {Array<Array<number>>} bounds The model's [min, max] corners, model frame (m)
 * @property {Array<Array<Array<number>>>} footprint_xy Outer rings of the footprint, [x, y] (m), closed
 * @property {Array<Array<Array<number>>>} footprint_lat_lon The same rings as [latitude, longitude] (°)
 * @property {LatLonFitOut} to_lat_lon
 */

/**
 * @typedef {object} StatesOut
 * @property {string} date Date
 * @property {number} schedule_id Schedule Id
 * @property {'finish'|'start'} basis Basis
 * @property {Object<string, 'built'|'in_progress'|'not_yet'>} states Each element (by index) at the end of the date
 * @property {Object<string, number>} counts Counts
 */

/**
 * @typedef {object} TemplateFieldOut
 * @property {string} name The request field (its unit in its name: _m, _deg, _m_px)
 * @property {string} label Label
 * @property {string} kind number, numbers, choice, flag, points2 or points3
 * @property {string} unit 'm', '°', 'm/px' or ''
 * @property {string} help Help
 * @property {*} [default] Default
 * @property {(number|null)} [ge] Ge
 * @property {(number|null)} [gt] Gt
 * @property {(number|null)} [le] Le
 * @property {(number|null)} [lt] Lt
 * @property {Array<string>} [choices] Choices
 * @property {string} [pair] Lists with the same pair name go together index by index, one row each (an orbit's ring: radius_m[i] with height_m[i]); '' for none
 */

/**
 * @typedef {object} TemplateOut
 * @property {string} name Name
 * @property {string} summary Summary
 * @property {boolean} walked Walked or driven indoors: no line of sight, altitude limit or minimum height
 * @property {number} safety_distance_m The default least distance to the model (m)
 * @property {Array<TemplateFieldOut>} fields Fields
 */

/**
 * @typedef {object} TokenIn
 * @property {string} [name] What the token is for
 */

/**
 * @typedef {object} TokenOut
 * @property {number} id Id
 * @property {string} name Name
 * @property {string} created_at Created At
 * @property {(string|null)} last_used_at Last Used At
 */

/**
 * @typedef {object} UserOut
 * @property {string} username Username
 * @property {Object<string, 'viewer'|'editor'|'owner'>} [projects] Your role in each project you belong to
 */

export {};
