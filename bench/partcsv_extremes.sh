#!/usr/bin/env bash
# Cuts DualSPHysics's PartCsv_NNNN.csv files, in place, to their header and the fluid particles
# (Type 3) with the smallest and the largest Pos.x: all bench/peer_compare.py reads of the Martin
# & Moyce runs (the column's back row at t = 0, the front). A device run's PartCsv files at a/120
# are ~150 MB; cut, they come back in a few kB.
#
#   bench/partcsv_extremes.sh PEER_RUN_DIR...    (each with data/PartCsv_*.csv)
set -euo pipefail
[[ $# -gt 0 ]] || { echo "usage: bench/partcsv_extremes.sh PEER_RUN_DIR..." >&2; exit 2; }
for dir in "$@"; do
  shopt -s nullglob
  files=("$dir"/data/PartCsv_*.csv)
  [[ ${#files[@]} -gt 0 ]] || { echo "partcsv_extremes.sh: $dir/data has no PartCsv_*.csv" >&2; exit 2; }
  for f in "${files[@]}"; do
    awk -F';' '
      header == 0 {
        print
        if ($0 ~ /Pos\.x/) {
          header = 1
          for (i = 1; i <= NF; ++i) { if ($i ~ /^Pos\.x/) xi = i; if ($i == "Type") ti = i }
          if (!xi || !ti) { print FILENAME ": no Pos.x or Type column" > "/dev/stderr"; exit 2 }
        }
        next
      }
      $ti == 3 {
        if (n == 0 || $xi < lo) { lo = $xi; low = $0 }
        if (n == 0 || $xi > hi) { hi = $xi; high = $0 }
        ++n
      }
      END { if (n > 0) { print low; print high } }' "$f" > "$f.cut"
    mv "$f.cut" "$f"
  done
done
