"""The exceptions mgdata raises for bad input.

Every user-facing problem is an :class:`MgdataError`; the CLI prints its message on one line and exits
non-zero without a traceback. Messages name the file, key or value at fault and what was expected.
"""


class MgdataError(Exception):
    """Base class: a problem with the user's input or environment, reported without a traceback."""


class LtlSyntaxError(MgdataError):
    """An LTL_f formula does not parse; the message gives the position and what was expected."""


class LtlLimitError(LtlSyntaxError):
    """An LTL_f formula exceeds a documented limit (length, nesting depth, propositions per constraint,
    automaton size); a subclass of :class:`LtlSyntaxError` so every place that reports bad formulas reports
    it."""


class SpecError(MgdataError):
    """A safety specification is malformed (unknown proposition, evaluator, parameter type …)."""


class RecipeError(MgdataError):
    """A family recipe is missing, malformed, or names something that does not exist."""


class UnknownFamilyError(RecipeError):
    """The requested family has no recipe or skeleton."""


class RobotModelError(MgdataError):
    """The Panda MJCF cannot be found or loaded."""


class AssetError(MgdataError):
    """An object model is unknown or its parameters are invalid."""


class SceneError(MgdataError):
    """A scene cannot be built (overlapping initial poses, missing bodies, bad camera names …)."""


class SimulationError(MgdataError):
    """The physics diverged (NaN/Inf or huge accelerations); the episode in progress cannot continue."""


class GraspDBError(MgdataError):
    """A grasp database file is malformed or names an unknown object."""


class DatasetError(MgdataError):
    """A dataset on disk is missing, corrupt, or of an unsupported version."""


class MetricsError(MgdataError):
    """A rollout-records file cannot be read or lacks a required field."""


class DeviceError(MgdataError):
    """A teleoperation device is missing or does not answer."""


class OutputError(MgdataError):
    """The output location cannot be written: not a folder, no permission, read-only, or disk full."""


class WorkerError(MgdataError):
    """An attempt worker process died (killed or crashed); what was committed before stays."""


class PolicyError(MgdataError):
    """The evaluated policy cannot be used: a bad ``--policy`` URL, a server that is down, an error the
    server reported, or a reply that is not an action chunk."""
