#!/usr/bin/env bash
# optimize truss against the layout LP solved by HiGHS, side by side on one core, on the same
# ground structure (not run in CI).
#
# For each file (it must ask for `[connect] full = true`): the layout LP over every admissible
# pair of its lattice joints, the LP optimize's start solves, is exported
# (benches/peers/layout_lp_export.rs) and solved by HiGHS with member adding
# (benches/peers/highs_layout.py: warm-started dual simplex, pricing in numpy, best of 3); then
# `optimize truss FILE -q --threads 1` runs (the whole run: the same LP by optimize's own member
# adding, then geometry optimization; CPU = user + system from /usr/bin/time over enough
# back-to-back runs to take at least 0.5 s, divided by their number, so that the 0.01 s
# resolution of /usr/bin/time does not decide; the best of ROUNDS such readings, default 3, as
# HiGHS's is the best of 3). Prints both LP optima (they must agree: an independent check of
# optimize's LP), optimize's final mass and status, both CPU times and their ratio, all pinned
# to one core (`taskset -c ${CORE:-0}`).
#
# Usage: [ROUNDS=3] [CORE=0] benches/peers/layout_lp_compare.sh [FILE ...]
# Default files: the problems/truss files posed against the LP (`linear` mass, `[connect] full`).
# Needs: pip install highspy numpy.
set -euo pipefail
cd "$(dirname "$0")/../.."
python3 -c 'import highspy, numpy' 2>/dev/null || { echo "needs: pip install highspy numpy"; exit 1; }
pin=()
command -v taskset >/dev/null && pin=(taskset -c "${CORE:-0}")
files=("$@")
if [ ${#files[@]} -eq 0 ]; then
    mapfile -t files < <(grep -l '^full = true' problems/truss/*.toml)
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cargo build --release --quiet --bin optimize --example layout_lp_export
printf '| file | HiGHS LP | optimize LP | optimize final | status, it. | HiGHS CPU s | optimize CPU s | ratio |\n'
printf '|---|---|---|---|---|---|---|---|\n'
for file in "${files[@]}"; do
    name=$(basename "$file" .toml)
    target/release/examples/layout_lp_export "$file" "$work/$name.json" 2>/dev/null
    highs=$("${pin[@]}" python3 benches/peers/highs_layout.py "$work/$name.json" adding 2>/dev/null |
        grep ' case 0: ')
    run=(target/release/optimize truss "$file" -o "$work/out_$name" -q --threads 1)
    "${pin[@]}" /usr/bin/time -f '%U %S' -o "$work/time" "${run[@]}" >/dev/null || true
    runs=$(awk '{ t = $1 + $2; n = t > 0 ? int(0.5 / t) + 1 : 50; print (n > 50 ? 50 : n) }' "$work/time")
    cpu=
    for _ in $(seq "${ROUNDS:-3}"); do
        "${pin[@]}" /usr/bin/time -f '%U %S' -o "$work/time" \
            bash -c 'for _ in $(seq "$1"); do "${@:2}" >/dev/null || true; done' _ "$runs" "${run[@]}"
        cpu=$(awk -v n="$runs" -v best="$cpu" '{ t = ($1 + $2) / n; print (best == "" || t < best) ? t : best }' "$work/time")
    done
    python3 - "$work/out_$name/result.json" "$name" "$highs" "$cpu" <<'PY'
import json, re, sys
r = json.load(open(sys.argv[1]))
name, cpu = sys.argv[2], float(sys.argv[4])
m = re.search(r"HiGHS \w+ (\w+), ([-0-9.eE+]+) \w+, ([0-9.]+) s CPU", sys.argv[3])
highs_value, highs_cpu = float(m.group(2)), float(m.group(3))
q = r["figures"]["quality"]
unit = r["headline"]["unit"]
print(f"| {name} | {highs_value:.4f} {unit} | {q['lp_value']:.4f} | {r['headline']['value']:.4f} "
      f"({100 * (r['headline']['value'] / highs_value - 1):+.2f} %) | {r['status']}, {r['iterations']} "
      f"| {highs_cpu:.4f} | {cpu:.3f} | {cpu / highs_cpu:.1f}× |")
PY
done
