"""MotionSegment: one step of a demonstration, as a family skeleton lists it.

Six kinds, each with only the options it needs:

* ``free``: collision-free joint-space motion (IK for the target, then OMPL + toppra) to ``target``;
* ``linear``: straight TCP line to ``target``, orientation held or slerped;
* ``gripper``: open or close the gripper, arm still, for ``steps`` control steps;
* ``reverse``: replay an earlier segment (``of``) backwards;
* ``hold``: keep the last command for up to ``steps`` steps (the executor stops early once the gate passes);
* ``guarded``: a contact-aware straight TCP line (a world ``direction`` or towards ``target``) that stops when
  the hand (or the held object) touches a body (``until=touch("lid")``) or presses on it with a normal force
  of at least a threshold (``until=force("lid", 5.0)``), never pushing harder than ``max_force``; reaching
  ``max_distance`` first fails the attempt (``guarded_no_contact``) unless ``on_miss="continue"``
  (:mod:`mgdata.engine.guarded`); with ``press=`` it slides in contact along the line, the force regulated
  across it (wiping).

A target is a :class:`~mgdata.motion.types.Pose` of the TCP in the world, or the name of a runtime target
that the skeleton's ``resolve`` computes from the live state when the segment starts. ``allow`` lists the body
pairs that may touch while planning (``("hand", "jar")``); ``attached`` names an object held by the gripper
(it moves with the TCP in collision checks); ``riders`` names objects riding inside the held or approached
object (food in a jar, liquid in a cup): they move with a held object, and the robot may touch them.
``gripper`` is the gripper command sent during the segment.

Example::

    segs = [
        free("pre_grasp", "pre_grasp"),
        linear("approach", "grasp", allow=(("hand", "jar"),)),
        gripper("close", "close", steps=12),
        linear("lift", "lift", gripper="close", attached="jar", allow=(("hand", "jar"), ("jar", "table"))),
        guarded("seat", (0.0, 0.0, -1.0), until=force("table", 5.0), max_distance=0.03, max_force=15.0,
                gripper="close", attached="jar"),
    ]
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from mgdata.motion.types import NO_CONTACTS, AllowedContacts, Pose
from mgdata.skeleton.guard import Guard, Until
from mgdata.skeleton.guard import force as force  # re-exported: skeletons write s.force(...), s.touch(...)
from mgdata.skeleton.guard import touch as touch

SegmentKind = Literal["free", "linear", "gripper", "reverse", "hold", "guarded"]
GripperCommand = Literal["open", "close"]
KINDS: tuple[str, ...] = ("free", "linear", "gripper", "reverse", "hold", "guarded")

Pairs = tuple[tuple[str, str], ...]


@dataclass(frozen=True)
class MotionSegment:
    """One segment; build it with :func:`free`, :func:`linear`, :func:`gripper`, :func:`reverse`,
    :func:`hold` or :func:`guarded`.

    Attributes:
        name: unique within the demonstration (used in failure reports and by ``reverse``).
        kind: one of :data:`KINDS`.
        target: free/linear (and guarded, unless it has a direction): a world TCP pose or a runtime-target
            name.
        gripper: the gripper command during the segment (for ``gripper`` segments: the new command).
        allow: body pairs allowed to be in contact while planning and re-checking.
        attached: body name of an object carried in the gripper during the segment.
        riders: object instances riding inside the held (or approached) object; never obstacles.
        orientation: linear only: ``"hold"`` the start orientation or ``"slerp"`` to the target's.
        of: reverse only: the name of the earlier segment to replay backwards.
        steps: gripper/hold only: control steps.
        speed: free/linear/reverse: fraction (0 … 1] of the planned speed; ``0.5`` takes twice as long and
            quarters the accelerations (e.g. while carrying something that could slip); guarded: the
            fraction of the ``[linear] speed`` cap to approach at.
        guard: guarded only: the direction or distance limit, the stop condition and the force bound.
    """

    name: str
    kind: SegmentKind
    target: Pose | str | None = None
    gripper: GripperCommand = "open"
    allow: AllowedContacts = NO_CONTACTS
    attached: str | None = None
    orientation: Literal["hold", "slerp"] = "hold"
    of: str | None = None
    steps: int = 0
    speed: float = 1.0
    riders: tuple[str, ...] = ()
    guard: Guard | None = None

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"segment {self.name!r}: kind {self.kind!r} is not one of {', '.join(KINDS)}")
        if self.gripper not in ("open", "close"):
            raise ValueError(f"segment {self.name!r}: gripper must be 'open' or 'close' ({self.gripper!r})")
        moving = self.kind in ("free", "linear")
        if self.kind != "guarded" and moving != (self.target is not None):
            raise ValueError(f"segment {self.name!r}: a target is required for free/linear segments only")
        if (self.kind == "guarded") != (self.guard is not None):
            raise ValueError(f"segment {self.name!r}: 'guard' is required for guarded segments only")
        if self.guard is not None and (self.guard.direction is None) == (self.target is None):
            raise ValueError(f"segment {self.name!r}: a guarded segment needs a direction or a target "
                             "(one of them)")
        if (self.kind == "reverse") != (self.of is not None):
            raise ValueError(f"segment {self.name!r}: 'of' is required for reverse segments only")
        if self.kind in ("gripper", "hold") and self.steps < 1:
            raise ValueError(f"segment {self.name!r}: {self.kind} segments need steps >= 1")
        if not 0.0 < self.speed <= 1.0:
            raise ValueError(f"segment {self.name!r}: speed must be in (0, 1], got {self.speed}")
        if self.orientation not in ("hold", "slerp"):
            raise ValueError(f"segment {self.name!r}: orientation must be 'hold' or 'slerp'")


def _allow(pairs: Pairs | AllowedContacts) -> AllowedContacts:
    return pairs if isinstance(pairs, AllowedContacts) else AllowedContacts(tuple(pairs))


def free(name: str, target: Pose | str, *, gripper: GripperCommand = "open", allow: Pairs = (),
         attached: str | None = None, speed: float = 1.0, riders: tuple[str, ...] = ()) -> MotionSegment:
    """Collision-free joint-space motion to a TCP target."""
    return MotionSegment(name, "free", target, gripper, _allow(allow), attached, speed=speed,
                         riders=tuple(riders))


def linear(name: str, target: Pose | str, *, gripper: GripperCommand = "open", allow: Pairs = (),
           attached: str | None = None, orientation: Literal["hold", "slerp"] = "hold",
           speed: float = 1.0, riders: tuple[str, ...] = ()) -> MotionSegment:
    """Straight TCP line to a target."""
    return MotionSegment(name, "linear", target, gripper, _allow(allow), attached, orientation, speed=speed,
                         riders=tuple(riders))


def gripper(name: str, command: GripperCommand, *, steps: int) -> MotionSegment:
    """Open or close the gripper with the arm still."""
    return MotionSegment(name, "gripper", gripper=command, steps=steps)


def reverse(name: str, of: str, *, gripper: GripperCommand = "open", allow: Pairs = (),
            attached: str | None = None, speed: float = 1.0, riders: tuple[str, ...] = ()) -> MotionSegment:
    """Replay the executed joint trajectory of segment ``of`` backwards."""
    return MotionSegment(name, "reverse", gripper=gripper, allow=_allow(allow), attached=attached, of=of,
                         speed=speed, riders=tuple(riders))


def hold(name: str, *, steps: int, gripper: GripperCommand = "open") -> MotionSegment:
    """Keep the arm where it is for up to ``steps`` control steps."""
    return MotionSegment(name, "hold", gripper=gripper, steps=steps)


def guarded(name: str, toward: tuple[float, float, float] | Pose | str, *, until: Until, max_force: float,
            max_distance: float | None = None, speed: float = 0.25, gripper: GripperCommand = "open",
            allow: Pairs = (), attached: str | None = None,
            on_miss: Literal["fail", "continue"] = "fail",
            press: tuple[float, float, float] | None = None) -> MotionSegment:
    """Contact-aware straight TCP line: along the world ``direction`` ``toward`` (3 numbers, any length)
    for at most ``max_distance`` metres, or towards a target (a pose or a runtime-target name; the limit
    defaults to the distance to it), until ``until`` holds, pushing with at most ``max_force`` newtons.
    With ``press`` (a world direction) it slides instead: the whole ``max_distance`` along ``toward``, in
    contact with ``until``'s body, its force regulated along ``press`` (:mod:`mgdata.engine.guarded`)."""
    if isinstance(toward, (Pose, str)):
        guard = Guard(until, None, max_distance, max_force, on_miss, press)
        return MotionSegment(name, "guarded", toward, gripper, _allow(allow), attached, speed=speed,
                             guard=guard)
    direction = tuple(float(v) for v in toward)
    if len(direction) != 3:
        raise ValueError(f"segment {name!r}: a guarded direction is 3 numbers (x, y, z), got {toward!r}")
    guard = Guard(until, (direction[0], direction[1], direction[2]), max_distance, max_force, on_miss, press)
    return MotionSegment(name, "guarded", None, gripper, _allow(allow), attached, speed=speed, guard=guard)
