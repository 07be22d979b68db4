"""LTL_f safety monitoring: parse → one minimal DFA per constraint → runtime monitor → rollout verdict.

- :func:`compile_ltlf` turns a formula (``true false ! & | -> <-> X WX F G U W R``, identifiers
  ``[a-z_][a-z0-9_]*``) into a cached minimal :class:`DFA` over non-empty finite traces.
- :class:`Monitor` steps every constraint of a :class:`mgdata.spec.SafetySpec` on label vectors and latches
  violations (:class:`MonitorState`); :meth:`Monitor.run` replays whole episodes offline.
- :func:`verdict` is the paper's engagement-gated rollout verdict ν; :class:`ConstraintStatus` the
  four-valued status of a constraint.
"""

from mgdata.ltl.compile import compile_ltlf
from mgdata.ltl.dfa import DFA
from mgdata.ltl.monitor import Monitor, MonitorState
from mgdata.ltl.parser import parse
from mgdata.ltl.semantics import holds
from mgdata.ltl.status import ConstraintStatus
from mgdata.ltl.verdict import verdict

__all__ = ["DFA", "ConstraintStatus", "Monitor", "MonitorState", "compile_ltlf", "holds", "parse", "verdict"]
