#!/usr/bin/env python3
"""The README's performance section, generated from bench_models' JSON (bench/bench_models.cpp).

    python3 scripts/bench_tables.py bench/results/quick.json                 # print the section
    python3 scripts/bench_tables.py bench/results/quick.json --write README.md
    python3 scripts/bench_tables.py bench/results/quick.json --check README.md
    python3 scripts/bench_tables.py some.json --validate                      # schema only

--write replaces the text between the marker lines BEGIN and END (below) in the file, keeping
the markers; --check exits 1 when that text differs from what --write would put there (so the
README and the checked-in JSON cannot drift apart), 77 (ctest's skip code) when the file has no
markers yet. Both validate the JSON first: every row has every key of ROW_KEYS, names from the
known sets, a positive finite evals_per_s and finite numbers or null elsewhere (NaN and Infinity
are refused by the parser). Only the standard library is used.
"""

import argparse
import json
import math
import os
import sys

BEGIN = "<!-- bench:begin -->"
END = "<!-- bench:end -->"
ROW_KEYS = ["model", "variant", "lights", "precision", "path", "evals_per_s", "ratio_to_smooth",
            "error_mean", "error_p95", "error_max"]
NUMBER_KEYS = ["evals_per_s", "ratio_to_smooth", "error_mean", "error_p95", "error_max"]
LIGHTS = ["probe", "directional_point", "quad", "four_quads"]
PRECISIONS = ["fp32", "fp64"]
PATHS = ["device", "host", "end_to_end", "shared_memory"]
SKIP = 77


def _refuse_constant(name):
    raise ValueError(f"{name} is not valid JSON (a measurement must be a finite number or null)")


def load(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f, parse_constant=_refuse_constant)


def problems(doc):
    """Every schema violation of a bench_models JSON document, as readable strings."""
    out = []
    if not isinstance(doc, dict) or not isinstance(doc.get("rows"), list):
        return ['expected an object {"rows": [...], ...}']
    if not doc["rows"]:
        out.append("rows: empty")
    for i, row in enumerate(doc["rows"]):
        where = f"rows[{i}]"
        if not isinstance(row, dict):
            out.append(f"{where}: not an object")
            continue
        for key in ROW_KEYS:
            if key not in row:
                out.append(f"{where}: missing key {key!r}")
        for key in ["model", "variant"]:
            if key in row and not (isinstance(row[key], str) and row[key]):
                out.append(f"{where}.{key}: {row[key]!r}; expected a non-empty string")
        for key, allowed in [("lights", LIGHTS), ("precision", PRECISIONS), ("path", PATHS)]:
            if key in row and row[key] not in allowed:
                out.append(f"{where}.{key}: {row[key]!r}; expected one of {allowed}")
        for key in NUMBER_KEYS:
            v = row.get(key)
            if v is None:
                if key == "evals_per_s" and key in row:
                    out.append(f"{where}.evals_per_s: null; every row is a measurement")
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                out.append(f"{where}.{key}: {v!r}; expected a finite number or null")
            elif key == "evals_per_s" and v <= 0:
                out.append(f"{where}.evals_per_s: {v}; expected > 0")
            elif key != "evals_per_s" and v < 0:
                out.append(f"{where}.{key}: {v}; expected >= 0")
        # bench_models counts the queries whose radiance was not finite (left out of the errors).
        if row.get("nonfinite", 0):
            out.append(f"{where}: {row['nonfinite']} queries gave non-finite radiance")
    # A row reporting another variant's timing (bench_models --quick, Driver::SharedTiming): that
    # variant's row on the same model, light set, precision and path was timed itself, with the
    # same rate and batch; its radiance was bit-identical, so its errors are the same too.
    for i, row in enumerate(doc["rows"]):
        shared = row.get("timing_shared_with") if isinstance(row, dict) else None
        if shared is None:
            continue
        where = f"rows[{i}].timing_shared_with"
        same = [r for r in doc["rows"] if isinstance(r, dict) and r.get("variant") == shared
                and all(r.get(k) == row.get(k) for k in ["model", "lights", "precision", "path"])]
        if not same:
            out.append(f"{where}: {shared!r}; no such row on the same model, lights, precision "
                       "and path")
            continue
        base = same[0]
        if base.get("timing_shared_with") is not None:
            out.append(f"{where}: {shared!r} reports another row's timing itself")
        for key in ["evals_per_s", "batch", "error_mean", "error_p95", "error_max",
                    "error_signed", "error_se"]:
            if base.get(key) != row.get(key):
                out.append(f"{where}: {key} {row.get(key)!r} differs from {shared!r}'s "
                           f"{base.get(key)!r}")
    return out


def rate(v):
    if v is None:
        return "-"
    for scale, unit in [(1e9, "G"), (1e6, "M"), (1e3, "k")]:
        if v >= scale:
            x = v / scale
            return (f"{x:.0f}" if x >= 100 else f"{x:.3g}") + " " + unit
    return f"{v:.3g}"


def num(v):
    return "-" if v is None else f"{v:.3g}"


def render(doc, json_ref):
    """The section (without the marker lines) for the document loaded from json_ref."""
    rows = doc["rows"]
    m = doc.get("machine", {})
    st = doc.get("settings", {})
    keys = []  # (model, variant, lights) in the JSON's order
    cell = {}
    for r in rows:
        k = (r["model"], r["variant"], r["lights"])
        if k not in cell:
            keys.append(k)
            cell[k] = {}
        cell[k][(r["path"], r["precision"])] = r
    out = []
    out.append("<!-- Generated by scripts/bench_tables.py from the JSON named below; edit neither "
               "by hand: rerun the command and the script. -->")
    out.append("")
    out.append(f"Generated from [`{json_ref}`]({json_ref}), written by:")
    out.append("")
    out.append("```sh")
    out.append(doc.get("command", "?"))
    out.append(f"python3 scripts/bench_tables.py {json_ref} --write README.md")
    out.append("```")
    out.append("")
    machine = (f"Machine: {m.get('device', '?')} ({m.get('platform', '?')}), "
               f"{m.get('cores', '?')} cores, {m.get('kernel', '?')}; run started "
               f"{m.get('started', '?')}, took {num(m.get('wall_seconds'))} s "
               f"({m.get('kernels_compiled', '?')} kernels compiled, "
               f"{m.get('kernels_from_cache', '?')} from the disk cache); load average "
               f"{m.get('load_average_start', '?')} at the start, "
               f"{m.get('load_average_end', '?')} at the end.")
    if m.get("note"):
        machine += f" **{m['note']}**"
    out.append(machine)
    out.append("")
    out.append(
        f"Every model of the model table with its registered variants (`bench/cases/`), "
        f"{st.get('base_queries', '?')} shared random queries in the local frame (probes carry "
        f"wi); each timed batch is those queries tiled until one run takes at least "
        f"{st.get('min_time_s', '?')} s or holds {st.get('max_batch', '?')} queries, median of "
        f"{st.get('repeat', '?')} runs after a warm-up run. Lights: `probe` (BRDF probes), "
        f"`directional_point` (one directional + one sphere light), `quad` (one 6 x 6 quad, 2.1 "
        f"sr), `four_quads` (four 1 x 1 quads). Device = the OpenCL device in process, one "
        f"command queue, buffer set-up and read-back included; host = the C++ host path on one "
        f"thread; end to end = the service in process on loopback through the client library "
        f"(fp32, each model's first variant per light set). Ratio = device fp32 evaluations/s "
        f"over those of `SMOOTH` `schlick` `directional_point` device fp32. Glint models shade "
        f"polygon lights with LTC.")
    out.append("")
    out.append("Evaluations per second (an evaluation is one query shading every light of its "
               "set):")
    out.append("")
    cols = [("device", "fp32"), ("device", "fp64"), ("host", "fp32"), ("host", "fp64"),
            ("end_to_end", "fp32")]
    out.append("| model | variant | lights | device fp32 | device fp64 | host fp32 | host fp64 | "
               "end to end fp32 | ratio to smooth |")
    out.append("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    def rate_cell(r):
        # bench_models --quick: a row timed as another variant's (Driver::SharedTiming).
        shared = r.get("timing_shared_with")
        return rate(r["evals_per_s"]) + (f" (= `{shared}`)" if shared else "")

    any_shared = False
    for k in keys:
        c = cell[k]
        vals = [rate_cell(c[p]) if p in c else "-" for p in cols]
        any_shared = any_shared or any(r.get("timing_shared_with") for r in c.values())
        ratio = num(c[("device", "fp32")]["ratio_to_smooth"]) if ("device", "fp32") in c else "-"
        out.append(f"| {k[0]} | `{k[1]}` | {k[2]} | " + " | ".join(vals) + f" | {ratio} |")
    out.append("")
    if any_shared:
        out.append(
            "A rate marked (= `v`) is the timing of variant `v`'s row, not measured again: the "
            "same program and passes gave bit-identical radiance on every query of that row's "
            "timed batch (`--quick` only; `bench/bench_models.cpp` Driver::SharedTiming; "
            "KEMPPINEN's polygon pass widens the explicit block to the light's image whatever "
            "k).")
        out.append("")
    out.append(
        "Errors of the device fp32 results (fp64 in the JSON): `SMOOTH` probes and "
        "point-like lights against the same request in fp64 on the host (fp32 rounding), "
        "per-query relative error |x - ref| / max(ref, 1e-3 max ref) of the RGB sum; `SMOOTH` "
        f"polygon lights the same against REFERENCE quadrature in fp64 on the host "
        f"({st.get('area_reference_queries', '?')} queries); glint models: the relative bias "
        "of the batch-mean radiance against the smooth model with the same material and lights, "
        "|mean / smooth mean - 1| (mean only, with its standard error: the glint models "
        "converge to the smooth one in expectation).")
    out.append("")
    out.append("| model | variant | lights | reference | mean | p95 | max | standard error |")
    out.append("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for k in keys:
        r = cell[k].get(("device", "fp32"))
        if r is None or r.get("error_mean") is None:
            continue
        out.append(f"| {k[0]} | `{k[1]}` | {k[2]} | {r.get('error_reference') or '-'} | "
                   f"{num(r['error_mean'])} | {num(r['error_p95'])} | {num(r['error_max'])} | "
                   f"{num(r.get('error_se'))} |")
    skipped = doc.get("skipped", [])
    if skipped:
        out.append("")
        groups = {}  # (model, reason) -> light sets, in the JSON's order
        for s in skipped:
            lights = groups.setdefault((s["model"], s["reason"]), [])
            if s["lights"] not in lights:
                lights.append(s["lights"])
        out.append("Not measured (refused by the server's validation, or failed):")
        out.append("")
        for (model, reason), lights in groups.items():
            out.append(f"- {model} with {', '.join(lights)}: {reason}")
    return "\n".join(out) + "\n"


def replace_section(text, section, path):
    if BEGIN not in text or END not in text:
        return None
    head, rest = text.split(BEGIN, 1)
    if END not in rest:
        raise SystemExit(f"{path}: {END!r} before {BEGIN!r}")
    _, tail = rest.split(END, 1)
    return head + BEGIN + "\n" + section + END + tail


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("json", help="bench_models --json output")
    g = ap.add_mutually_exclusive_group()
    g.add_argument("--write", metavar="FILE", help="replace the section between the markers")
    g.add_argument("--check", metavar="FILE", help="exit 1 if the section differs")
    g.add_argument("--validate", action="store_true", help="check the JSON schema only")
    a = ap.parse_args(argv)
    try:
        doc = load(a.json)
    except (OSError, ValueError) as e:
        print(f"{a.json}: {e}", file=sys.stderr)
        return 1
    bad = problems(doc)
    if bad:
        print(f"{a.json}: {len(bad)} schema problem(s):\n  " + "\n  ".join(bad[:50]),
              file=sys.stderr)
        return 1
    if a.validate:
        print(f"{a.json}: {len(doc['rows'])} rows, schema ok")
        return 0
    target = a.write or a.check
    # The JSON as the target file would link it (relative to the file's folder).
    json_ref = a.json
    if target:
        json_ref = os.path.relpath(a.json, os.path.dirname(os.path.abspath(target)) or ".")
    section = render(doc, json_ref)
    if not target:
        sys.stdout.write(section)
        return 0
    with open(target, encoding="utf-8") as f:
        text = f.read()
    new = replace_section(text, section, target)
    if new is None:
        print(f"{target}: no {BEGIN} / {END} marker lines", file=sys.stderr)
        return SKIP if a.check else 1
    if a.check:
        if new != text:
            print(f"{target}: the section between the markers is not what {a.json} gives; "
                  f"regenerate: python3 scripts/bench_tables.py {a.json} --write {target}",
                  file=sys.stderr)
            return 1
        print(f"{target}: section matches {a.json}")
        return 0
    with open(target, "w", encoding="utf-8") as f:
        f.write(new)
    print(f"wrote the section of {target} from {a.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
