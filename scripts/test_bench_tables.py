#!/usr/bin/env python3
"""Tests of scripts/bench_tables.py: the schema check refuses what it must, and --write / --check
round-trip through the markers (run by ctest as bench_tables_script)."""

import copy
import json
import os
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_tables  # noqa: E402

ROW = {"model": "SMOOTH", "variant": "schlick", "lights": "directional_point", "precision": "fp32",
       "path": "device", "evals_per_s": 1.5e8, "ratio_to_smooth": 1.0, "error_mean": 1e-7,
       "error_p95": 3e-7, "error_max": 9e-7, "error_reference": "fp64 host", "nonfinite": 0}
DOC = {"command": "build/bench/bench_models --quick --json x.json",
       "machine": {"device": "dev", "cores": 2, "note": "loaded"},
       "settings": {"base_queries": 16}, "rows": [ROW], "skipped": []}


def write(text, suffix=".json"):
    f = tempfile.NamedTemporaryFile("w", suffix=suffix, delete=False)
    f.write(text)
    f.close()
    return f.name


class Schema(unittest.TestCase):
    def test_good_document_passes(self):
        self.assertEqual(bench_tables.problems(DOC), [])

    def test_every_missing_key_is_named(self):
        for key in bench_tables.ROW_KEYS:
            doc = copy.deepcopy(DOC)
            del doc["rows"][0][key]
            self.assertIn(f"rows[0]: missing key {key!r}", bench_tables.problems(doc))

    def test_nan_and_infinity_are_refused_by_the_parser(self):
        for literal in ["NaN", "Infinity", "-Infinity"]:
            path = write(json.dumps(DOC).replace('"error_max": 9e-07', f'"error_max": {literal}'))
            with self.assertRaises(ValueError):
                bench_tables.load(path)
            os.unlink(path)

    def test_bad_values(self):
        cases = [("lights", "sphere"), ("precision", "fp16"), ("path", "gpu"),
                 ("evals_per_s", None), ("evals_per_s", 0), ("error_mean", -1.0),
                 ("ratio_to_smooth", "fast"), ("model", ""), ("nonfinite", 3)]
        for key, value in cases:
            doc = copy.deepcopy(DOC)
            doc["rows"][0][key] = value
            self.assertTrue(bench_tables.problems(doc), f"{key}={value!r} accepted")

    def test_empty_rows_refused(self):
        self.assertTrue(bench_tables.problems({"rows": []}))


class Markers(unittest.TestCase):
    def test_write_then_check_then_drift(self):
        js = write(json.dumps(DOC))
        readme = write(f"# title\n\n{bench_tables.BEGIN}\nold\n{bench_tables.END}\ntail\n", ".md")
        self.assertEqual(bench_tables.main([js, "--write", readme]), 0)
        with open(readme) as f:
            text = f.read()
        self.assertTrue(text.startswith("# title\n\n" + bench_tables.BEGIN + "\n"))
        self.assertTrue(text.endswith(bench_tables.END + "\ntail\n"))
        self.assertIn("build/bench/bench_models --quick --json x.json", text)
        self.assertIn("| SMOOTH | `schlick` | directional_point | 150 M |", text)
        self.assertEqual(bench_tables.main([js, "--check", readme]), 0)
        doc = copy.deepcopy(DOC)
        doc["rows"][0]["evals_per_s"] = 1.6e8
        with open(js, "w") as f:
            json.dump(doc, f)
        self.assertEqual(bench_tables.main([js, "--check", readme]), 1)
        os.unlink(js)
        os.unlink(readme)

    def test_shared_timing_is_marked(self):
        # A row that reports another variant's timing says so in its cell and below the table;
        # a document without such rows renders no note (the checked-in README section).
        self.assertNotIn("(= `", bench_tables.render(DOC, "x.json"))
        doc = copy.deepcopy(DOC)
        other = dict(ROW, variant="k=4", timing_shared_with="schlick")
        doc["rows"].append(other)
        self.assertEqual(bench_tables.problems(doc), [])
        text = bench_tables.render(doc, "x.json")
        self.assertIn("| SMOOTH | `k=4` | directional_point | 150 M (= `schlick`) |", text)
        self.assertIn("A rate marked (= `v`) is the timing of variant `v`'s row", text)

    def test_shared_timing_must_match_a_timed_row(self):
        doc = copy.deepcopy(DOC)
        doc["rows"].append(dict(ROW, variant="k=4", timing_shared_with="k=1"))
        self.assertTrue(any("no such row" in p for p in bench_tables.problems(doc)))
        doc = copy.deepcopy(DOC)
        doc["rows"].append(dict(ROW, variant="k=4", evals_per_s=2e8, timing_shared_with="schlick"))
        self.assertTrue(any("evals_per_s" in p for p in bench_tables.problems(doc)))
        doc = copy.deepcopy(DOC)
        doc["rows"].append(dict(ROW, variant="k=4", error_mean=2e-7, timing_shared_with="schlick"))
        self.assertTrue(any("error_mean" in p for p in bench_tables.problems(doc)))
        doc = copy.deepcopy(DOC)
        doc["rows"].append(dict(ROW, variant="k=4", timing_shared_with="schlick"))
        doc["rows"].append(dict(ROW, variant="k=9", timing_shared_with="k=4"))
        self.assertTrue(any("reports another row's timing" in p
                            for p in bench_tables.problems(doc)))

    def test_no_markers_is_a_skip(self):
        js = write(json.dumps(DOC))
        readme = write("# no markers\n", ".md")
        self.assertEqual(bench_tables.main([js, "--check", readme]), bench_tables.SKIP)
        self.assertEqual(bench_tables.main([js, "--write", readme]), 1)
        os.unlink(js)
        os.unlink(readme)


if __name__ == "__main__":
    unittest.main()
