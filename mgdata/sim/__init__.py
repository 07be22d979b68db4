"""Layer 1 simulation primitives (see docs/sim.md).

``config`` (``recipes/sim.toml``: physics, gripper, cameras), ``robot`` (Panda model and constants),
``assets`` (procedural object library), ``world`` + ``scene`` (TaskSpec -> Scene), ``cameras`` + ``renderer``
(CameraRig), ``predicates`` + ``labelling`` (the labelling function L), ``engagement``, ``controller`` (20 Hz
joint-position actions), ``particles`` (liquid, dust), ``geometry``, ``meshcache`` and ``collision``
(decimation and convex-decomposition caches).
"""
