#!/usr/bin/env python3
"""The smooth kernel against Mitsuba 3 (issue 13): the same GGX anisotropic conductor (alpha
(0.3, 0.1), eta (0.2, 0.4, 1.4), k (3.9, 2.4, 1.8)) evaluated on the same N fp32 direction
pairs by Mitsuba's vectorised `roughconductor` eval (variant llvm_ad_rgb, its JIT-compiled LLVM
kernel on every core) and by glint's SMOOTH probe kernel on the in-process device path
(build/bench/smooth_probe_driver: buffer set-up and read-back included, as the service runs a
request), in interleaved rounds; then checks that the two agree.

Mitsuba's eval returns f cos(theta_light) like glint's probe, but its shadowing-masking is the
separable Smith G1(wo) G1(wi), glint's the height-correlated G2 = 1 / (1 + Lambda_o + Lambda_i)
(Heitz 2014 Eq. 98 vs 99). The agreement check multiplies Mitsuba's value by
G2 / (G1(wo) G1(wi)), computed in float64 here from the GGX Lambda (Heitz 2014 Eq. 86), so what
is compared is D F / (4 cos_o) on both sides.

Mitsuba comes from PyPI into a venv of its own (not a dependency of glint); its Dr.Jit needs a
newer libLLVM than bookworm's default 14/15 (those abort compiling its kernel), libllvm19:
  apt-get install libllvm19
  python3 -m venv /tmp/mitsuba-venv && /tmp/mitsuba-venv/bin/pip install mitsuba==3.9.1 numpy
Timings: wall M/s on this (shared) machine, and M per CPU-second (all threads of the process),
which another process's load changes much less.
  /tmp/mitsuba-venv/bin/python bench/mitsuba_compare.py [--n 1048576] [--rounds 7] [--per-round 5]
      [--driver build/bench/smooth_probe_driver] [--bench-models build/bench/bench_models]
      [--host] [--settle 0.2] [--json PATH] [--driver-b OTHER/smooth_probe_driver]
--driver-b times a second glint driver (e.g. main's build copied to /tmp) in the same rounds,
alternating which of the two goes first, and prints its rates, the median of the per-round
ratios --driver / --driver-b (wall and CPU) and whether the two outputs are bit-identical: an
interleaved A/B of two builds under the same load.
--host adds a second comparison: Mitsuba on one thread against glint's host path (one thread).
--bench-models (default on when the binary exists; --bench-models '' skips it) also runs, once per
round between Mitsuba's evals, `bench_models --quick --models SMOOTH --lights probe --precisions
fp32 --paths device` (its own probe queries, the SMOOTH `conductor` and `schlick` rows) and keeps
the median rate of each row over the rounds, so the benchmark's rows and Mitsuba are timed under
the same load.
Prints a markdown table; --json writes {"command", "machine", "rows": [...]} with rows in the
bench_models format (model, variant, lights, precision, path, evals_per_s, ratio_to_smooth,
error_mean, error_p95, error_max) plus evals_per_cpu_s and ratio_to_mitsuba (this row's rate over
Mitsuba's, wall); Mitsuba's rows have model MITSUBA3. error_* of the SMOOTH conductor row on the
1M pairs is its relative difference to Mitsuba (G2 corrected, see above); mean is the median.
Not asserted in a test: a measurement on a shared machine.
"""
import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

ALPHA = (0.3, 0.1)
ETA = (0.2, 0.4, 1.4)
K = (3.9, 2.4, 1.8)


def hemisphere_directions(rng, n):
    """n directions uniform on the upper hemisphere (z > 0), float32."""
    u1, u2 = rng.random(n), rng.random(n)
    z = np.maximum(u1, 1e-4)  # uniform z on (0, 1] is uniform solid angle
    r = np.sqrt(1.0 - z * z)
    phi = 2.0 * np.pi * u2
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1).astype(np.float32)


def ggx_lambda(w):
    """GGX Lambda of unit directions w (n x 3), anisotropic (Heitz 2014 Eq. 86), float64."""
    w = w.astype(np.float64)
    s2 = (ALPHA[0] * w[:, 0]) ** 2 + (ALPHA[1] * w[:, 1]) ** 2
    return 0.5 * (-1.0 + np.sqrt(1.0 + s2 / (w[:, 2] ** 2)))


class GlintDriver:
    def __init__(self, driver, wo_path, wi_path, out_path, path):
        self.p = subprocess.Popen(
            [driver, "--wo", wo_path, "--wi", wi_path, "--out", out_path, "--material",
             "conductor", "--path", path],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        line = self.p.stdout.readline()
        if not line.startswith("ready"):
            raise RuntimeError(f"smooth_probe_driver did not start: {line!r}")

    def round(self, k):
        """k evaluations: [(wall seconds, CPU seconds of all threads)]."""
        self.p.stdin.write(f"round {k}\n")
        self.p.stdin.flush()
        fields = self.p.stdout.readline().split()
        if not fields or fields[0] != "seconds":
            raise RuntimeError(f"smooth_probe_driver: unexpected answer {fields!r}")
        return [tuple(float(x) for x in f.split(",")) for f in fields[1:]]

    def write(self):
        self.p.stdin.write("write\n")
        self.p.stdin.flush()
        if self.p.stdout.readline().strip() != "ok":
            raise RuntimeError("smooth_probe_driver could not write its output")

    def close(self):
        self.p.stdin.write("quit\n")
        self.p.stdin.flush()
        self.p.wait()


def bench_models_round(binary, json_path):
    """One bench_models run of the SMOOTH fp32 probe rows on the device: {variant: row}."""
    subprocess.run([binary, "--quick", "--models", "SMOOTH", "--lights", "probe", "--precisions",
                    "fp32", "--paths", "device", "--json", json_path],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    with open(json_path) as f:
        return {r["variant"]: r for r in json.load(f)["rows"]
                if r["model"] == "SMOOTH" and r["lights"] == "probe" and r["path"] == "device"}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=1 << 20)
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--per-round", type=int, default=5)
    ap.add_argument("--driver", default="build/bench/smooth_probe_driver")
    ap.add_argument("--bench-models", default="build/bench/bench_models",
                    help="bench_models binary for the interleaved SMOOTH probe rows ('' skips)")
    ap.add_argument("--host", action="store_true",
                    help="also Mitsuba on one thread against glint's host path")
    ap.add_argument("--settle", type=float, default=0.2,
                    help="seconds of pause before each side's evaluations: Dr.Jit's worker "
                         "threads keep spinning after an eval and took ~24%% of the cores from "
                         "the glint evaluations that followed at once (0 measures that)")
    ap.add_argument("--json")
    ap.add_argument("--driver-b", default="",
                    help="a second smooth_probe_driver timed in the same rounds (A/B)")
    args = ap.parse_args()

    # Bookworm's default libLLVM (14/15) cannot compile Dr.Jit 1.5's kernels ("LLVM ERROR:
    # Cannot select: fmaximum", then abort); libllvm19 (apt) can.
    llvm19 = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
    if "DRJIT_LIBLLVM_PATH" not in os.environ and os.path.exists(llvm19):
        os.environ["DRJIT_LIBLLVM_PATH"] = llvm19
    import drjit as dr
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")

    rng = np.random.default_rng(13)
    n = args.n
    wo = hemisphere_directions(rng, n)  # towards the viewer (Mitsuba's si.wi)
    wi = hemisphere_directions(rng, n)  # towards the light (Mitsuba's eval `wo`)

    bsdf = mi.load_dict({
        "type": "roughconductor", "distribution": "ggx",
        "alpha_u": ALPHA[0], "alpha_v": ALPHA[1],
        "eta": {"type": "rgb", "value": list(ETA)},
        "k": {"type": "rgb", "value": list(K)},
    })
    ctx = mi.BSDFContext()

    def to_mi(a):
        v = mi.Vector3f(a[:, 0], a[:, 1], a[:, 2])
        dr.eval(v)
        return v

    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wi = to_mi(wo)
    light = to_mi(wi)
    dr.eval(si.wi, light)

    def mitsuba_eval():
        # Inputs already in memory; the timed part is the eval kernel and its output allocation.
        t0, c0 = time.perf_counter(), time.process_time()
        value = bsdf.eval(ctx, si, light)
        dr.eval(value)
        dr.sync_thread()
        return (time.perf_counter() - t0, time.process_time() - c0), value

    def mitsuba_eval_numpy():
        # The same from numpy inputs to a numpy output (host <-> Dr.Jit copies included).
        t0 = time.perf_counter()
        s = dr.zeros(mi.SurfaceInteraction3f)
        s.wi = mi.Vector3f(wo[:, 0], wo[:, 1], wo[:, 2])
        v = bsdf.eval(ctx, s, mi.Vector3f(wi[:, 0], wi[:, 1], wi[:, 2]))
        out = v.numpy()
        return time.perf_counter() - t0, out

    results = {}
    use_bench_models = bool(args.bench_models) and os.path.exists(args.bench_models)
    bench_rows = {}  # variant -> [row of each round]
    with tempfile.TemporaryDirectory() as tmp:
        wo_path, wi_path = os.path.join(tmp, "wo.f32"), os.path.join(tmp, "wi.f32")
        out_path = os.path.join(tmp, "out.f32")
        wo.tofile(wo_path)
        wi.tofile(wi_path)

        configs = [("all cores", None, "device")]
        if args.host:
            configs.append(("one thread", 1, "host"))
        for label, threads, path in configs:
            if threads:
                dr.set_thread_count(threads)
            glint = GlintDriver(args.driver, wo_path, wi_path, out_path, path)
            out_b_path = os.path.join(tmp, "out_b.f32")
            glint_b = (GlintDriver(args.driver_b, wo_path, wi_path, out_b_path, path)
                       if args.driver_b else None)
            t_gb, ab_ratios = [], []
            _, value = mitsuba_eval()  # JIT compile + warm
            mitsuba_eval_numpy()
            t_mi, t_mi_np, t_gl = [], [], []
            for _ in range(args.rounds):  # interleaved rounds
                time.sleep(args.settle)
                for _ in range(args.per_round):
                    t_mi.append(mitsuba_eval()[0])
                time.sleep(args.settle)
                if glint_b is None:
                    t_gl += glint.round(args.per_round)
                else:
                    # Alternate which build goes first; per-round ratios of the medians.
                    first_a = len(ab_ratios) % 2 == 0
                    ra = glint.round(args.per_round) if first_a else None
                    rb = glint_b.round(args.per_round)
                    if not first_a:
                        ra = glint.round(args.per_round)
                    t_gl += ra
                    t_gb += rb
                    ab_ratios.append(tuple(
                        statistics.median(t[j] for t in rb) / statistics.median(t[j] for t in ra)
                        for j in (0, 1)))
                for _ in range(max(1, args.per_round // 2)):
                    t_mi_np.append(mitsuba_eval_numpy()[0])
                if use_bench_models and path == "device":
                    rows = bench_models_round(args.bench_models, os.path.join(tmp, "bm.json"))
                    for variant, r in rows.items():
                        bench_rows.setdefault(variant, []).append(r)
                    for _ in range(args.per_round):  # Mitsuba again, after the bench run
                        t_mi.append(mitsuba_eval()[0])
            glint.write()
            glint.close()
            ours = np.fromfile(out_path, dtype=np.float32).reshape(n, 3).astype(np.float64)
            ab = None
            if glint_b is not None:
                glint_b.write()
                glint_b.close()
                out_b = np.fromfile(out_b_path, dtype=np.float32)
                out_a = np.fromfile(out_path, dtype=np.float32)
                ab = {
                    "evals_per_s": n / statistics.median(t[0] for t in t_gb),
                    "evals_per_cpu_s": n / statistics.median(t[1] for t in t_gb),
                    "ratio_wall": statistics.median(r[0] for r in ab_ratios),
                    "ratio_cpu": statistics.median(r[1] for r in ab_ratios),
                    "ratios_cpu": [round(r[1], 3) for r in ab_ratios],
                    "bit_identical": bool(out_a.tobytes() == out_b.tobytes()),
                    "differing": int(np.sum(out_a.view(np.uint32) != out_b.view(np.uint32))),
                }
            theirs = np.asarray(value.numpy(), dtype=np.float64).reshape(3, n).T \
                if np.asarray(value.numpy()).shape[0] == 3 else \
                np.asarray(value.numpy(), dtype=np.float64).reshape(n, 3)
            lo, li = ggx_lambda(wo), ggx_lambda(wi)
            g_ratio = (1.0 + lo) * (1.0 + li) / (1.0 + lo + li)  # G2 / (G1o G1i)
            theirs_corr = theirs * g_ratio[:, None]
            top = theirs_corr.max()
            live = theirs_corr > 1e-3 * top
            rel = np.abs(ours[live] - theirs_corr[live]) / theirs_corr[live]
            row = {
                "mitsuba_evals_per_s": n / statistics.median(t[0] for t in t_mi),
                "mitsuba_evals_per_cpu_s": n / statistics.median(t[1] for t in t_mi),
                "mitsuba_numpy_io_evals_per_s": n / statistics.median(t_mi_np),
                "glint_evals_per_s": n / statistics.median(t[0] for t in t_gl),
                "glint_evals_per_cpu_s": n / statistics.median(t[1] for t in t_gl),
                "glint_path": path,
                "rel_error_median": float(np.median(rel)),
                "rel_error_p99": float(np.quantile(rel, 0.99)),
                "rel_error_max": float(rel.max()),
                "compared_channels": int(live.sum()),
                "zero_both": int(np.sum((ours <= 0) & (theirs <= 0))),
                "driver_b": ab,
            }
            results[label] = row

    load = os.getloadavg()
    print(f"Mitsuba {mi.__version__} llvm_ad_rgb vs glint SMOOTH conductor probes, n = {n}, "
          f"{args.rounds} interleaved rounds x {args.per_round}, {os.cpu_count()} cores, "
          f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}\n")
    print("| threads | Mitsuba eval M/s | per CPU-s | Mitsuba numpy in/out M/s | glint path | "
          "glint M/s | per CPU-s | glint / Mitsuba (wall, CPU) | rel. diff median | p99 | max |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for label, r in results.items():
        print(f"| {label} | {r['mitsuba_evals_per_s'] / 1e6:.0f} | "
              f"{r['mitsuba_evals_per_cpu_s'] / 1e6:.0f} | "
              f"{r['mitsuba_numpy_io_evals_per_s'] / 1e6:.0f} | {r['glint_path']} | "
              f"{r['glint_evals_per_s'] / 1e6:.0f} | {r['glint_evals_per_cpu_s'] / 1e6:.0f} | "
              f"{r['glint_evals_per_s'] / r['mitsuba_evals_per_s']:.2f}, "
              f"{r['glint_evals_per_cpu_s'] / r['mitsuba_evals_per_cpu_s']:.2f} | "
              f"{r['rel_error_median']:.2g} | {r['rel_error_p99']:.2g} | "
              f"{r['rel_error_max']:.2g} |")
    for label, r in results.items():
        ab = r["driver_b"]
        if ab:
            print(f"\n{label}: --driver-b {args.driver_b}: {ab['evals_per_s'] / 1e6:.0f} M/s, "
                  f"{ab['evals_per_cpu_s'] / 1e6:.0f} per CPU-s, "
                  f"{ab['evals_per_s'] / r['mitsuba_evals_per_s']:.2f} of Mitsuba (wall); "
                  f"--driver / --driver-b per round, median: wall {ab['ratio_wall']:.3f}, "
                  f"CPU {ab['ratio_cpu']:.3f} (CPU each round: {ab['ratios_cpu']}); "
                  f"outputs bit-identical: {ab['bit_identical']} ({ab['differing']} floats "
                  f"differ)")
    mitsuba_rate = results["all cores"]["mitsuba_evals_per_s"]
    if bench_rows:
        print(f"\nbench_models SMOOTH fp32 device probe rows (median of {args.rounds} runs "
              f"interleaved with the Mitsuba evals above):\n")
        print("| variant | M evals/s | / Mitsuba (wall) | batch |")
        print("|---|---|---|---|")
        for variant, rs in sorted(bench_rows.items()):
            rate = statistics.median(r["evals_per_s"] for r in rs)
            print(f"| {variant} | {rate / 1e6:.0f} | {rate / mitsuba_rate:.2f} | "
                  f"{rs[0]['batch']} |")
    if args.json:
        def row(model, variant, path, rate, cpu_rate=None, err=None, **extra):
            r = {"model": model, "variant": variant, "lights": "probe", "precision": "fp32",
                 "path": path, "evals_per_s": rate, "ratio_to_smooth": None,
                 "error_mean": None, "error_p95": None, "error_max": None,
                 "evals_per_cpu_s": cpu_rate, "ratio_to_mitsuba": None}
            if err:
                r.update(err)
            r.update(extra)
            return r
        rows = []
        for label, r in results.items():
            threads = "all_cores" if label == "all cores" else "one_thread"
            ref = r["mitsuba_evals_per_s"]
            rows.append(row("MITSUBA3", "roughconductor", f"llvm_ad_rgb_{threads}",
                            ref, r["mitsuba_evals_per_cpu_s"], queries=n))
            rows.append(row("MITSUBA3", "roughconductor", f"llvm_ad_rgb_{threads}_numpy_io",
                            r["mitsuba_numpy_io_evals_per_s"], queries=n,
                            ratio_to_mitsuba=r["mitsuba_numpy_io_evals_per_s"] / ref))
            rows.append(row("SMOOTH", "conductor", r["glint_path"], r["glint_evals_per_s"],
                            r["glint_evals_per_cpu_s"],
                            {"error_mean": r["rel_error_median"], "error_p95": r["rel_error_p99"],
                             "error_max": r["rel_error_max"]},
                            error_reference="Mitsuba 3 x G2/(G1 G1), mean = median, p95 = p99",
                            ratio_to_mitsuba=r["glint_evals_per_s"] / ref, queries=n,
                            driver="smooth_probe_driver", threads=threads))
        for variant, rs in sorted(bench_rows.items()):
            r = dict(rs[0])
            r["evals_per_s"] = statistics.median(x["evals_per_s"] for x in rs)
            # (null: the ratio's reference, the directional_point row, is not in these runs)
            ratios = [x["ratio_to_smooth"] for x in rs if x["ratio_to_smooth"] is not None]
            r["ratio_to_smooth"] = statistics.median(ratios) if ratios else None
            r["ratio_to_mitsuba"] = r["evals_per_s"] / mitsuba_rate
            r["driver"] = f"bench_models --quick (median of {len(rs)} runs)"
            rows.append(r)
        with open(args.json, "w") as f:
            json.dump({"command": " ".join(shlex.quote(a) for a in sys.argv),
                       "machine": {"cores": os.cpu_count(), "mitsuba": mi.__version__,
                                   "load_average_end": " ".join(f"{x:.2f}" for x in load),
                                   "note": "shared machine: compare ratios, not absolutes"},
                       "n": n, "rows": rows}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
