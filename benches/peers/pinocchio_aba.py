#!/usr/bin/env python3
"""Side-by-side: our articulated-body algorithm (ABA) against Pinocchio's on the same models.

For each character (default: Luxo and the biped), runs `cargo run --release --example peer_aba`,
which exports the model, random states (fixed seed) and our accelerations and ABA time; builds
the same model in Pinocchio (planar root joint, revolute/prismatic joints with unaligned axes,
the same inertias and gravity), checks that both give the same accelerations, and times
Pinocchio's `aba` on the same states. Outside CI: needs `pip install pin numpy`.

Pinocchio's planar joint has q = (x, y, cos θ, sin θ) and v = (v_x, v_y, ω_z), ours q = (x, y, θ)
and v = (ω_z, v_x, v_y); both velocities are in the link frame, so only the order differs.

Pinocchio is called through its Python bindings, so its time includes the call overhead; the
script also times a near-empty bound call (`pin.neutral`) to show the size of that overhead.
"""

import argparse
import json
import pathlib
import subprocess
import sys
import timeit

import numpy as np
import pinocchio as pin

ROOT = pathlib.Path(__file__).resolve().parents[2]


def ours(problem, states, seed):
    """Runs the exporter; returns its JSON."""
    out = subprocess.run(
        ["cargo", "run", "--quiet", "--release", "--example", "peer_aba", "--",
         str(problem), str(states), str(seed)],
        cwd=ROOT, check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def build(spec):
    """The Pinocchio model of an exported character; joints in our link order."""
    model = pin.Model()
    model.gravity = pin.Motion(np.array(spec["gravity"]), np.zeros(3))
    joint_ids = []
    for link in spec["links"]:
        parent = 0 if link["parent"] is None else joint_ids[link["parent"]]
        axis = np.array(link["axis"], dtype=float)
        kind = link["joint"]
        if kind == "planar":
            joint = pin.JointModelPlanar()
        elif kind == "revolute":
            joint = pin.JointModelRevoluteUnaligned(axis)
        elif kind == "prismatic":
            joint = pin.JointModelPrismaticUnaligned(axis)
        else:
            sys.exit(f"joint kind {kind} is not mapped")
        placement = pin.SE3(np.eye(3), np.array(link["origin"], dtype=float))
        jid = model.addJoint(parent, joint, placement, link["name"])
        inertia = pin.Inertia(link["mass"], np.array(link["com"]), np.array(link["inertia"]))
        model.appendBodyToJoint(jid, inertia, pin.SE3.Identity())
        joint_ids.append(jid)
    return model


def convert(spec, q, v, tau):
    """Our (q, v, τ) in Pinocchio's coordinates, and the permutation of v."""
    qp, order = [], []
    qi = vi = 0
    for link in spec["links"]:
        if link["joint"] == "planar":
            x, y, th = q[qi:qi + 3]
            qp += [x, y, np.cos(th), np.sin(th)]
            order += [vi + 1, vi + 2, vi]
            qi, vi = qi + 3, vi + 3
        else:
            qp.append(q[qi])
            order.append(vi)
            qi, vi = qi + 1, vi + 1
    order = np.array(order)
    return np.array(qp), np.asarray(v)[order], np.asarray(tau)[order], order


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("problems", nargs="*",
                        default=["problems/gait/luxo_leap.toml", "problems/gait/biped_hop.toml"])
    parser.add_argument("--states", type=int, default=200)
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    print(f"pinocchio {pin.__version__}; {args.states} random states, seed {args.seed}")
    print(f"{'model':<12}{'nv':>4}{'max |Δv̇|':>12}{'ours ns':>10}{'pin ns':>10}"
          f"{'empty call ns':>15}{'pin/ours':>10}")
    worst = 0.0
    for problem in args.problems:
        spec = ours(ROOT / problem, args.states, args.seed)
        model = build(spec)
        data = model.createData()
        converted = [convert(spec, q, v, t)
                     for q, v, t in zip(spec["q"], spec["v"], spec["tau"])]
        gap = 0.0
        for (q, v, t, order), ref in zip(converted, spec["vdot"]):
            a = pin.aba(model, data, q, v, t)
            gap = max(gap, float(np.max(np.abs(a - np.asarray(ref)[order]))))
        worst = max(worst, gap)

        def run_all():
            for q, v, t, _ in converted:
                pin.aba(model, data, q, v, t)

        def empty_all():
            for _ in converted:
                pin.neutral(model)

        per = lambda f: min(timeit.repeat(f, number=5, repeat=9)) / (5 * len(converted)) * 1e9
        t_pin, t_empty = per(run_all), per(empty_all)
        print(f"{spec['problem']:<12}{spec['nv']:>4}{gap:>12.2e}{spec['aba_ns_median']:>10.0f}"
              f"{t_pin:>10.0f}{t_empty:>15.0f}{t_pin / spec['aba_ns_median']:>10.2f}")
    if worst > 1e-9:
        sys.exit(f"accelerations disagree: max |Δv̇| = {worst:.3e}")
    print("accelerations agree to 1e-9")


if __name__ == "__main__":
    main()
