#!/usr/bin/env bash
# The same case, the same particle spacing and the same machine for DualSPHysics 5.4 and the
# project (bench/README.md, "Against DualSPHysics").
#
#   bench/peer_dualsphysics.sh --case spheric2|dambreak|martinmoyce --out DIR [--peer DIR]
#                              [--dp LIST] [--tmax S] [--device gpu|cpu] [--threads N]
#                              [--project-build DIR] [--project-solvers LIST]
#
# --peer: the directory with DualSPHysics5.4_linux64_sm90.xz, GenCase_linux64_v5.0.229.xz and
#   the case XMLs (default ../shared/peers/dualsphysics from the repository's root; `.peer` on
#   the GPU box). Nothing from it is copied into the repository: the binaries are unpacked into a
#   temporary directory that is removed at the end.
# --dp: comma list of spacings in m. Defaults: spheric2 0.02,0.01; dambreak 0.0085;
#   martinmoyce a/15,a/30,a/60 (a = 0.05715 m; the peer's XMLs exist for a/15, a/30, a/60,
#   a/120, and only those spacings are accepted for this case).
# --tmax: simulated seconds. Defaults: spheric2 1.0, dambreak 0.5, martinmoyce 0.2 (the XML's).
# --device: gpu (DualSPHysics -gpu, the project on cuda) or cpu (DualSPHysics -cpu
#   -ompthreads:N, the project with N OpenMP threads). Default: gpu when nvidia-smi lists one.
# --threads: CPU threads for both codes on the cpu device (default: all cores).
# --project-build: the project's build directory (default build/release): bench/accuracy_bench
#   and clients/cli/dysa.
# --project-solvers: spheric2 only, a comma list of the project's solvers (default: the scene's,
#   wcsph). The first is the row "project"; each further one runs accuracy_bench --solvers S
#   beside it and is the row "project_S" of every output (e.g. wcsph,dfsph).
#
# For each spacing: GenCase + DualSPHysics, then the project on the same scene:
#   spheric2     accuracy_bench --case spheric_test2 --spacings DP --end TMAX --step-series
#   dambreak     dysa run PEER/project_case_dambreak.json --set particle_spacing=DP
#   martinmoyce  dysa run on scenes/validation/dam_break_martin_moyce.json with the slab kept
#                4 particles thick at DP (as the validation case does)
# and writes, under --out, with TAG the GPU's name (spaces to _) or "cpu" on the cpu device:
#   peer_throughput_CASE_TAG.csv   wall time, steps, particles, particle-steps/s and pair
#                                  interactions/s of both codes (neighbours are estimates)
#   peer_compare_CASE_TAG.csv/png  spheric2 and martinmoyce: bench/peer_compare.py's measures
#   peer_series_*_TAG.csv          spheric2: both codes' gauges as the same 1 ms measures
#   raw_CASE_TAG/                  the codes' logs and gauge files (not meant for the repository)
#   compare_command.txt            where /usr/bin/python3 lacks numpy or matplotlib (a GPU box
#                                  without Debian's packages): peer_compare.py's arguments, to
#                                  run where they are installed (the raw outputs are kept)
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
peer="$repo/../shared/peers/dualsphysics"
case_name=""
out=""
dp_list=""
tmax=""
device=""
threads=$(nproc)
build="$repo/build/release"
project_solvers=""

die() {
  echo "peer_dualsphysics.sh: $*" >&2
  exit 2
}
need_value() { [[ $# -ge 2 && -n "$2" ]] || die "$1 needs a value"; }
is_number() { [[ "$1" =~ ^([0-9]+\.?[0-9]*|\.[0-9]+)([eE][-+]?[0-9]+)?$ ]]; }

while [[ $# -gt 0 ]]; do
  case "$1" in
    --peer) need_value "$@"; peer="$2"; shift 2 ;;
    --case) need_value "$@"; case_name="$2"; shift 2 ;;
    --out) need_value "$@"; out="$2"; shift 2 ;;
    --dp) need_value "$@"; dp_list="$2"; shift 2 ;;
    --tmax) need_value "$@"; tmax="$2"; shift 2 ;;
    --device) need_value "$@"; device="$2"; shift 2 ;;
    --threads) need_value "$@"; threads="$2"; shift 2 ;;
    --project-build) need_value "$@"; build="$2"; shift 2 ;;
    --project-solvers) need_value "$@"; project_solvers="$2"; shift 2 ;;
    -h | --help) sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) die "unknown argument '$1' (allowed: --peer --case --out --dp --tmax --device --threads --project-build --project-solvers)" ;;
  esac
done

case "$case_name" in
  spheric2 | dambreak | martinmoyce) ;;
  "") die "--case is required (allowed: spheric2, dambreak, martinmoyce)" ;;
  *) die "--case '$case_name' is not one of: spheric2, dambreak, martinmoyce" ;;
esac
[[ -n "$out" ]] || die "--out is required (a directory for the CSVs)"
if [[ -z "$device" ]]; then
  if command -v nvidia-smi > /dev/null && nvidia-smi -L > /dev/null 2>&1; then device=gpu; else device=cpu; fi
fi
case "$device" in
  gpu | cpu) ;;
  *) die "--device '$device' is not one of: gpu, cpu" ;;
esac
[[ "$threads" =~ ^[1-9][0-9]*$ ]] || die "--threads '$threads' must be a positive integer"
extra_solvers=()
if [[ -n "$project_solvers" ]]; then
  [[ "$case_name" == spheric2 ]] || die "--project-solvers is for --case spheric2"
  IFS=',' read -r -a solvers <<< "$project_solvers"
  for s in "${solvers[@]}"; do
    case "$s" in
      wcsph | dfsph) ;;
      *) die "--project-solvers value '$s' is not one of: wcsph, dfsph (the physical solvers)" ;;
    esac
  done
  [[ "${solvers[0]}" == wcsph ]] || die "--project-solvers must start with wcsph (the scene's solver, the row \"project\")"
  extra_solvers=("${solvers[@]:1}")
fi
[[ -d "$peer" ]] || die "--peer '$peer' is not a directory"
peer=$(cd "$peer" && pwd)
for f in DualSPHysics5.4_linux64_sm90.xz GenCase_linux64_v5.0.229.xz; do
  [[ -f "$peer/$f" ]] || die "--peer '$peer' has no $f"
done

a=0.05715 # m, the Martin & Moyce column
case "$case_name" in
  spheric2) dp_list="${dp_list:-0.02,0.01}"; tmax="${tmax:-1.0}" ;;
  dambreak) dp_list="${dp_list:-0.0085}"; tmax="${tmax:-0.5}" ;;
  martinmoyce) dp_list="${dp_list:-$(awk -v a=$a 'BEGIN { printf "%.6g,%.6g,%.6g", a/15, a/30, a/60 }')}"; tmax="${tmax:-0.2}" ;;
esac
positive() { is_number "$1" && awk -v v="$1" 'BEGIN { exit !(v > 0) }'; }
positive "$tmax" || die "--tmax '$tmax' must be a positive number of seconds"
IFS=',' read -r -a dps <<< "$dp_list"
[[ ${#dps[@]} -gt 0 ]] || die "--dp '$dp_list' is empty (a comma list of spacings in m)"
for dp in "${dps[@]}"; do
  positive "$dp" || die "--dp value '$dp' must be a positive number (m)"
done
# The Martin & Moyce XMLs are one per spacing: dp must be a/N for N in 15, 30, 60, 120.
mm_n() {
  awk -v a=$a -v d="$1" 'BEGIN { n = a / d; split("15 30 60 120", ok, " ");
    for (i in ok) if (n > ok[i] - 0.01 && n < ok[i] + 0.01) { print ok[i]; exit }
    print "" }'
}
if [[ "$case_name" == martinmoyce ]]; then
  for dp in "${dps[@]}"; do
    [[ -n "$(mm_n "$dp")" ]] || die "--dp value '$dp' for martinmoyce must be a/15, a/30, a/60 or a/120 (a = $a m)"
  done
fi

accuracy_bench="$build/bench/accuracy_bench"
dysa="$build/clients/cli/dysa"
for bin in "$accuracy_bench" "$dysa"; do
  [[ -x "$bin" ]] || die "--project-build '$build' has no $bin; build it (cmake --build $build --target accuracy_bench dysa)"
done

if [[ "$device" == cpu ]]; then
  tag=cpu
  peer_dev=(-cpu "-ompthreads:$threads")
  project_dev=(--device cpu --threads "$threads")
else
  command -v nvidia-smi > /dev/null || die "--device gpu needs nvidia-smi (no NVIDIA driver found)"
  tag=$(nvidia-smi --query-gpu=name --format=csv,noheader | head -n 1 | tr ' ' '_')
  [[ -n "$tag" ]] || die "--device gpu: nvidia-smi lists no GPU"
  peer_dev=(-gpu)
  project_dev=(--device cuda)
fi

mkdir -p "$out"
out=$(cd "$out" && pwd)
raw="$out/raw_${case_name}_$tag"
mkdir -p "$raw"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
xz -dc "$peer/GenCase_linux64_v5.0.229.xz" > "$work/GenCase"
xz -dc "$peer/DualSPHysics5.4_linux64_sm90.xz" > "$work/DualSPHysics"
chmod +x "$work/GenCase" "$work/DualSPHysics"

now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.3f", b - a }'; }
# The value after "KEY" on its line of Run.out, without thousands separators.
run_out() { grep -m 1 -- "$2" "$1" | sed 's/^[^:=]*[:=][ .]*//; s/,//g; s/ .*//'; }

throughput="$out/peer_throughput_${case_name}_$tag.csv"
echo "code,case,dp_m,device,tag,threads,particles,fluid_particles,steps,simulated_s,wall_s,run_s,steps_per_s,particle_steps_per_s,fluid_particle_steps_per_s,neighbours,neighbours_basis,pairs_per_s" > "$throughput"
# code dp particles fluid steps simulated wall run neighbours basis
row() {
  awk -v code="$1" -v cs="$case_name" -v dp="$2" -v dev="$device" -v tag="$tag" -v th="$threads" \
    -v np="$3" -v nf="$4" -v st="$5" -v sim="$6" -v wall="$7" -v run="$8" -v nb="$9" -v basis="${10}" \
    'BEGIN { ps = np * st / run; printf "%s,%s,%s,%s,%s,%s,%d,%d,%d,%.6g,%.3f,%.3f,%.6g,%.6g,%.6g,%.4g,%s,%.6g\n",
      code, cs, dp, dev, tag, (dev == "cpu" ? th : ""), np, nf, st, sim, wall, run, st / run, ps,
      nf * st / run, nb, basis, ps * nb }' >> "$throughput"
  tail -n 1 "$throughput"
}

# DualSPHysics on XML $1 (without _Def.xml's .xml) at dp $2 into $3; extra solver arguments after.
run_peer() {
  local def="$1" dp="$2" dir="$3"
  shift 3
  mkdir -p "$dir"
  cp "$peer/$def.xml" "$work/"
  local gencase_args=(-save:all)
  [[ "$case_name" == martinmoyce ]] || gencase_args+=("-dp:$dp")
  (cd "$work" && ./GenCase "$def" "$dir/Case" "${gencase_args[@]}") > "$dir/GenCase.log" 2>&1 ||
    { tail -n 20 "$dir/GenCase.log" >&2; die "GenCase failed on $def at dp $dp (log: $dir/GenCase.log)"; }
  local t0 t1
  t0=$(now)
  "$work/DualSPHysics" "${peer_dev[@]}" "$dir/Case" "$dir" "-tmax:$tmax" -svres:1 "$@" > "$dir/DualSPHysics.log" 2>&1 ||
    { tail -n 20 "$dir/DualSPHysics.log" >&2; die "DualSPHysics failed on $def at dp $dp (log: $dir/DualSPHysics.log)"; }
  t1=$(now)
  peer_wall=$(elapsed "$t0" "$t1")
  rm -f "$dir"/data/Part_*.bi4 "$dir"/*.vtk "$dir"/Case.bi4
  local r="$dir/Run.out"
  peer_particles=$(run_out "$r" "Particles of simulation (initial)")
  peer_fluid=$(grep -m 1 '^Total particles:' "$r" | sed 's/.*fluid=\([0-9]*\).*/\1/')
  peer_steps=$(run_out "$r" "Steps of simulation")
  peer_run=$(run_out "$r" "Simulation Runtime")
  peer_h=$(grep -m 1 '^KernelH=' "$r" | sed 's/^KernelH=\([0-9.eE+-]*\).*/\1/')
  peer_sim=$(grep -m 1 '^TimeMax=' "$r" | sed 's/^TimeMax=//')
  # Neighbours of a particle inside a full lattice within the Wendland support 2h: an estimate.
  if grep -q '2D-Simulation' "$r"; then
    peer_nb=$(awk -v h="$peer_h" -v d="$dp" 'BEGIN { print 3.14159265358979 * (2 * h) ^ 2 / d ^ 2 }')
    peer_basis="estimate: pi (2h)^2 / dp^2 (2D lattice) with h=${peer_h} m from Run.out"
  else
    peer_nb=$(awk -v h="$peer_h" -v d="$dp" 'BEGIN { print 4 / 3 * 3.14159265358979 * (2 * h) ^ 3 / d ^ 3 }')
    peer_basis="estimate: (4/3) pi (2h)^3 / dp^3 (full lattice) with h=${peer_h} m from Run.out"
  fi
}
# The project's neighbours within its kernel support 2 h, h = R dp: R is the scene's
# smoothing_length_ratio, or that parameter's default (`dysa run --help`), where the build has
# one; without it the support is 2 dp (params.h: particle_spacing).
project_neighbours() {
  local ratio
  ratio=$(/usr/bin/python3 -c 'import json, sys; print(json.load(open(sys.argv[1])).get("params", {}).get("smoothing_length_ratio", ""))' "$1")
  if [[ -z "$ratio" ]]; then
    ratio=$("$dysa" run --help | awk '$1 == "smoothing_length_ratio" { for (i = 2; i < NF; ++i) if ($i == "default") { sub(/,$/, "", $(i + 1)); print $(i + 1) } }')
  fi
  if [[ -n "$ratio" ]]; then
    project_nb=$(awk -v r="$ratio" 'BEGIN { print 4 / 3 * 3.14159265358979 * (2 * r) ^ 3 }')
    project_basis="estimate: (4/3) pi (2h)^3 / dp^3 (full lattice) with h = $ratio dp (smoothing_length_ratio)"
  else
    project_nb=$(awk 'BEGIN { print 4 / 3 * 3.14159265358979 * 2 ^ 3 }')
    project_basis="estimate: (4/3) pi (2dp)^3 / dp^3 (full lattice; support 2 dp)"
  fi
}

# The numbers of `dysa run`'s summary line: "N steps of P particles in W s ...".
dysa_summary() { grep -m 1 ' steps of .* particles in ' "$1" | awk '{ print $1, $4, $7 }'; }

compare_args=()
for dp in "${dps[@]}"; do
  echo "== $case_name dp $dp, tmax $tmax, $device ($tag)" >&2
  pdir="$raw/peer_dp$dp"
  jdir="$raw/project_dp$dp"
  mkdir -p "$jdir"
  case "$case_name" in
    spheric2)
      run_peer CaseSphericTest2_Def "$dp" "$pdir" -sv:none
      row dualsphysics "$dp" "$peer_particles" "$peer_fluid" "$peer_steps" "$peer_sim" "$peer_wall" "$peer_run" "$peer_nb" "$peer_basis"
      t0=$(now)
      "$accuracy_bench" --case spheric_test2 --spacings "$dp" --end "$tmax" --step-series \
        "${project_dev[@]}" --out "$jdir" > "$jdir/accuracy_bench.log" 2>&1 ||
        { tail -n 20 "$jdir/accuracy_bench.log" >&2; die "accuracy_bench failed at dp $dp (log: $jdir/accuracy_bench.log)"; }
      t1=$(now)
      # accuracy_spheric_test2.csv: solver,spacing_m,particles,steps,particle_steps,wall_s,end_s,...
      read -r jp js jrun jsim < <(awk -F, 'NR == 2 { print $3, $4, $6, $7 }' "$jdir/accuracy_spheric_test2.csv")
      project_neighbours "$repo/scenes/validation/spheric_test2.json"
      row project "$dp" "$jp" "$jp" "$js" "$jsim" "$(elapsed "$t0" "$t1")" "$jrun" "$project_nb" "$project_basis"
      steps_file=$(ls "$jdir"/spheric_test2_steps_*.csv)
      compare_args+=(--run "$dp" "$pdir" "$steps_file")
      for s in "${extra_solvers[@]}"; do
        sdir="$raw/project_${s}_dp$dp"
        mkdir -p "$sdir"
        t0=$(now)
        "$accuracy_bench" --case spheric_test2 --spacings "$dp" --end "$tmax" --step-series \
          --solvers "$s" "${project_dev[@]}" --out "$sdir" > "$sdir/accuracy_bench.log" 2>&1 ||
          { tail -n 20 "$sdir/accuracy_bench.log" >&2; die "accuracy_bench --solvers $s failed at dp $dp (log: $sdir/accuracy_bench.log)"; }
        t1=$(now)
        read -r jp js jrun jsim < <(awk -F, 'NR == 2 { print $3, $4, $6, $7 }' "$sdir/accuracy_spheric_test2.csv")
        row "project_$s" "$dp" "$jp" "$jp" "$js" "$jsim" "$(elapsed "$t0" "$t1")" "$jrun" "$project_nb" "$project_basis"
        compare_args+=(--project-run "$s" "$dp" "$(ls "$sdir"/spheric_test2_steps_*.csv)")
      done
      ;;
    dambreak)
      run_peer CaseDambreak_Def "$dp" "$pdir" -sv:none
      row dualsphysics "$dp" "$peer_particles" "$peer_fluid" "$peer_steps" "$peer_sim" "$peer_wall" "$peer_run" "$peer_nb" "$peer_basis"
      [[ -f "$peer/project_case_dambreak.json" ]] || die "--peer '$peer' has no project_case_dambreak.json"
      t0=$(now)
      "$dysa" run "$peer/project_case_dambreak.json" --set "particle_spacing=$dp" --end-time "$tmax" \
        "${project_dev[@]}" --out "$jdir" > "$jdir/dysa_run.log" 2>&1 ||
        { tail -n 20 "$jdir/dysa_run.log" >&2; die "dysa run failed at dp $dp (log: $jdir/dysa_run.log)"; }
      t1=$(now)
      read -r js jp jrun < <(dysa_summary "$jdir/dysa_run.log")
      project_neighbours "$peer/project_case_dambreak.json"
      row project "$dp" "$jp" "$jp" "$js" "$tmax" "$(elapsed "$t0" "$t1")" "$jrun" "$project_nb" "$project_basis"
      ;;
    martinmoyce)
      n=$(mm_n "$dp")
      run_peer "CaseMartinMoyce2D_a${n}_Def" "$dp" "$pdir" -sv:csv
      row dualsphysics "$dp" "$peer_particles" "$peer_fluid" "$peer_steps" "$peer_sim" "$peer_wall" "$peer_run" "$peer_nb" "$peer_basis"
      # The validation scene with its slab 4 particles thick at dp (ValidationOptions' default)
      # and the front probed every 2 ms, as the peer saves its parts.
      /usr/bin/python3 - "$repo/scenes/validation/dam_break_martin_moyce.json" "$dp" "$jdir/scene.json" << 'EOF'
import json, sys
scene = json.load(open(sys.argv[1]))
d = float(sys.argv[2])
scene["domain"]["max"][2] = 4 * d
for b in scene["fluid_blocks"]:
    b["center"][2], b["size"][2] = 2 * d, 4 * d
scene["params"]["particle_spacing"] = d
scene["probe_interval"] = 0.002
json.dump(scene, open(sys.argv[3], "w"), indent=1)
EOF
      t0=$(now)
      "$dysa" run "$jdir/scene.json" --end-time "$tmax" "${project_dev[@]}" --out "$jdir" > "$jdir/dysa_run.log" 2>&1 ||
        { tail -n 20 "$jdir/dysa_run.log" >&2; die "dysa run failed at dp $dp (log: $jdir/dysa_run.log)"; }
      t1=$(now)
      read -r js jp jrun < <(dysa_summary "$jdir/dysa_run.log")
      project_neighbours "$jdir/scene.json"
      row project "$dp" "$jp" "$jp" "$js" "$tmax" "$(elapsed "$t0" "$t1")" "$jrun" "$project_nb" "$project_basis"
      compare_args+=(--run "$dp" "$pdir" "$jdir/probes.csv")
      ;;
  esac
done
echo "wrote $throughput" >&2

if [[ ${#compare_args[@]} -gt 0 ]]; then
  compare=("$repo/bench/peer_compare.py" --case "$case_name" --tag "$tag" --tmax "$tmax"
           --repo "$repo" --out "$out" "${compare_args[@]}")
  if /usr/bin/python3 -c 'import numpy, matplotlib' 2> /dev/null; then
    /usr/bin/python3 "${compare[@]}"
  else
    # A GPU box without Debian's python3-numpy and python3-matplotlib: the runs' outputs stay
    # under $raw, and the comparison runs where they are installed, with the same arguments.
    echo "${compare[*]}" > "$out/compare_command.txt"
    echo "peer_dualsphysics.sh: /usr/bin/python3 has no numpy or matplotlib here; the outputs are" \
      "kept in $raw; run /usr/bin/python3 $(cat "$out/compare_command.txt") where it has them" >&2
  fi
fi
