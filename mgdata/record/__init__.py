"""Episode records and the LeRobot v3.0 datasets they are written to.

- :mod:`~mgdata.record.episode`: the recorder-sink contract (DatasetSchema, Frame, EpisodeMeta, EpisodeSink).
- :mod:`~mgdata.record.writer`: :class:`DatasetWriter` (create / open to resume / append, crash-safe commits);
  :mod:`~mgdata.record.staging`: :class:`EpisodeStager` for parallel workers.
- :mod:`~mgdata.record.reader`: :class:`DatasetReader` (episodes, labels, metadata, decoded frames; no torch).
- :mod:`~mgdata.record.physics`, :mod:`~mgdata.record.scenes`: what makes a dataset self-contained (the
  per-frame MuJoCo state and the compiled scenes).
- :mod:`~mgdata.record.validate`: ``mgdata validate`` (structure, counts, stats, checksums, and the audit
  of what the gate promised, :mod:`~mgdata.record.audit`).
- :mod:`~mgdata.record.views`, :mod:`~mgdata.record.export_v21`: loader views and the v2.1 export.
- :mod:`~mgdata.record.card`: the dataset card (``README.md``, the Hub's page) every writer keeps current.
- :mod:`~mgdata.record.layout`: the on-disk format; ``docs/dataset-format.md`` describes it in full.

Submodules are imported explicitly (nothing heavy is imported here).
"""
