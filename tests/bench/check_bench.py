#!/usr/bin/python3
"""CTest smoke test of scripts/bench (label `bench`): runs `scripts/bench --quick` into a
temporary folder and checks that every CSV row is complete, that the sweep, scene family,
1-thread, FLIP, raster, micro-variant and patch rows are there, and that every chart file exists.
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
    with open(os.path.join(out, "machine.txt")) as f:
        machine = f.read()
    # raster.csv is left out only where raster_bench found no OpenGL context (said in machine.txt).
    raster_skipped = "raster experiments: skipped" in machine
    csvs = ["results.csv", "sweep.csv", "family.csv", "accuracy.csv", "micro.csv", "patches.csv", "failure.csv"]
    if not raster_skipped:
        csvs.append("raster.csv")
    for name in csvs:
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
    for m in ("auto", "classify/scalar", "classify/vertex", "classify/fragment", "classify/auto",
              "bvh", "kdtree", "grid", "cones", "brute"):
        if m not in methods:
            failures.append("results.csv has no rows for " + m)
    kinds = {r["kind"] for r in results}
    for k in ("eye", "shadow", "reflection", "refraction", "diffuse"):
        if k not in kinds:
            failures.append("results.csv has no rows for ray kind " + k)
    # `auto` is what `rayclass render` uses by default: the headline needs it on every ray kind.
    auto_kinds = {r["kind"] for r in results if r["method"] == "auto" and r["threads"] == "2"}
    if kinds - auto_kinds:
        failures.append("results.csv: no auto rows for " + ", ".join(sorted(kinds - auto_kinds)))
    if not {r["method"] for r in results if r["threads"] == "1"} >= {"classify/fragment", "bvh"}:
        failures.append("results.csv has no 1-thread rows for classify/fragment and bvh")

    def load(name):
        with open(os.path.join(out, name), newline="") as f:
            return list(csv.DictReader(f))

    sweep = load("sweep.csv")
    for param in ("min-candidates", "min-rays"):
        for style in ("classify/vertex", "classify/fragment", "classify/auto"):
            if len({r["value"] for r in sweep if r["param"] == param and r["method"] == style}) < 2:
                failures.append("sweep.csv: fewer than two %s values for %s" % (param, style))
    family = load("family.csv")
    for m in ("classify/auto", "bvh", "brute"):
        if len({r["triangles"] for r in family if r["method"] == m}) < 2:
            failures.append("family.csv: fewer than two scene sizes for " + m)
    # FLIP is a number where flip-evaluator is installed and "missing" otherwise, never empty.
    flip_installed = "image metric: HDR-FLIP" in machine
    def is_number(v):
        try:
            return float(v) >= 0
        except ValueError:
            return False

    for r in load("accuracy.csv"):
        v = r["flip"]
        if (is_number(v) if flip_installed else v == "missing") is False:
            failures.append("accuracy.csv: flip of %s is %r" % (r["setting"], v))
    if not raster_skipped:
        experiments = {r["experiment"] for r in load("raster.csv")}
        for e in ("depth", "hulls", "rotation", "layers"):
            if e not in experiments:
                failures.append("raster.csv has no %s rows" % e)
    patches = load("patches.csv")
    for e in ("boxes", "tessellation") + (() if raster_skipped else ("raster",)):
        if len([r for r in patches if r["experiment"] == e]) < 2:
            failures.append("patches.csv has fewer than two %s rows" % e)
    # The raster pass draws the patches' eye hits exactly as the kernel finds them.
    for r in patches:
        if r["experiment"] == "raster" and r["id_mismatch"] != "0":
            failures.append("patches.csv: raster and kernel eye hits differ: %s" % r)
        if r["experiment"] == "tessellation" and \
                (is_number(r["flip"]) if flip_installed else r["flip"] == "missing") is False:
            failures.append("patches.csv: flip of %s is %r" % (r["setting"], r["flip"]))
    micro_rows = load("micro.csv")
    micro = {(r["kind"], r["method"]) for r in micro_rows}
    # The variants are the same formulas: on the same rays they find the same number of hits.
    for k in ("sphere", "quadric", "triangle"):
        counts = {r["hits"] for r in micro_rows if r["kind"] == k}
        if len(counts) > 1:
            failures.append("micro.csv: %s variants disagree on the hits: %s" % (k, sorted(counts)))
    for k in ("sphere", "quadric", "triangle"):
        for m in ("brute-scalar", "scalar-branch", "scalar-select", "vec16-branch",
                  "vec16-select"):
            if (k, m) not in micro:
                failures.append("micro.csv has no row for %s %s" % (k, m))
    # Every rayclass query gives every ray the same answer, ray by ray: the digest of the
    # primitive ids and distances, and that of the hits' u and v (Embree's watertight triangle
    # test may decide a grazing ray differently from Moeller-Trumbore, so it is not compared).
    for column, what in (("hits_digest", "hits"), ("uv_digest", "hits' u and v")):
        digests = {}
        for r in results:
            if r["method"].startswith("embree"):
                continue
            if not r.get(column):
                failures.append("results.csv: no %s for %s %s" % (column, r["kind"], r["method"]))
            key = (r["scene"], r["camera"], r["kind"])
            digests.setdefault(key, {}).setdefault(r.get(column), []).append(r["method"])
        for key, values in digests.items():
            if len(values) != 1:
                failures.append("methods disagree on the %s of %s, ray by ray: %s" %
                                (what, key, sorted(values.values())))
    failure = load("failure.csv")
    for case in ("grid: teapot in a stadium", "cones: incoherent rays",
                 "classify: diffuse bounces", "kdtree: build time and memory"):
        if not any(r["case"] == case for r in failure):
            failures.append("failure.csv has no rows for " + case)
    failure_digests = {}
    for r in failure:
        if r["hits_digest"] != "-":
            key = (r["case"], r["kind"])
            failure_digests.setdefault(key, {}).setdefault(r["hits_digest"], []).append(r["method"])
    for key, values in failure_digests.items():
        if len(values) != 1:
            failures.append("failure.csv: methods disagree on the hits of %s: %s" %
                            (key, sorted(values.values())))
    for name in ("styles.png", "sweep.png", "accel.png", "scaling.png", "speed_accuracy.png",
                 "micro.png", "raster.png", "patches.png", "failure.png", "summary.md", "machine.txt"):
        path = os.path.join(out, name)
        if not os.path.exists(path) or os.path.getsize(path) == 0:
            failures.append("missing or empty " + name)
    if failures:
        print("\n".join(failures))
        sys.exit(1)
    print("bench smoke test: %d result rows, every file present" % len(results))
