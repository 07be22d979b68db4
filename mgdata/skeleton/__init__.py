"""The skeleton authoring API (Layer 2 as a family sees it): :class:`FamilySkeleton` and its registry, the
:class:`Context` an attempt runs in, :class:`MotionSegment` and its constructors, guard conditions, the shared
pick-and-carry motion and the per-attempt variation draws."""
