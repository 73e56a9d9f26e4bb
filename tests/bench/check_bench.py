#!/usr/bin/python3
"""CTest smoke test of scripts/bench (label `bench`): runs `scripts/bench --quick` into a
temporary folder and checks that every CSV row is complete and every chart file exists.
usage: check_bench.py SOURCE_DIR BUILD_DIR"""
import csv
import os
import subprocess
import sys
import tempfile

src, build = sys.argv[1], sys.argv[2]
with tempfile.TemporaryDirectory(prefix="rayclass-bench-test-") as out:
    p = subprocess.run(["/usr/bin/python3", os.path.join(src, "scripts", "bench"), "--quick",
                        "--build", build, out])
    if p.returncode != 0:
        sys.exit("scripts/bench --quick failed with %d" % p.returncode)
    failures = []
    for name in ("results.csv", "accuracy.csv", "micro.csv"):
        path = os.path.join(out, name)
        if not os.path.exists(path):
            failures.append("missing " + name)
            continue
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
        if len(rows) < 2:
            failures.append("%s has no data rows" % name)
            continue
        header = rows[0]
        for i, row in enumerate(rows[1:], start=2):
            if len(row) != len(header) or any(v.strip() == "" for v in row):
                failures.append("%s line %d incomplete: %s" % (name, i, row))
    with open(os.path.join(out, "results.csv"), newline="") as f:
        results = list(csv.DictReader(f))
    methods = {r["method"] for r in results}
    for m in ("classify/scalar", "classify/vertex", "classify/fragment", "classify/auto", "bvh",
              "brute"):
        if m not in methods:
            failures.append("results.csv has no rows for " + m)
    kinds = {r["kind"] for r in results}
    for k in ("eye", "shadow", "reflection", "refraction", "diffuse"):
        if k not in kinds:
            failures.append("results.csv has no rows for ray kind " + k)
    # Every rayclass query finds the same hits on the same rays (Embree's watertight triangle
    # test may decide a grazing ray differently from Moeller-Trumbore, so it is not compared).
    hits = {}
    for r in results:
        if r["method"].startswith("embree"):
            continue
        hits.setdefault((r["scene"], r["camera"], r["kind"]), set()).add(r["hits"])
    for key, values in hits.items():
        if len(values) != 1:
            failures.append("methods disagree on the hits of %s: %s" % (key, sorted(values)))
    for name in ("styles.png", "accel.png", "speed_accuracy.png", "micro.png", "summary.md",
                 "machine.txt"):
        path = os.path.join(out, name)
        if not os.path.exists(path) or os.path.getsize(path) == 0:
            failures.append("missing or empty " + name)
    if failures:
        print("\n".join(failures))
        sys.exit(1)
    print("bench smoke test: %d result rows, every file present" % len(results))
