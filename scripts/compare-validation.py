#!/usr/bin/env python3
"""Compares two `dysa validate` outputs (say, --device cpu and --device cuda) row by row.

    scripts/compare-validation.py CPU.txt GPU.txt [--max-points 0.2]

Reads the table rows `case  measure  value  target  status` and prints, for each measure, both
values and their difference. A value in percent must agree within --max-points percentage
points; a count (solves stopped at the cap) must be equal. Exits 1 when a row differs by more,
or when the two outputs do not list the same rows.
"""
import argparse
import re
import sys

ROW = re.compile(r"^(?P<name>\S.*?)\s+(?P<value>-?[\d.]+)(?P<pct>%?)\s+(?P<target>-?[\d.]+)%?\s+"
                 r"(?P<status>ok|MISSED|missed|FAIL\w*)\s*$")


def rows(path):
    table = {}
    with open(path, encoding="utf-8") as f:
        for line in f:
            m = ROW.match(line.rstrip("\n"))
            if m and not line.startswith("case "):
                table[m.group("name").strip()] = (float(m.group("value")), m.group("pct") == "%")
    return table


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("reference")
    parser.add_argument("other")
    parser.add_argument("--max-points", type=float, default=0.2,
                        help="largest difference of a percentage, in percentage points")
    args = parser.parse_args()
    a, b = rows(args.reference), rows(args.other)
    if not a or set(a) != set(b):
        print(f"the outputs list different rows: {sorted(set(a) ^ set(b)) or 'none found'}")
        return 1
    worst, failed = 0.0, False
    print(f"{'measure':55s} {'reference':>10s} {'other':>10s} {'diff':>8s}")
    for name in a:
        (x, pct), (y, _) = a[name], b[name]
        diff = abs(x - y)
        ok = diff <= args.max_points if pct else x == y
        worst = max(worst, diff if pct else 0.0)
        failed |= not ok
        unit = "%" if pct else ""
        print(f"{name:55s} {x:9.2f}{unit:1s} {y:9.2f}{unit:1s} {diff:7.2f}{'' if ok else '  EXCEEDS'}")
    print(f"largest difference {worst:.2f} points (allowed {args.max_points}): "
          f"{'FAILED' if failed else 'agree'}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
