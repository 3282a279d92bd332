"""glintd's Open Inference Protocol service called by Triton's own pure-Python gRPC client
(tritonclient[grpc] from PyPI, with its own compiled protos: a wire-compatibility check of
proto/inference/grpc_service.proto), compared with glint.v1 through the C++ CLI `glint eval`.

The reference for ModelInfer is `glint eval` of the same queries (written to CSV with 9
significant digits, which round-trips every float32) and settings, against the same server:
the radiance must be equal bit for bit.

usage: tritonclient_test.py GLINTD GLINT EXAMPLES_DIR   (run by tests/kserve/python_env.sh)
"""
import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np
import tritonclient.grpc as triton
from tritonclient.utils import InferenceServerException

from glintd_server import Glintd

GLINTD, GLINT, EXAMPLES = sys.argv[1:4]
PAINT = (f"{EXAMPLES}/materials/paint_schlick.json", f"{EXAMPLES}/lights/studio.json")
PROBE = (f"{EXAMPLES}/materials/gold_aniso.json", None)
SPARKLE = (f"{EXAMPLES}/materials/sparkle_binomial.json", f"{EXAMPLES}/lights/rect_small.json")
MODELS = {"paint": PAINT, "probe": PROBE, "sparkle": SPARKLE}
server = None


def setUpModule():
    global server
    args = []
    for name, (material, lights) in MODELS.items():
        args += ["--model", f"{name}={material}" + (f",{lights}" if lights else "")]
    server = Glintd(GLINTD, args).__enter__()


def tearDownModule():
    server.__exit__(None, None, None)


def unit_vectors(rng, n, min_z=0.1):
    z = rng.uniform(min_z, 1.0, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], 1).astype(np.float32)


# The mirror direction of rect_small.json's light seen from the origin: the sparkle preset's
# glints (binomial counts of facets reflecting the light) light up only near it.
SPARKLE_MIRROR = np.float32([0, -0.845, 0.534])


def make_queries(n, probe, frame, seed, near=None):
    rng = np.random.default_rng(seed)
    q = {"wo": unit_vectors(rng, n),
         "uv": rng.uniform(-3, 3, (n, 2)).astype(np.float32),
         "footprint": rng.uniform(1e-4, 2e-3, (n, 4)).astype(np.float32)}
    if near is not None:  # wo scattered about `near`, footprints of some 100 facets
        wo = near + 0.15 * rng.standard_normal((n, 3))
        wo[:, 2] = np.maximum(wo[:, 2], 0.1)
        q["wo"] = (wo / np.linalg.norm(wo, axis=1, keepdims=True)).astype(np.float32)
        q["footprint"] = rng.uniform(5e-3, 2e-2, (n, 4)).astype(np.float32)
    if probe:
        q["wi"] = unit_vectors(rng, n)
    if frame:
        a = 0.3 * (np.arange(n) % 5)
        q["position"] = np.concatenate([rng.uniform(-3, 3, (n, 2)), np.zeros((n, 1))],
                                       1).astype(np.float32)
        q["normal"] = np.stack([np.zeros(n), -np.sin(a), np.cos(a)], 1).astype(np.float32)
        q["tangent"] = np.tile(np.float32([1, 0, 0]), (n, 1))
    return q


CSV_COLUMNS = {"uv": "u,v", "footprint": "dudx,dvdx,dudy,dvdy", "wo": "wox,woy,woz",
               "wi": "wix,wiy,wiz", "position": "px,py,pz", "normal": "nx,ny,nz",
               "tangent": "tx,ty,tz"}


def glint_eval(model, queries, *options):
    """glint.v1 Evaluate through the C++ CLI: radiance as float32 [N, 3]."""
    material, lights = MODELS[model]
    with tempfile.TemporaryDirectory() as d:
        names = list(queries)
        table = np.concatenate([queries[k] for k in names], 1)
        csv = os.path.join(d, "q.csv")
        with open(csv, "w") as f:
            f.write(",".join(CSV_COLUMNS[k] for k in names) + "\n")
            for row in table:
                f.write(",".join("%.9g" % v for v in row) + "\n")
        out = os.path.join(d, "out.npy")
        cmd = [GLINT, "eval", "--server", server.address, "--material", material,
               "--queries", csv, "--out", out] + list(options)
        if lights:
            cmd += ["--lights", lights]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        return np.load(out)


def infer(client, model, queries, parameters=None):
    inputs = []
    for name, array in queries.items():
        tensor = triton.InferInput(name, list(array.shape), "FP32")
        tensor.set_data_from_numpy(array)
        inputs.append(tensor)
    result = client.infer(model, inputs, outputs=[triton.InferRequestedOutput("radiance")],
                          parameters=parameters)
    return result.as_numpy("radiance")


def bit_equal(a, b):
    return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(
        a.view(np.uint32), b.view(np.uint32))


class TritonClient(unittest.TestCase):
    def setUp(self):
        self.client = triton.InferenceServerClient(server.address)

    def test_model_infer_equals_glint_eval_bit_for_bit(self):
        seed = 1
        for model, probe in (("paint", False), ("probe", True), ("sparkle", False)):
            for frame in (False, True):
                with self.subTest(model=model, frame=frame):
                    near = SPARKLE_MIRROR if model == "sparkle" else None
                    q = make_queries(500, probe, frame, seed, near)
                    seed += 1
                    got = infer(self.client, model, q)
                    self.assertEqual(got.dtype, np.float32)
                    self.assertEqual(got.shape, (500, 3))
                    self.assertTrue(bit_equal(got, glint_eval(model, q)))

    def test_parameters_override_seed_area_method_and_precision(self):
        q = make_queries(200, False, False, 9, SPARKLE_MIRROR)
        reference = glint_eval("sparkle", q, "--seed", "7", "--area-method", "mc",
                               "--samples", "16", "--precision", "fp64")
        # The overrides change these queries' radiance, so the equality below means something.
        self.assertFalse(bit_equal(reference, glint_eval("sparkle", q)))
        got = infer(self.client, "sparkle", q, parameters={
            "seed": 7, "area_method": "MONTE_CARLO", "area_samples": 16, "precision": "FP64"})
        self.assertTrue(bit_equal(got, reference))

    def assertRefused(self, model, queries, code, *needles, parameters=None):
        with self.assertRaises(InferenceServerException) as caught:
            infer(self.client, model, queries, parameters)
        self.assertEqual(caught.exception.status(), "StatusCode." + code)
        for needle in needles:
            self.assertIn(needle, caught.exception.message())

    def test_malformed_tensors_are_invalid_argument(self):
        q = make_queries(40, False, False, 3)
        q["wo"][17, 1] = np.nan
        self.assertRefused("paint", q, "INVALID_ARGUMENT", "input 'wo' row 17", "not finite")
        q = make_queries(40, False, False, 3)
        q["uv"] = np.zeros((40, 3), np.float32)
        self.assertRefused("paint", q, "INVALID_ARGUMENT", "input 'uv': shape [40, 3]",
                           "expected [40, 2]")
        q = make_queries(40, False, False, 3)
        q["wo"] = q["wo"].astype(np.float64)
        with self.assertRaises(InferenceServerException) as caught:
            tensor = triton.InferInput("wo", [40, 3], "FP64")
            tensor.set_data_from_numpy(q["wo"])
            self.client.infer("paint", [tensor])
        self.assertEqual(caught.exception.status(), "StatusCode.INVALID_ARGUMENT")
        self.assertIn("input 'wo': datatype 'FP64'; expected FP32", caught.exception.message())
        q = make_queries(40, True, False, 3)
        self.assertRefused("paint", q, "INVALID_ARGUMENT", "input 'wi': unknown")
        self.assertRefused("paint", make_queries(4, False, False, 3), "INVALID_ARGUMENT",
                           "parameter 'exposure': unknown", parameters={"exposure": 2})
        self.assertRefused("nope", make_queries(4, False, False, 3), "NOT_FOUND",
                           "registered models: paint, probe, sparkle")

    def test_health_metadata_and_config(self):
        c = self.client
        self.assertTrue(c.is_server_live())
        self.assertTrue(c.is_server_ready())
        self.assertTrue(c.is_model_ready("paint"))
        self.assertFalse(c.is_model_ready("nope"))
        md = c.get_server_metadata(as_json=True)
        self.assertEqual(md["name"], "glintd")
        self.assertEqual(md["extensions"], ["model_configuration", "statistics"])

        md = c.get_model_metadata("probe", as_json=True)
        self.assertEqual(md["versions"], ["1"])
        self.assertEqual([(t["name"], t["datatype"], t["shape"]) for t in md["inputs"]],
                         [("wo", "FP32", ["-1", "3"]), ("wi", "FP32", ["-1", "3"]),
                          ("uv", "FP32", ["-1", "2"]), ("footprint", "FP32", ["-1", "4"]),
                          ("position", "FP32", ["-1", "3"]), ("normal", "FP32", ["-1", "3"]),
                          ("tangent", "FP32", ["-1", "3"])])
        self.assertEqual([(t["name"], t["datatype"], t["shape"]) for t in md["outputs"]],
                         [("radiance", "FP32", ["-1", "3"])])
        # A lit model takes no wi (a BRDF probe batch must carry no lights).
        names = [t["name"] for t in c.get_model_metadata("paint", as_json=True)["inputs"]]
        self.assertEqual(names, ["wo", "uv", "footprint", "position", "normal", "tangent"])

        config = c.get_model_config("paint", as_json=True)["config"]
        self.assertEqual(config["name"], "paint")
        self.assertEqual(config["platform"], "glint")
        self.assertNotIn("max_batch_size", config)  # proto3 JSON omits the 0 it holds
        self.assertEqual([(i["name"], i["data_type"], i["dims"], i.get("optional", False))
                          for i in config["input"]],
                         [("wo", "TYPE_FP32", ["-1", "3"], False),
                          ("uv", "TYPE_FP32", ["-1", "2"], True),
                          ("footprint", "TYPE_FP32", ["-1", "4"], True),
                          ("position", "TYPE_FP32", ["-1", "3"], True),
                          ("normal", "TYPE_FP32", ["-1", "3"], True),
                          ("tangent", "TYPE_FP32", ["-1", "3"], True)])
        self.assertEqual(config["output"], [{"name": "radiance", "data_type": "TYPE_FP32",
                                             "dims": ["-1", "3"]}])

    def test_statistics_count_successes_and_failures(self):
        def stats():
            s = self.client.get_inference_statistics("probe", as_json=True)["model_stats"]
            self.assertEqual(len(s), 1)
            return s[0]
        before = stats()
        q = make_queries(8, True, False, 4)
        infer(self.client, "probe", q)
        q["wi"][2] = 2.0
        with self.assertRaises(InferenceServerException):
            infer(self.client, "probe", q)
        after = stats()
        count = lambda s, k: int(s["inference_stats"].get(k, {}).get("count", 0))
        self.assertEqual(count(after, "success"), count(before, "success") + 1)
        self.assertEqual(count(after, "fail"), count(before, "fail") + 1)
        self.assertEqual(int(after["inference_count"]), int(before.get("inference_count", 0)) + 1)


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
