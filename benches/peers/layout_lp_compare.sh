#!/usr/bin/env bash
# optimize truss against the layout LP solved by HiGHS, side by side on one core, on the same
# ground structure (not run in CI).
#
# For each file (it must ask for `[connect] full = true`): the layout LP over every admissible
# pair of its lattice joints, the LP optimize's start solves, is exported
# (benches/peers/layout_lp_export.rs) and solved by HiGHS with member adding
# (benches/peers/highs_layout.py: warm-started dual simplex, pricing in numpy, best of 3); then
# `optimize truss FILE -q --threads 1` runs (the whole run: the same LP by optimize's own member
# adding, then geometry optimization; CPU = user + system from /usr/bin/time). Prints both LP
# optima (they must agree: an independent check of optimize's LP), optimize's final mass and
# status, both CPU times and their ratio, all pinned to one core (`taskset -c ${CORE:-0}`).
#
# Usage: benches/peers/layout_lp_compare.sh [FILE ...]
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
    "${pin[@]}" /usr/bin/time -f '%U %S' -o "$work/time" \
        target/release/optimize truss "$file" -o "$work/out_$name" -q --threads 1 >/dev/null || true
    cpu=$(awk '{print $1 + $2}' "$work/time")
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
      f"| {highs_cpu:.4f} | {cpu:.2f} | {cpu / highs_cpu:.0f}× |")
PY
done
