"""The package as installed: where it was imported from, the checked-in stubs against the
generator, the query arrays against the wire contract, and syntax for Python 3.9."""

from __future__ import annotations

import ast
import os
import pathlib
import subprocess
import sys

import glint
from glint._queries import ARRAYS
from conftest import SOURCE_DIR

PACKAGE_SOURCE = SOURCE_DIR / "client" / "python"


def test_imported_from_the_venv_not_the_source_tree():
    installed = pathlib.Path(glint.__file__).resolve()
    assert pathlib.Path(sys.prefix).resolve() in installed.parents, installed
    assert sys.prefix != sys.base_prefix  # inside the venv run_python_tests.sh made


def test_checked_in_stubs_equal_regenerated(tmp_path):
    """glint/v1/*_pb2*.py are what regenerate_stubs.sh makes from proto/ now: a proto change
    without regenerating fails here."""
    run = subprocess.run(["bash", str(PACKAGE_SOURCE / "regenerate_stubs.sh"), str(tmp_path)],
                         env=dict(os.environ, PYTHON=sys.executable), capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    for name in ("glint_pb2.py", "glint_pb2.pyi", "glint_pb2_grpc.py"):
        fresh = (tmp_path / "glint" / "v1" / name).read_bytes()
        assert fresh == (PACKAGE_SOURCE / "glint" / "v1" / name).read_bytes(), (
            f"glint/v1/{name} is stale: run client/python/regenerate_stubs.sh")


def test_query_arrays_are_every_repeated_float_of_query_batch():
    from google.protobuf.descriptor import FieldDescriptor

    wire = [f.name for f in glint.pb.QueryBatch.DESCRIPTOR.fields
            if f.type == FieldDescriptor.TYPE_FLOAT]
    assert [name for name, _ in ARRAYS] == wire


def test_sources_parse_as_python_3_9():
    """requires-python >= 3.9: the grammar of 3.9 (no match, no parenthesised context managers,
    no except*). Annotations are never evaluated (from __future__ import annotations)."""
    for path in sorted((PACKAGE_SOURCE / "glint").glob("*.py")):
        ast.parse(path.read_text(), filename=str(path), feature_version=(3, 9))
