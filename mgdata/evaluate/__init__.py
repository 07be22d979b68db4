"""Closed-loop policy evaluation on the locked scenarios (docs/eval.md).

``wire`` (openpi's msgpack-numpy encoding), ``server`` / ``client`` (openpi's websocket policy protocol),
``policies`` (the reference policies ``hold``, ``random``, ``replay``), ``conventions`` (observation keys per
model family), ``restore`` (a stored scenario as a live :class:`~mgdata.sim.scene.Scene`), ``rollout`` (one
monitored rollout through :class:`~mgdata.episode.runner.EpisodeRunner`), ``run`` (scenarios × seeds,
resumable, parallel), ``page`` (the HTML results page).
"""
