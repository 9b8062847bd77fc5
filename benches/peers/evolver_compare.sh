#!/usr/bin/env bash
# Surface Evolver vs optimize side by side on the same CMC start meshes, one core, CPU time
# (not run in CI).
#
# For each case: the problem file's start mesh at the given resolution is written as an Evolver
# datafile (benches/peers/evolver_export.rs, lengths in cm) and minimized by `evolver-nox-d`
# (20 gradient steps, then Newton steps with line search `hessian_seek` until the energy
# changes by less than 1e-12 relative, at most 40: plain `hessian` steps diverge on the cube
# film, whose Hessian with tangential motion is indefinite); optimize solves the
# same file at the same resolution with no edge flips (so both keep the start's connectivity),
# `-q --threads 1`. The two programs run alternately (optimize, Evolver, optimize, ... for
# ROUNDS rounds, default 1) pinned to one core (`taskset -c ${CORE:-0}` when available); CPU
# time is user + system from /usr/bin/time over REPEAT back-to-back runs of one program, divided
# by REPEAT (default: enough runs for a reading of at least 0.5 s, from one timed run first, so
# that the 0.01 s resolution of /usr/bin/time does not decide small cases), the best of the
# rounds. Prints facets, both areas (cm²), their relative difference, both CPU times per run,
# the ratio optimize / Evolver and the repeat counts.
#
# What both do: by default the film only: Evolver's script computes no eigenvalues and optimize
# runs with `[stability] eigenvalues = 0` (its stability analysis off). STABILITY=1: the film
# and its six smallest eigenvalues: optimize runs its default stability analysis (the inertia
# count and the six smallest eigenvalues of the area's second variation in normal motion under
# the volume constraints, mass-weighted) and Evolver's script ends, after convergence, with
# `linear_metric; ritz(-1e-6, 6)` (hessian_normal is on by default: normal motion; the volume
# constraints are projected out; `linear_metric` weights by the linear-interpolation metric so
# that the eigenvalues approximate the smooth operator's, as optimize's mixed-area weights do;
# ritz factors the Hessian at the probe, prints the inertia there and the six eigenvalues above
# it). Evolver does not exclude rigid motions, so on a free double bubble its six include the
# five near-zero rigid modes; the work, an inertia count and six eigenvalues from one
# factorization, is the same. The mode is printed first.
#
# REFERENCE=1 adds, untimed, the area Evolver reaches when it also relaxes tangentially: its
# standard script, then `hessian_normal off` and conjugate-gradient steps (`U`, `g 200` at a
# time) until the area changes by less than 1e-10 relative (at most 100 × 200 steps), and
# optimize's difference to it. The standard script's Newton steps move vertices along their
# normals only (`hessian_normal`), so its area depends on the tangential layout left by its 20
# gradient steps: at 648 double-bubble facets it stops 0.038 % above that relaxed area, while
# optimize relaxes tangentially between its rounds (docs/notes/cmc.md).
#
# The relaxed point is probed (`eigenprobe 0` with hessian_normal on: its inertia in normal
# motion) and dumped; the smallest and largest triangle angles of the dump are printed
# (benches/peers/evolver_angles.py): Evolver's tangential steps may leave nearly degenerate
# triangles.
#
# CONFIRM=1 adds, untimed, Evolver started at optimize's answer (the last timed run's
# result.json, exported by evolver_export at the same resolution): its area as loaded and on
# Evolver's own projection onto the volumes (`m 0; g 1`), its inertia in normal motion and
# triangle angles there; then Evolver's standard script from it (the timed runs' commands) and,
# with REFERENCE=1, the tangential relaxation too, each end's area, inertia and (last end)
# angles; with STABILITY=1 also Evolver's `linear_metric; ritz(-1e-6, 6)` at optimize's answer,
# the eigenvalues of one configuration in both programs (the timed runs' ritz is at Evolver's
# own end). It shows whether Evolver stays at optimize's answer or finds lower area. A closing
# table lists per case Evolver's areas from the shared start and from optimize's answer, and
# optimize's.
#
# KEEP=1 keeps the work directory (datafiles, logs, dumps, optimize's run folders) and prints
# its path.
#
# FORMULATION=area (or normal, curvature) sets optimize's top-level `formulation` for every
# case (default: the file's own, normal unless it says otherwise).
#
# QP=sparse (or dense) sets optimize's `[solver] qp` for every case (default: the file's own
# setting, i.e. the solver's automatic choice: dense below 2000 variables).
#
# Usage: benches/peers/evolver_compare.sh [CASE ...]   CASE = file:resolution
# Default cases: double bubble V = 1, 2 cm³ at 648, 3,042 and 11,250 facets and the bubble-free
# cube frame film at 792, 3,168 and 10,648 facets.
# Needs: evolver-nox-d (Debian/Ubuntu: apt-get install -y evolver-nox).
set -euo pipefail
cd "$(dirname "$0")/../.."
EVOLVER=${EVOLVER:-evolver-nox-d}
ROUNDS=${ROUNDS:-1}
LIMIT=${LIMIT:-600}
command -v "$EVOLVER" >/dev/null || { echo "$EVOLVER not found (apt-get install -y evolver-nox)"; exit 1; }
pin=()
command -v taskset >/dev/null && pin=(taskset -c "${CORE:-0}")
cases=("$@")
if [ ${#cases[@]} -eq 0 ]; then
    cases=(problems/cmc/double_bubble.toml:6 problems/cmc/double_bubble.toml:13
           problems/cmc/double_bubble.toml:25
           problems/cmc/cube_frame_film.toml:6 problems/cmc/cube_frame_film.toml:12
           problems/cmc/cube_frame_film.toml:22)
fi
work=$(mktemp -d)
trap 'if [ "${KEEP:-0}" = 1 ]; then echo "work files kept in $work"; else rm -rf "$work"; fi' EXIT
cargo build --release --quiet --bin optimize --example evolver_export
bin=target/release/optimize
export_bin=target/release/examples/evolver_export
# Evolver's standard script (timed), its tangential relaxation (REFERENCE=1) and an inertia
# probe at the current point in normal motion (hessian_normal on), each with a marker line.
cat > "$work/standard.cmd" <<'CMD'
g 20;
for ( inx := 1 ; inx <= 40 ; inx += 1 ) {
    oldE := total_energy; hessian_seek;
    if abs(oldE - total_energy) < 1e-12 * abs(total_energy) then break;
};
printf "EVOLVER_AREA %.12f\n", total_area;
CMD
cat > "$work/relax.cmd" <<'CMD'
hessian_normal off;
U;
for ( inx := 1 ; inx <= 100 ; inx += 1 ) {
    oldA := total_area; g 200;
    if abs(oldA - total_area) < 1e-10 * abs(total_area) then break;
};
printf "EVOLVER_RELAXED_AREA %.12f\n", total_area;
hessian_normal on;
CMD
probe() { printf 'printf "EVOLVER_PROBE %s\\n";\neigenprobe 0;\n' "$1"; }
cp "$work/standard.cmd" "$work/run.cmd"
if [ "${STABILITY:-0}" = 1 ]; then
    printf 'linear_metric;\nritz(-1e-6, 6);\n' >> "$work/run.cmd"
    echo "mode: STABILITY=1, film and six smallest eigenvalues (optimize's default stability analysis; Evolver: linear_metric; ritz(-1e-6, 6) after convergence)"
else
    echo "mode: film only (optimize [stability] eigenvalues = 0; Evolver computes no eigenvalues); STABILITY=1 adds them to both"
fi
echo q >> "$work/run.cmd"
# The untimed reference (REFERENCE=1): the standard script, then tangential relaxation too,
# the relaxed point probed and dumped (DATAFILE.dmp) for its triangle angles.
{ cat "$work/standard.cmd" "$work/relax.cmd"; probe relaxed; printf 'dump;\nq\n'; } > "$work/ref.cmd"
# The untimed confirmation (CONFIRM=1), two Evolver runs started at optimize's answer. The
# first probes it: its area as loaded, then one iteration at scale 0 (`m 0; g 1`: no motion
# along the force, only Evolver's projection onto the body volumes, which also sets the
# pressures its Hessian needs), its area and inertia there. The second runs the standard
# script from it (and with REFERENCE=1 the tangential relaxation), probed, and dumps its end.
{
    printf 'printf "EVOLVER_LOADED_AREA %%.12f\\n", total_area;\nm 0;\ng 1;\n'
    printf 'printf "EVOLVER_PROJECTED_AREA %%.12f\\n", total_area;\n'; probe loaded
    [ "${STABILITY:-0}" = 1 ] && printf 'linear_metric;\nritz(-1e-6, 6);\n'
    echo q
} > "$work/answer.cmd"
{
    cat "$work/standard.cmd"; probe standard
    [ "${REFERENCE:-0}" = 1 ] && { cat "$work/relax.cmd"; probe relaxed; }
    printf 'dump;\nq\n'
} > "$work/confirm.cmd"
# CPU seconds (user + system) of one run of a command, its output to $1: the total over
# REPEAT runs (or, without REPEAT, over enough runs to take at least 0.5 s) divided by their
# number, printed with that number.
cpu() {
    local out=$1; shift
    local runs=${REPEAT:-}
    if [ -z "$runs" ]; then
        /usr/bin/time -f "%U %S" -o "$work/time" timeout "$LIMIT" "${pin[@]}" "$@" > "$out" 2>&1 || true
        runs=$(awk '{ t = $1 + $2; n = t > 0 ? int(0.5 / t) + 1 : 50; print (n > 50 ? 50 : n) }' "$work/time" | tail -1)
    fi
    /usr/bin/time -f "%U %S" -o "$work/time" timeout "$LIMIT" "${pin[@]}" \
        bash -c 'for _ in $(seq "$1"); do "${@:3}" > "$2" 2>&1 || true; done' _ "$runs" "$out" "$@" || true
    awk -v n="$runs" '{ printf "%.4f:%d\n", ($1 + $2) / n, n }' "$work/time" | tail -1
}
printf "%-34s %7s %14s %14s %9s %9s %9s %7s\n" case facets "optimize cm²" "evolver cm²" "diff %" "opt CPU" "evol CPU" ratio
[ "${REFERENCE:-0}" = 1 ] && echo "(REFERENCE=1: each row ends with Evolver's tangentially relaxed area and optimize's difference to it)"
for c in "${cases[@]}"; do
    file=${c%%:*}; res=${c##*:}; name=$(basename "$file" .toml)_$res
    "$export_bin" "$file" "$work/$name.fe" "$res" 100 2>"$work/export.log"
    facets=$(grep -o '[0-9]* triangles' "$work/export.log" | cut -d' ' -f1)
    # Same file, same resolution, no edge flips.
    sed -e "s/^resolution = .*/resolution = $res/" "$file" > "$work/$name.toml"
    if grep -q '^\[quality\]' "$work/$name.toml"; then
        sed -i -e '/^\[quality\]/a flip_rounds = 0' -e '/^flip_rounds = [1-9]/d' "$work/$name.toml"
    else
        printf '\n[quality]\nflip_rounds = 0\n' >> "$work/$name.toml"
    fi
    if [ "${STABILITY:-0}" != 1 ]; then
        printf '\n[stability]\neigenvalues = 0\n' >> "$work/$name.toml"
    fi
    if [ -n "${FORMULATION:-}" ]; then
        sed -i -e '/^formulation = /d' -e "0,/^name = .*/s//&\nformulation = \"$FORMULATION\"/" "$work/$name.toml"
    fi
    if [ -n "${QP:-}" ]; then
        if grep -q '^\[solver\]' "$work/$name.toml"; then
            sed -i -e '/^qp = /d' "$work/$name.toml"
            sed -i -e "/^\[solver\]/a qp = \"$QP\"" "$work/$name.toml"
        else
            printf '\n[solver]\nqp = "%s"\n' "$QP" >> "$work/$name.toml"
        fi
    fi
    ours=""; theirs=""
    for _ in $(seq "$ROUNDS"); do
        ours="$ours $(cpu "$work/$name.json" "$bin" cmc "$work/$name.toml" -o "$work/out_$name" --json -q --threads 1)"
        theirs="$theirs $(cpu "$work/$name.evolver.log" "$EVOLVER" -x -f "$work/run.cmd" "$work/$name.fe")"
    done
    : > "$work/$name.ref.log"
    if [ "${REFERENCE:-0}" = 1 ]; then
        timeout "$LIMIT" "$EVOLVER" -x -f "$work/ref.cmd" "$work/$name.fe" > "$work/$name.ref.log" 2>&1 || true
    fi
    : > "$work/$name.answer.log"; : > "$work/$name.confirm.log"
    if [ "${CONFIRM:-0}" = 1 ]; then
        # optimize's answer (the last timed run's result.json, same resolution, no flips).
        if "$export_bin" "$file" "$work/$name.answer.fe" "$res" 100 "$work/out_$name/result.json" 2>>"$work/export.log"; then
            timeout "$LIMIT" "$EVOLVER" -x -f "$work/answer.cmd" "$work/$name.answer.fe" > "$work/$name.answer.log" 2>&1 || true
            timeout "$LIMIT" "$EVOLVER" -x -f "$work/confirm.cmd" "$work/$name.answer.fe" > "$work/$name.confirm.log" 2>&1 || true
        else
            echo "ANSWER_NOT_EXPORTED $(tail -1 "$work/export.log")" > "$work/$name.answer.log"
        fi
    fi
    python3 - "$work/$name.json" "$work/$name.evolver.log" "$c" "$facets" "$ours" "$theirs" \
        "$work/$name.ref.log" "$work/$name.confirm.log" "$work/$name" "$work/summary" <<'PY'
import json, os, re, sys
sys.path.insert(0, "benches/peers")
from evolver_angles import describe
summary, log, case, facets, ours_cpu, theirs_cpu, ref_log, confirm_log, stem, table = sys.argv[1:]
def slurp(path):
    # A log's text; empty when the run was cut off before writing it (LIMIT).
    try:
        return open(path).read()
    except OSError:
        return ""
try:
    ours = json.load(open(summary))
    area, status = ours["objective"] * 1e4, f"{ours['status']}, {ours['iterations']} iterations"
except (ValueError, OSError):
    ours, area, status = {}, float("nan"), "no result"
text = slurp(log)
match = re.findall(r"EVOLVER_AREA ([-0-9.eE+]+)", text)
theirs = float(match[-1]) if match else float("nan")
# STABILITY=1: optimize's smallest and sixth eigenvalue and Evolver's six as printed, 1/cm²
# (Evolver's include the rigid modes of a free cluster).
stability = ours.get("figures", {}).get("stability")
def ritz(text):
    # The six values Evolver's ritz prints after its last "ritz(" command, as printed.
    values = re.findall(r"^\s*\d+\.\s+(\S+)\s*$", text.split("ritz(")[-1], re.M)
    return " ".join(f"{float(v):.4g}" for v in values[:6])
if stability:
    status += ("; optimize λ " + " ".join(f"{v * 1e-4:.4g}" for v in stability["smallest_eigenvalues"])
               + " /cm², Evolver ritz " + ritz(text))
def best(readings):
    # "seconds:runs" per round; the fastest round.
    return min((float(t), int(n)) for t, n in (r.split(":") for r in readings.split()))
(t_ours, n_ours), (t_theirs, n_theirs) = best(ours_cpu), best(theirs_cpu)
diff = 100 * (area - theirs) / theirs if theirs else float("nan")
ref_text = slurp(ref_log)
relaxed = re.findall(r"EVOLVER_RELAXED_AREA ([-0-9.eE+]+)", ref_text)
ref = float(relaxed[-1]) if relaxed else float("nan")
if relaxed:
    status += f"; Evolver relaxed {ref:.6f} cm², optimize {100 * (area - ref) / ref:+.4f} %"
print(f"{case:34s} {facets:>7s} {area:14.6f} {theirs:14.6f} "
      f"{diff:9.4f} {t_ours:9.4f} {t_theirs:9.4f} "
      f"{t_ours / max(t_theirs, 1e-9):7.2f}   ({status}; runs {n_ours} / {n_theirs})")
def probes(text):
    # Evolver's inertia in normal motion at each marked point: "N <" eigenvalues below 0.
    return {name: f"{below}<, {zero}==, {above}>" for name, below, zero, above in re.findall(
        r"EVOLVER_PROBE (\w+)\s.*?Eigencounts:\s*(\d+) <,\s*(\d+) ==,\s*(\d+) >", text, re.S)}
def angles(path):
    try:
        return describe(path)
    except (OSError, ValueError, KeyError, IndexError) as e:
        return f"not read ({e})"
# REFERENCE=1 / CONFIRM=1: per case, the points compared, their inertia in normal motion and
# their triangles, then one line of the closing table.
lines = []
if relaxed:
    lines.append(f"Evolver from the shared start, relaxed: {ref:.6f} cm², normal-motion inertia "
                 f"{probes(ref_text).get('relaxed', '?')}; {angles(stem + '.fe.dmp')}")
answer_text = slurp(stem + ".answer.log")
confirm_text = answer_text + slurp(confirm_log)
nan = float("nan")
loaded = re.findall(r"EVOLVER_LOADED_AREA ([-0-9.eE+]+)", confirm_text)
projected = re.findall(r"EVOLVER_PROJECTED_AREA ([-0-9.eE+]+)", confirm_text)
projected = float(projected[-1]) if projected else nan
standard = re.findall(r"EVOLVER_AREA ([-0-9.eE+]+)", confirm_text)
answer_relaxed = re.findall(r"EVOLVER_RELAXED_AREA ([-0-9.eE+]+)", confirm_text)
confirmed = float(standard[-1]) if standard else nan
confirmed_relaxed = float(answer_relaxed[-1]) if answer_relaxed else nan
failed = re.findall(r"ANSWER_NOT_EXPORTED (.*)", answer_text)
if failed:
    lines.append(f"optimize's answer not exported: {failed[-1]}")
if loaded:
    inertia = probes(confirm_text)
    lines.append(f"optimize's answer in Evolver: total_area {float(loaded[-1]):.9f} cm² "
                 f"(optimize {area:.9f}), on Evolver's volumes {projected:.9f} "
                 f"({100 * (projected - area) / area:+.6f} %), normal-motion inertia "
                 f"{inertia.get('loaded', '?')}; {angles(stem + '.answer.fe')}")
    if "ritz(" in answer_text:
        lines.append(f"Evolver's ritz at optimize's answer: {ritz(answer_text)} /cm²")
    lines.append(f"Evolver from optimize's answer, standard script: {confirmed:.9f} cm² "
                 f"({100 * (confirmed - area) / area:+.6f} % from the answer), inertia "
                 f"{inertia.get('standard', '?')}")
    if answer_relaxed:
        lines.append(f"Evolver from optimize's answer, relaxed: {confirmed_relaxed:.9f} cm² "
                     f"({100 * (confirmed_relaxed - area) / area:+.6f} % from the answer), "
                     f"inertia {inertia.get('relaxed', '?')}")
    lines.append(f"Evolver's end from optimize's answer: {angles(stem + '.answer.fe.dmp')}")
for line in lines:
    print(f"    {line}")
if lines:
    with open(table, "a") as out:
        out.write(f"{case:34s} {facets:>7s} {theirs:14.6f} {ref:14.6f} {confirmed:14.6f} "
                  f"{confirmed_relaxed:14.6f} {area:14.6f}\n")
PY
done
if [ -s "$work/summary" ]; then
    echo
    echo "Areas, cm² (nan: not run): Evolver's standard script from the shared start and relaxed"
    echo "tangentially too (REFERENCE=1); the same two from optimize's answer (CONFIRM=1); optimize."
    printf "%-34s %7s %14s %14s %14s %14s %14s\n" case facets "evol start" "evol st. rel." \
        "evol answer" "evol ans. rel." optimize
    cat "$work/summary"
fi
