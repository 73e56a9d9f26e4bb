"""scripts/bench's patch experiments on the teapot scene (scenes/teapot.json), rows of patches.csv
and the chart patches.png:

  boxes         the thesis's experiment: frame time and misses against boxes per patch
                (--patch-boxes N, and the scene's own split by flatness, "flat"); the misses are
                the eye rays' id mismatch against the reference rendered with the same boxes
  tessellation  the teapot as patches against the teapot tessellated by the project's own
                tessellator (bench/patches/tessellate_patches, n x n quads a patch): frame time,
                scene memory (--stats scene_bytes), HDR-FLIP of the whole image and the
                silhouette mismatch (pixels whose first hit lies on another object,
                bench/patches/object_mismatch) against the reference render of the patches
  raster        the patches' eye rays by the raster pass against the kernel: frame time and the
                eye hits' time (raster: time_s.eye_hits_raster; kernel: generation 0's
                classification and its share of the query kernels); left out without OpenGL

Every render is `rayclass render` with the default options unless the row says otherwise (depth
6). The settings of one experiment run interleaved, run by run, so the machine's load spreads
over all of them; times are the median of the runs with their min and max.
"""
import json
import os
import statistics

BOXES = ["1", "4", "16", "64", "256", "1024", "flat"]
QUICK_BOXES = ["1", "flat"]
# 97 x 97 is where the tessellation's silhouette mismatch first meets the patches' at 1024x768
# (docs/bench/patches.md), so the chart holds the speed at equal silhouette error too.
TESSELLATIONS = [1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 97]
QUICK_TESSELLATIONS = [1, 3]
FIELDS = ["experiment", "setting", "primitives", "scene_bytes", "median_s", "min_s", "max_s",
          "eye_s", "id_mismatch", "silhouette_mismatch", "flip", "rmse"]
QUERY_PREFIXES = ("kernel_rc_query", "kernel_rc_intersect", "kernel_rc_gather")


class Bench:
    def __init__(self, ctx, build, quick, runs, tmp):
        self.ctx, self.build, self.quick, self.runs, self.tmp = ctx, build, quick, runs, tmp
        self.rayclass = os.path.join(build, "rayclass")
        self.scene = os.path.join(ctx.ROOT, "scenes", "teapot.json")
        w, h = (64, 48) if quick else (1024, 768)
        self.size = ["--width", str(w), "--height", str(h)]

    def render(self, scene, out, extra, stats=True):
        cmd = [self.rayclass, "render", scene, "-o", out, "--aov", "id", "-q"] + self.size + extra
        if stats:
            cmd += ["--stats", out + ".json"]
        self.ctx.run(cmd, env=self.ctx.pocl_env(2))
        if stats:
            with open(out + ".json") as f:
                return json.load(f)
        return None

    def timed(self, settings):
        """settings: [(label, scene, extra)]; renders them interleaved. Returns {label: (stats of
        the last run, [render seconds], [eye-hit seconds])} and leaves each label's last image in
        TMP/label.exr."""
        out = {label: (None, [], []) for label, _, _ in settings}
        for _ in range(self.runs):
            for label, scene, extra in settings:
                s = self.render(scene, os.path.join(self.tmp, label + ".exr"), extra)
                out[label][1].append(s["time_s"]["render"])
                out[label][2].append(eye_seconds(s))
                out[label] = (s, out[label][1], out[label][2])
        return out

    def compare(self, a, b):
        p = self.ctx.run([self.rayclass, "compare", a, b, "--json"], check=False)
        return json.loads(p.stdout)


def eye_seconds(s):
    if "eye_hits_raster" in s["time_s"]:
        return s["time_s"]["eye_hits_raster"]
    gen = s["rays_by_generation"][0]
    # The eye rays' query: generation 0's host classification and its nearest-hit kernels (the
    # kernel times are per render; generation 0's share is its share of the rays queried).
    rays = sum(g["rays"] for g in s["rays_by_generation"])
    kernels = sum(v for k, v in s["time_s"].items() if k.startswith(QUERY_PREFIXES))
    return gen["host_classify_seconds"] + kernels * gen["rays"] / max(rays, 1)


def row(experiment, setting, s, times, eye, **extra):
    r = {"experiment": experiment, "setting": setting, "primitives": s["primitives"],
         "scene_bytes": s["scene_bytes"], "median_s": "%.4g" % statistics.median(times),
         "min_s": "%.4g" % min(times), "max_s": "%.4g" % max(times),
         "eye_s": "%.4g" % statistics.median(eye), "id_mismatch": "-",
         "silhouette_mismatch": "-", "flip": "-", "rmse": "-"}
    r.update(extra)
    return r


def boxes(b):
    counts = QUICK_BOXES if b.quick else BOXES
    settings = [(f"boxes_{c}", b.scene, [] if c == "flat" else ["--patch-boxes", c])
                for c in counts]
    b.ctx.log("patches: boxes per patch, %d runs" % b.runs)
    timed = b.timed(settings)
    rows = []
    for (label, scene, extra), c in zip(settings, counts):
        ref = os.path.join(b.tmp, label + "_ref.exr")
        b.ctx.log("patches: reference eye hits, boxes " + c)
        b.render(scene, ref, ["--reference", "--max-depth", "0"] + extra, stats=False)
        cmp = b.compare(os.path.join(b.tmp, label + ".exr"), ref)
        s, times, eye = timed[label]
        rows.append(row("boxes", c, s, times, eye,
                        id_mismatch="%.6g" % cmp["id_mismatch_fraction"]))
    return rows


def tessellation(b, flip):
    ns = QUICK_TESSELLATIONS if b.quick else TESSELLATIONS
    settings = [("patches", b.scene, [])]
    for n in ns:
        obj = os.path.join(b.tmp, "teapot_%d.obj" % n)
        b.ctx.run([os.path.join(b.build, "bench", "tessellate_patches"), b.scene, "teapot",
                   str(n), obj])
        with open(b.scene) as f:
            scene = json.load(f)
        scene["objects"][0] = {"type": "mesh", "file": obj, "material": "porcelain",
                               "name": "teapot"}
        path = os.path.join(b.tmp, "teapot_%d.json" % n)
        with open(path, "w") as f:
            json.dump(scene, f)
        settings.append(("%dx%d" % (n, n), path, []))
    b.ctx.log("patches: the teapot reference render")
    ref = os.path.join(b.tmp, "teapot_ref.exr")
    b.render(b.scene, ref, ["--reference"], stats=False)
    b.ctx.log("patches: patches against %d tessellations, %d runs" % (len(ns), b.runs))
    timed = b.timed(settings)
    flip_ref = flip.load(ref) if flip else None
    rows = []
    for label, scene, _ in settings:
        img = os.path.join(b.tmp, label + ".exr")
        sil = b.ctx.run([os.path.join(b.build, "bench", "object_mismatch"), scene, img, b.scene,
                         ref]).stdout.strip()
        flip_error = ("%.6g" % flip.evaluate(flip_ref, flip.load(img), "HDR",
                                             applyMagma=False)[1]) if flip else "missing"
        cmp = b.compare(img, ref)
        s, times, eye = timed[label]
        rows.append(row("tessellation", label, s, times, eye, silhouette_mismatch=sil,
                        flip=flip_error, rmse="%.6g" % cmp["rmse"]))
    return rows


def raster(b):
    settings = [("kernel", b.scene, ["--eye-rays", "kernel"]),
                ("raster", b.scene, ["--eye-rays", "raster"])]
    probe = b.ctx.run([b.rayclass, "render", b.scene, "-o", os.path.join(b.tmp, "probe.png"),
                       "-q", "--eye-rays", "raster", "--width", "8", "--height", "6"],
                      env=b.ctx.pocl_env(2), check=False)
    if probe.returncode != 0:
        b.ctx.log("patches: raster experiment skipped: " + probe.stderr.strip())
        return []
    b.ctx.log("patches: raster pass against the kernel, %d runs" % b.runs)
    timed = b.timed(settings)
    rows = []
    cmp = b.compare(os.path.join(b.tmp, "raster.exr"), os.path.join(b.tmp, "kernel.exr"))
    for label, _, _ in settings:
        s, times, eye = timed[label]
        rows.append(row("raster", label, s, times, eye,
                        id_mismatch="%.6g" % cmp["id_mismatch_fraction"],
                        rmse="%.6g" % cmp["rmse"]))
    return rows


def bench_patches(ctx, build, quick, runs, tmp, flip):
    b = Bench(ctx, build, quick, runs, tmp)
    return boxes(b) + tessellation(b, flip) + raster(b)


def chart_patches(rows, path):
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, 2, figsize=(11, 8))
    sel = [r for r in rows if r["experiment"] == "boxes"]
    ax = axes[0, 0]
    fixed = sorted((int(r["setting"]), r) for r in sel if r["setting"] != "flat")
    ax.plot([c for c, _ in fixed], [float(r["median_s"]) for _, r in fixed], "o-", color="C0",
            label="frame time")
    ax.set_xscale("log", base=2)
    ax.set_xlabel("boxes per patch (--patch-boxes)")
    ax.set_ylabel("frame s (median)", color="C0")
    ax2 = ax.twinx()
    ax2.plot([c for c, _ in fixed], [max(float(r["id_mismatch"]), 1e-7) for _, r in fixed],
             "s--", color="C3", label="id mismatch")
    ax2.set_yscale("log")
    ax2.set_ylabel("eye-ray id mismatch against the reference", color="C3")
    for r in sel:
        if r["setting"] == "flat":
            ax.axhline(float(r["median_s"]), color="C0", ls=":", lw=1)
            ax2.axhline(max(float(r["id_mismatch"]), 1e-7), color="C3", ls=":", lw=1)
    ax2.axhline(1e-4, color="k", lw=0.8)
    ax.set_title("Boxes per patch (dotted: the default split by flatness; black: 1e-4)",
                 fontsize=9)

    tess = [r for r in rows if r["experiment"] == "tessellation"]
    for ax, key, label in ((axes[0, 1], "silhouette_mismatch", "silhouette mismatch"),
                           (axes[1, 0], "flip", "HDR-FLIP against the reference")):
        for r in tess:
            try:
                x = max(float(r[key]), 1e-7)
            except ValueError:
                continue
            patch = r["setting"] == "patches"
            ax.scatter([x], [float(r["median_s"])], color="C3" if patch else "C0",
                       marker="*" if patch else "o", s=80 if patch else 30)
            ax.annotate("%s, %.0f KiB" % (r["setting"], int(r["scene_bytes"]) / 1024),
                        (x, float(r["median_s"])), fontsize=7, xytext=(3, 3),
                        textcoords="offset points")
        ax.set_xscale("log")
        ax.set_xlabel(label)
        ax.set_ylabel("frame s (median)")
        ax.set_title("Patches (star) against tessellations (n x n quads a patch, KiB)",
                     fontsize=9)

    ax = axes[1, 1]
    ras = [r for r in rows if r["experiment"] == "raster"]
    xs = range(len(ras))
    ax.bar([x - 0.2 for x in xs], [float(r["median_s"]) for r in ras], 0.4, label="frame")
    ax.bar([x + 0.2 for x in xs], [float(r["eye_s"]) for r in ras], 0.4, label="eye hits")
    ax.set_xticks(list(xs))
    ax.set_xticklabels([r["setting"] for r in ras])
    ax.set_ylabel("s (median)")
    ax.legend(fontsize=7)
    ax.set_title("Patch eye rays: raster pass against the kernel", fontsize=9)
    fig.suptitle("Bezier patches by Newton iteration: the teapot scene, 2 PoCL threads",
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
