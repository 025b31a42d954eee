"""sightplan: create and evaluate reality capture plans against 4D building models."""

__version__ = "0.1.0"
