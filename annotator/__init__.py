"""The browser grasp annotator (``mgdata annotate``): a viser app over the asset library and the grasp DB
with live reachability and collision feedback. See ``docs/annotator.md``."""
