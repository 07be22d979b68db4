"""The skeleton authoring API (Layer 2 as a family sees it): :class:`FamilySkeleton` and its registry, the
:class:`Context` an attempt runs in, :class:`MotionSegment` and its constructors, guard conditions, the shared
pick-and-carry motion and the per-attempt variation draws.

The generic idioms family skeletons share, one concept per module:

==================  ==========================================================================================
``poses``           backing off along the approach axis, straight up, yaw about the vertical, rotation about
                    an axis, the held object's pose in the TCP frame
``grasp_choice``    this attempt's grasp from the gate's facts (round-robin by the draw)
``candidates``      the first reachable candidate (its IK solution seeds ``ctx.q_hints``)
``whatif``          what-if state: the planner's copy changed (or the live scene, restored), checks inside
``spots``           free spots to set something down (grids, rings, clearance, the put-down lines)
``reach``           reach tests: a straight-down hand, the arm's path through poses, a grasp's reach
``articulation``    a slide (a drawer) driven by its handle: poses, what is in its way, drivable grasps, the
                    drive's segments and arm path
``opening``         lowering a held object into a rectangular opening (a pulled-out drawer)
``pick_place``      a tagged pick (open … lift) and place (lower, release, retreat), as segments
``relocate``        moving an object out of the way onto a free spot
``pile``            a stack taken off top first onto a pile beside it (the spot, the place poses)
``wipe``            wiping a patch off a tray's floor with a held tool (its recipe keys)
``pour``            pouring from a held carrier into a tray (its recipe keys)
``carrier``         picking the carrier a pour starts from (grasps clear of the food, on its pouring side)
``task_rng``        task-seeded random streams by name (``ctx.task_rng(name)``)
==================  ==========================================================================================
"""
