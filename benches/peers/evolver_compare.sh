#!/usr/bin/env bash
# Surface Evolver vs optimize on the same CMC start meshes (not run in CI).
#
# For each case: the problem file's start mesh at the given resolution is written as an Evolver
# datafile (benches/peers/evolver_export.rs, lengths in cm) and minimized by `evolver-nox-d`
# (20 gradient steps, 10 Newton steps with line search `hessian_seek`, then plain Newton
# steps `hessian` until the energy changes by less than 1e-12 relative);
# optimize solves the same file at the same resolution with no edge flips (so both keep the
# start's connectivity). Prints both areas (cm²), their relative difference and both wall times.
#
# Usage: benches/peers/evolver_compare.sh [CASE ...]   CASE = file:resolution
# Needs: evolver-nox-d (Debian/Ubuntu: apt-get install -y evolver-nox).
set -euo pipefail
cd "$(dirname "$0")/../.."
EVOLVER=${EVOLVER:-evolver-nox-d}
command -v "$EVOLVER" >/dev/null || { echo "$EVOLVER not found (apt-get install -y evolver-nox)"; exit 1; }
cases=("$@")
if [ ${#cases[@]} -eq 0 ]; then
    cases=(problems/cmc/double_bubble.toml:3 problems/cmc/double_bubble.toml:5
           problems/cmc/cube_frame.toml:2 problems/cmc/cube_frame.toml:3
           problems/cmc/cube_frame_film.toml:3)
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cargo build --release --quiet --bin optimize --example evolver_export
bin=target/release/optimize
export_bin=target/release/examples/evolver_export
cat > "$work/run.cmd" <<'CMD'
g 20;
for ( inx := 1 ; inx <= 10 ; inx += 1 ) { hessian_seek };
for ( inx := 1 ; inx <= 20 ; inx += 1 ) {
    oldE := total_energy; hessian;
    if abs(oldE - total_energy) < 1e-12 * abs(total_energy) then break;
};
printf "EVOLVER_AREA %.12f\n", total_area;
q
CMD
printf "%-34s %5s %8s %14s %14s %9s %9s %9s\n" case res vertices "optimize cm²" "evolver cm²" "diff %" "opt s" "evol s"
for c in "${cases[@]}"; do
    file=${c%%:*}; res=${c##*:}; name=$(basename "$file" .toml)
    "$export_bin" "$file" "$work/$name.fe" "$res" 100 2>"$work/export.log"
    vertices=$(grep -o '[0-9]* vertices' "$work/export.log" | cut -d' ' -f1)
    # Same file, same resolution, no edge flips.
    sed -e "s/^resolution = .*/resolution = $res/" "$file" > "$work/$name.toml"
    if grep -q '^\[quality\]' "$work/$name.toml"; then
        sed -i -e '/^\[quality\]/a flip_rounds = 0' -e '/^flip_rounds = [1-9]/d' "$work/$name.toml"
    else
        printf '\n[quality]\nflip_rounds = 0\n' >> "$work/$name.toml"
    fi
    t0=$(date +%s.%N)
    "$bin" cmc "$work/$name.toml" -o "$work/out_$name" --json -q > "$work/$name.json" || true
    t1=$(date +%s.%N)
    "$EVOLVER" -x -f "$work/run.cmd" "$work/$name.fe" < /dev/null > "$work/$name.evolver.log" 2>&1 || true
    t2=$(date +%s.%N)
    python3 - "$work/$name.json" "$work/$name.evolver.log" "$c" "$res" "$vertices" "$t0" "$t1" "$t2" <<'PY'
import json, re, sys
summary, log, case, res, vertices, t0, t1, t2 = sys.argv[1:]
ours = json.load(open(summary))
area = ours["objective"] * 1e4
match = re.findall(r"EVOLVER_AREA ([-0-9.eE+]+)", open(log).read())
theirs = float(match[-1]) if match else float("nan")
print(f"{case:34s} {res:>5s} {vertices:>8s} {area:14.6f} {theirs:14.6f} "
      f"{100 * (area - theirs) / theirs:9.4f} {float(t1) - float(t0):9.2f} {float(t2) - float(t1):9.2f}"
      f"   ({ours['status']}, {ours['iterations']} iterations)")
PY
done
