"""Geometry below the plans and the engines: distances between points, segments and triangles."""
