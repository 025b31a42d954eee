"""The model file formats sightplan reads, by extension."""

IFC_EXTENSIONS: tuple[str, ...] = (".ifc", ".ifczip")
MESH_EXTENSIONS: tuple[str, ...] = (".obj", ".ply", ".stl", ".gltf", ".glb")
POINT_CLOUD_EXTENSIONS: tuple[str, ...] = (".las", ".laz")  # and .ply files without faces
SUPPORTED_EXTENSIONS: tuple[str, ...] = IFC_EXTENSIONS + MESH_EXTENSIONS + POINT_CLOUD_EXTENSIONS
