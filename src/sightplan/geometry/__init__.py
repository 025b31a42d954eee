"""Geometry below the plans and the engines, each convention stated once:

- :mod:`.poses`: the world frame, camera axes, gimbal angles and quaternions;
- :mod:`.axes`: Z up (scenes) and Y up (glTF, the viewers);
- :mod:`.distance`: exact point/segment–triangle distances (flight clearance, validation);
- :mod:`.glb`: binary glTF written directly.

Ray queries against a scene are the engines' public API (:meth:`sightplan.engines.base.Engine.hits_from`,
``pixel_directions``, ``unoccluded_rays``).
"""
