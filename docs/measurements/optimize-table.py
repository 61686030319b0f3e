#!/usr/bin/env python3
"""The table of docs/measurements/optimize.md from `rtmesh optimize --json` lines.

    rtmesh optimize ../shared/meshes -o OUT --json --jobs 1 > batch.jsonl
    python3 docs/measurements/optimize-table.py batch.jsonl
"""
import json
import sys


def pct(before, after):
    return f"{100 * (after / before - 1):+.1f}%" if before else "—"


rows = [json.loads(line) for line in open(sys.argv[1]) if line.strip()]
print("| file | triangles in → out | paired | primary box/ray | primary Mrays/s | diffuse Mrays/s "
      "| same hits | Embree quads: primary, diffuse Mrays/s | Embree BVH bytes | Embree build | seconds (prepare) |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
for r in sorted(rows, key=lambda r: r["input"]):
    name = r["input"].split("/meshes/")[-1]
    if not r["ok"]:
        print(f"| {name} | failed: {r['error']} |")
        continue
    b, a = r["before"], r["after"]
    prod = {p["workload"]: p for p in r.get("production", [])}
    if prod:
        p = prod["primary"]
        embree = f"{pct(p['mrays_before'], p['mrays_after'])}, {pct(prod['diffuse']['mrays_before'], prod['diffuse']['mrays_after'])}"
        bytes_ratio = f"{p['bvh_bytes_after'] / p['bvh_bytes_before']:.2f}×"
        build_ratio = f"{p['build_seconds_after'] / p['build_seconds_before']:.2f}×"
    else:
        embree = bytes_ratio = build_ratio = "—"
    print(
        f"| {name} | {r['triangles_in']} → {r['triangles_out']} | {100 * r['pair_ratio']:.2f}% "
        f"| {b['primary']['box_tests_per_ray']:.2f} → {a['primary']['box_tests_per_ray']:.2f} "
        f"| {b['primary']['mrays_per_s']:.1f} → {a['primary']['mrays_per_s']:.1f} ({pct(b['primary']['mrays_per_s'], a['primary']['mrays_per_s'])}) "
        f"| {b['diffuse']['mrays_per_s']:.1f} → {a['diffuse']['mrays_per_s']:.1f} ({pct(b['diffuse']['mrays_per_s'], a['diffuse']['mrays_per_s'])}) "
        f"| {100 * r['same_hits']['share']:.3f}% "
        f"| {embree} | {bytes_ratio} | {build_ratio} | {r['seconds']:.2f} ({r['step_seconds']['prepare']:.2f}) |"
    )
