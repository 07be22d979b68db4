"""The procedural asset library: object models by stable name (``category/model``).

See :mod:`mgdata.sim.assets.model` for the frame and naming conventions and
:mod:`mgdata.sim.assets.library` for the registry.
"""

from mgdata.sim.assets.library import categories, get_model, model_names
from mgdata.sim.assets.model import Articulation, Cavity, Geom, Joint, Link, Mesh, ObjectModel, Particles

__all__ = [
    "Articulation",
    "Cavity",
    "Geom",
    "Joint",
    "Link",
    "Mesh",
    "ObjectModel",
    "Particles",
    "categories",
    "get_model",
    "model_names",
]
