"""A user's own objects (docs/objects.md): ``mgdata objects import`` turns a textured mesh file into an object
entry (:mod:`mgdata.sim.assets.entries`) and its checked grasps (:mod:`mgdata.grasps`); ``objects list``."""
