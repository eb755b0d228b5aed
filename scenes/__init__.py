"""Scene model, built-in archetype scenes and file loaders."""
from scenes.model import Environment, Light, Material, Scene, View  # noqa: F401
