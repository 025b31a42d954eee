"""The file formats sightplan reads and writes, one module each: its constants, its reader (if any), its writer
(if any) and one ``FORMAT`` record (:class:`~.base.FlightFormat`) naming them. :mod:`.registry` finds every
module that declares a ``FORMAT``; :func:`sightplan.plan.load.load_plan`, :func:`sightplan.export.export_plan`,
the command line and the web API read the registry. Adding a format is adding a module here (and its tests).

- flight apps: :mod:`.qgc` (QGroundControl ``.plan``), :mod:`.wpl` (QGC WPL 110), :mod:`.wpml` (DJI WPML
  ``.kmz``), :mod:`.litchi` (Litchi CSV, written only);
- maps (written only): :mod:`.kml`, :mod:`.geojson`;
- poses of a flown capture (read only): :mod:`.sightplan` (sightplan's JSON plan), :mod:`.opensfm`,
  :mod:`.colmap`, :mod:`.csv`;
- shared: :mod:`.base` (the record), :mod:`.flight` (a plan as flight waypoints: what every writer starts from),
  :mod:`.reading` (what the flight-app readers share), :mod:`.mavlink` (MAVLink numbers and missions, for
  ``qgc`` and ``wpl``).
"""
