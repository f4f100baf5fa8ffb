#!/usr/bin/env python3
"""Compares two metrics.json files of `ridgeline run` on every key that is not a timing.

    scripts/compare_metrics.py BASE/metrics.json NEW/metrics.json [--rtol 1e-9]

A speed change must not change what the flight does: every number must agree to `rtol`
relative, strings and booleans exactly, and both files must have the same keys. Timings
(wall and CPU times, real-time factors, the MPC step's and the plan's durations) differ from
run to run and are skipped. A number whose both values are below 1e-12 in magnitude is a
round-off zero (e.g. a slack of 1e-15 m): its relative difference means nothing, so it is
not counted as a difference but listed when the two values differ.

Prints the largest relative difference and every key that differs; exit 0 when all agree,
1 when some differ, 2 on bad input.
"""
import argparse
import json
import sys

TIMING_KEYS = {"cpu_time_s", "wall_time_s", "global_plan_s", "real_time_factor",
               "real_time_factor_cpu", "mpc_solve_us", "mpc_solve_cpu_us"}
ROUND_OFF_ZERO = 1e-12


def flatten(value, path, out):
    """Fills out {"a/b[2]/c": leaf} with the leaves of value, leaving timing keys out."""
    if isinstance(value, dict):
        for key, item in value.items():
            if key not in TIMING_KEYS:
                flatten(item, f"{path}/{key}", out)
    elif isinstance(value, list):
        for i, item in enumerate(value):
            flatten(item, f"{path}[{i}]", out)
    else:
        out[path] = value


def load(path):
    try:
        with open(path, encoding="utf-8") as f:
            leaves = {}
            flatten(json.load(f), "", leaves)
            return leaves
    except (OSError, json.JSONDecodeError) as error:
        print(f"error: {path}: {error}", file=sys.stderr)
        sys.exit(2)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("base")
    parser.add_argument("new")
    parser.add_argument("--rtol", type=float, default=1e-9)
    args = parser.parse_args()
    base, new = load(args.base), load(args.new)

    differences = []
    for key in sorted(set(base) ^ set(new)):
        differences.append(f"{key}: only in {'base' if key in base else 'new'}")
    max_rel, max_rel_key, zeros = 0.0, "", []
    for key in sorted(set(base) & set(new)):
        a, b = base[key], new[key]
        numeric = all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (a, b))
        if not numeric:
            if a != b:
                differences.append(f"{key}: {a!r} != {b!r}")
            continue
        if abs(a) < ROUND_OFF_ZERO and abs(b) < ROUND_OFF_ZERO:
            if a != b:
                zeros.append(f"{key}: {a!r} vs {b!r}")
            continue
        rel = abs(a - b) / max(abs(a), abs(b))
        if rel > max_rel:
            max_rel, max_rel_key = rel, key
        if rel > args.rtol:
            differences.append(f"{key}: {a!r} != {b!r} (relative {rel:.3g})")

    print(f"{len(set(base) & set(new))} keys compared (timings left out); "
          f"max relative difference {max_rel:.3g}" + (f" at {max_rel_key}" if max_rel_key else ""))
    if zeros:
        print(f"{len(zeros)} unequal round-off zeros (both below {ROUND_OFF_ZERO:g}):")
        for line in zeros:
            print("  " + line)
    if differences:
        print(f"{len(differences)} differ beyond rtol {args.rtol:g}:")
        for line in differences:
            print("  " + line)
        return 1
    print(f"equal to rtol {args.rtol:g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
