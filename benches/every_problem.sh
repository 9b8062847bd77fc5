#!/usr/bin/env bash
# Runs every problem file under problems/ (or the files given as arguments) as a user would,
# `optimize KIND FILE --threads 1 -q`, one at a time, and prints a Markdown table: file, exit
# code, status, the headline answer in the file's units, iterations, CPU seconds (user + sys of
# the process, from /usr/bin/time). Each run writes into its own folder under $OUT (default: a
# temporary folder, removed at the end).
#
#   benches/every_problem.sh                          # every file (gait files take minutes to an hour)
#   benches/every_problem.sh problems/truss/*.toml    # one kind
#   OPTIMIZE=target/release/optimize benches/every_problem.sh ...
#
# Needs python3 (to read result.json) and GNU time.
set -euo pipefail
cd "$(dirname "$0")/.."
optimize=${OPTIMIZE:-target/release/optimize}
[[ -x $optimize ]] || { echo "error: $optimize not found (cargo build --release first)" >&2; exit 2; }
out=${OUT:-$(mktemp -d)}
[[ -n ${OUT:-} ]] || trap 'rm -rf "$out"' EXIT

if (($# == 0)); then set -- problems/*/*.toml; fi

echo "| file | exit | status | headline | iterations | CPU s |"
echo "|---|---|---|---|---|---|"
for file in "$@"; do
    kind=$(basename "$(dirname "$file")")
    name=$(basename "$file" .toml)
    dir="$out/$kind/$name"
    mkdir -p "$out/$kind"
    set +e
    /usr/bin/time -f '%U %S' -o "$dir.time" "$optimize" "$kind" "$file" --threads 1 -q -o "$dir" \
        >/dev/null 2>"$dir.err"
    code=$?
    set -e
    cpu=$(awk 'END { printf "%.2f", $1 + $2 }' "$dir.time")
    summary=$(python3 - "$dir/result.json" <<'PY' 2>/dev/null || echo "- | - | -"
import json, sys
d = json.load(open(sys.argv[1]))
h = d.get("headline") or {}
value = h.get("value")
head = "-" if value is None else f"{h.get('name', '')} {value:.6g} {h.get('unit', '')}".strip()
print(f"{d.get('status', '-')} | {head} | {d.get('iterations', '-')}")
PY
)
    if [[ ! -f $dir/result.json ]]; then
        summary="$(head -n 1 "$dir.err" | cut -c1-80 | tr '|' '/') | - | -"
    fi
    echo "| $kind/$name | $code | $summary | $cpu |"
done
