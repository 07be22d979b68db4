"""LTL_f monitor benchmark: compile time per family spec, monitor throughput, single-step costs.

Targets (issue 2): compile ≤ 50 ms per family spec; ≥ 1,000,000 vectorised steps/s for one constraint;
≤ 2 µs per Python-level ``dfa.step``; ``mon.step`` on the jar spec a few µs (the 20 Hz step budget of
labelling + monitor is 100 µs). Issue 8: compile time stays bounded at the formula limits (``docs/ltl.md``):
``bench_limits`` grows adversarial formula families until the compiler refuses them and prints the slowest
accepted compile of each.

Run: ``.venv/bin/python benchmarks/bench_ltl.py``
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable

import numpy as np

from mgdata.errors import LtlLimitError
from mgdata.ltl import Monitor, compile_ltlf
from mgdata.ltl.parser import MAX_PROPOSITIONS
from mgdata.spec import Constraint, SafetySpec, family_spec, known_families


def best_of(fn: Callable[[], object], repeat: int = 5) -> float:
    """The fastest of ``repeat`` wall-clock timings of ``fn()``, in seconds."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def bench_compile() -> None:
    print("compile time per family spec (cold cache; target <= 50 ms):")
    for name in known_families():
        spec = family_spec(name)

        def cold(spec: SafetySpec = spec) -> None:
            compile_ltlf.cache_clear()
            Monitor(spec)

        ms = best_of(cold) * 1e3
        states = [d.n_states for d in Monitor(spec).dfas]
        print(f"  {name:<15} {ms:7.2f} ms   {len(spec.constraints)} constraints, DFA states {states}")
    compile_ltlf.cache_clear()
    jar = family_spec("jar")
    whole = " & ".join(f"({c.formula})" for c in jar.constraints)
    print(f"  (jar as one monolithic formula, for comparison: {best_of(lambda: _cold(whole)) * 1e3:.2f} ms, "
          f"{compile_ltlf(whole).n_states} states)")


def _cold(formula: str) -> None:
    compile_ltlf.cache_clear()
    compile_ltlf(formula)


def bench_throughput() -> None:
    jar = family_spec("jar")
    upright = SafetySpec("one", (Constraint("up", "G jar_upright"),), jar.propositions)
    ordering = SafetySpec("one", (jar.constraints[0],), jar.propositions)
    n_props = len(jar.propositions)
    # safe episodes, so no absorbing state cuts the replay short: on the table, open, upright, not dropped
    single = np.zeros((1_000_000, n_props), dtype=bool)
    single[:, [0, 3]] = True
    batch = np.broadcast_to(single[:2000], (256, 2000, n_props)).copy()
    print("vectorised replay (Monitor.run on safe episodes; target >= 1,000,000 steps/s for one constraint),")
    print("in millions of constraint-steps per second:")
    cases = (("G jar_upright", upright), ("jar_on_support W jar_closed", ordering),
             ("jar spec (3 constraints)", jar))
    for label, spec in cases:
        mon = Monitor(spec)
        c = len(spec.constraints)
        t1 = best_of(lambda mon=mon: mon.run(single), 3)
        tb = best_of(lambda mon=mon: mon.run(batch), 3)
        print(f"  {label:<28} one episode of 1e6 steps: {single.shape[0] * c / t1 / 1e6:6.1f}"
              f"   batch of 256 x 2000 steps: {batch.shape[0] * batch.shape[1] * c / tb / 1e6:6.1f}")


def bench_single_step() -> None:
    dfa = compile_ltlf("jar_on_support W jar_closed")
    q = dfa.step(dfa.initial, 0b10)
    n = 200_000

    def steps() -> None:
        step = dfa.step
        for _ in range(n):
            step(q, 0b10)

    print(f"single Python-level dfa.step: {best_of(steps) / n * 1e6:.3f} µs (target <= 2 µs)")
    mon = Monitor(family_spec("jar"))
    labels = np.array([True, False, False, True])
    mon.reset()

    def mon_steps() -> None:
        for _ in range(n // 4):
            mon.step(labels)

    print(f"mon.step on the jar spec (3 constraints, returns MonitorState): "
          f"{best_of(mon_steps) / (n // 4) * 1e6:.2f} µs")


LIMIT_FAMILIES: dict[str, Callable[[int], str]] = {
    "F p0 & … & F pk": lambda k: " & ".join(f"F p{i}" for i in range(k)),
    "G F p0 & … & G F pk": lambda k: " & ".join(f"G F p{i}" for i in range(k)),
    "G((p0 -> F p1) & …)": lambda k: "G(" + " & ".join(f"(p{i} -> F p{i + 1})" for i in range(k - 1)) + ")",
    "(p0 W p1) & (p1 W p2) & …": lambda k: " & ".join(f"(p{i} W p{i + 1})" for i in range(k - 1)),
    "G(a -> X X … X b), n X": lambda n: "G(a -> " + "X " * n + "b)",
    "F(a & X F(a & X F …)), n F": lambda n: "F(a & X " * (n - 1) + "F a" + ")" * (n - 1),
    "G(a -> (b U (c U … ))), n U": lambda n: "G(a -> " + " U ".join(f"p{i % 6}" for i in range(n + 1)) + ")",
}


def bench_limits() -> None:
    print(f"compile time at the limits (<= {MAX_PROPOSITIONS} propositions, bounded automaton size): each "
          "family grows until refused")
    worst = 0.0
    for label, make in LIMIT_FAMILIES.items():
        slowest, largest, refused = 0.0, 0, None
        for n in range(2, 33):
            formula = make(n)
            compile_ltlf.cache_clear()
            start = time.perf_counter()
            try:
                compile_ltlf(formula)
            except LtlLimitError as err:
                why = str(err).split(": ")[-1][:40]
                refused = f"refused at n={n} in {time.perf_counter() - start:.2f} s ({why}…)"
                break
            slowest, largest = max(slowest, time.perf_counter() - start), n
        worst = max(worst, slowest)
        print(f"  {label:<28} accepted up to n={largest}, slowest {slowest:5.2f} s; "
              f"{refused or 'never refused'}")
    print(f"  slowest accepted compile over all families: {worst:.2f} s")


if __name__ == "__main__":
    if "--limits" in sys.argv:
        bench_limits()
        sys.exit()
    bench_compile()
    bench_throughput()
    bench_single_step()
    bench_limits()
