#!/usr/bin/env python3
"""Solves the layout LP exported by `layout_lp_export` with HiGHS, the LP solver a user of
layout optimization would pick, and prints its optimum (in the problem's unit) and its CPU time.

Usage: python3 benches/peers/highs_layout.py LP.json [METHOD]
METHOD `adding` (the default): member adding as in layout-optimization codes (Gilbert & Tyas
2003): the LP on the cheapest INITIAL fraction of the members (environment, default 0.1;
doubled while infeasible), then the members whose reduced cost c_j − a_jᵀy is below
−1e-6·c_j added, most violated first, at most max(200, members in the LP) per pass, to the
same HiGHS model (warm-started dual simplex) until none is left: the optimum over every
member. METHOD `full`: HiGHS on the whole LP at once (its default `choose` solver).
CPU time is this process's (time.process_time) around the solves and the pricing, one thread
(`threads = 1`), not the JSON parse; best of REPEAT runs (environment, default 3).
Needs: pip install highspy numpy.
"""
import json
import os
import sys
import time

import highspy
import numpy as np


class Columns:
    """The exported LP's columns (compressed sparse columns) as numpy arrays."""

    def __init__(self, case):
        self.ptr = np.array(case["col_ptr"], dtype=np.int64)
        self.rows = np.array(case["row_idx"], dtype=np.int32)
        self.values = np.array(case["values"], dtype=np.double)
        self.cost = np.array(case["cost"], dtype=np.double)
        self.b = np.array(case["b"], dtype=np.double)
        self.col_of_entry = np.repeat(np.arange(len(self.cost)), np.diff(self.ptr))

    def reduced_costs(self, y):
        """c − Aᵀy for every column."""
        return self.cost - np.bincount(self.col_of_entry, weights=self.values * y[self.rows],
                                       minlength=len(self.cost))

    def add_to(self, h, cols):
        """Adds the columns `cols` (ascending) to the HiGHS model `h`."""
        starts, index, value = [0], [], []
        for j in cols:
            lo, hi = self.ptr[j], self.ptr[j + 1]
            index.append(self.rows[lo:hi])
            value.append(self.values[lo:hi])
            starts.append(starts[-1] + hi - lo)
        n = len(cols)
        h.addCols(n, self.cost[cols], np.zeros(n), np.full(n, highspy.kHighsInf),
                  starts[-1], np.array(starts[:-1], dtype=np.int32),
                  np.concatenate(index).astype(np.int32), np.concatenate(value))


def new_highs(cols, solver):
    """An empty HiGHS model with the equality rows A x = b and no columns."""
    h = highspy.Highs()
    h.setOptionValue("output_flag", False)
    h.setOptionValue("threads", 1)
    h.setOptionValue("solver", solver)
    h.addRows(len(cols.b), cols.b, cols.b, 0, np.array([], dtype=np.int32),
              np.array([], dtype=np.int32), np.array([], dtype=np.double))
    return h


def solve_full(cols):
    """HiGHS on the whole LP; returns (objective, status, LP solves, columns in the last LP)."""
    h = new_highs(cols, "choose")
    cols.add_to(h, np.arange(len(cols.cost)))
    h.run()
    return h.getInfo().objective_function_value, h.getModelStatus(), 1, len(cols.cost)


def solve_adding(cols):
    """Member adding (module docstring); same return as `solve_full`."""
    fraction = float(os.environ.get("INITIAL", "0.1"))
    order = np.argsort(cols.cost, kind="stable")
    h = new_highs(cols, "simplex")
    present = np.zeros(len(cols.cost), dtype=bool)
    solves = 0
    while True:
        chosen = order[: max(1, int(fraction * len(order)))]
        new = np.sort(chosen[~present[chosen]])
        cols.add_to(h, new)
        present[new] = True
        h.run()
        solves += 1
        status = h.getModelStatus()
        if status == highspy.HighsModelStatus.kOptimal or fraction >= 1.0:
            break
        fraction = min(1.0, 2.0 * fraction)
    while status == highspy.HighsModelStatus.kOptimal:
        y = np.array(h.getSolution().row_dual)
        reduced = cols.reduced_costs(y)
        violating = np.flatnonzero(~present & (reduced < -1e-6 * cols.cost))
        if len(violating) == 0:
            break
        worst = violating[np.argsort(reduced[violating] / cols.cost[violating], kind="stable")]
        new = np.sort(worst[: max(200, int(present.sum()))])
        cols.add_to(h, new)
        present[new] = True
        h.run()
        solves += 1
        status = h.getModelStatus()
    return h.getInfo().objective_function_value, status, solves, int(present.sum())


def solve(case, method):
    """One timed run; returns (optimum in the unit, CPU seconds, status, solves, columns)."""
    cols = Columns(case)
    started = time.process_time()
    objective, status, solves, used = (solve_adding if method == "adding" else solve_full)(cols)
    cpu = time.process_time() - started
    h = highspy.Highs()
    return (objective * case["objective_to_unit"], cpu, h.modelStatusToString(status), solves,
            used)


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    data = json.load(open(sys.argv[1]))
    method = sys.argv[2] if len(sys.argv) > 2 else "adding"
    if method not in ("adding", "full"):
        sys.exit(f"unknown method {method}: adding or full")
    repeat = int(os.environ.get("REPEAT", "3"))
    for k, case in enumerate(data["cases"]):
        runs = [solve(case, method) for _ in range(repeat)]
        objective, _, status, solves, used = runs[0]
        cpu = min(r[1] for r in runs)
        print(f"{data['problem']} case {k}: HiGHS {method} {status}, "
              f"{objective:.6f} {data['unit']}, {cpu:.4f} s CPU, {solves} LP solve(s), "
              f"{used} of {case['cols']} columns, {case['rows']} rows")


if __name__ == "__main__":
    main()
