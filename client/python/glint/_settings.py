"""Material, lights and per-request options as the wire messages.

Materials and lights are accepted in the proto3 JSON form of ``glint.v1.Material`` and
``glint.v1.LightList`` that the CLI's files use (as Python dicts, or a path to such a file), or as
the generated messages. Parsing is protobuf's own (``google.protobuf.json_format``), with unknown
fields refused, as the CLI does, so that a typo never silently falls back to a default.
"""

from __future__ import annotations

import json
import os
from typing import Any, List, Mapping, Sequence, Union

from google.protobuf import json_format

from glint.v1 import glint_pb2 as pb

MaterialLike = Union[pb.Material, Mapping[str, Any], str, "os.PathLike[str]"]
LightsLike = Union[
    None,
    pb.LightList,
    Mapping[str, Any],
    Sequence[Union[pb.Light, Mapping[str, Any]]],
    str,
    "os.PathLike[str]",
]

# The CLI's --area-method spellings, plus the enum names.
_AREA_METHODS = {
    "ltc": pb.LTC,
    "lecocq": pb.LECOCQ,
    "lecocq-pearson": pb.LECOCQ_PEARSON,
    "lecocq_pearson": pb.LECOCQ_PEARSON,
    "mc": pb.MONTE_CARLO,
    "monte-carlo": pb.MONTE_CARLO,
    "monte_carlo": pb.MONTE_CARLO,
    "reference": pb.REFERENCE,
    "auto": pb.AUTO,
}
_PRECISIONS = {"fp32": pb.FP32, "fp64": pb.FP64}


def _read_json_file(path: "os.PathLike[str] | str", what: str) -> Any:
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except OSError as e:
        raise ValueError(f"{what}: cannot read {os.fspath(path)}: {e.strerror}") from None
    except json.JSONDecodeError as e:
        raise ValueError(f"{what}: {os.fspath(path)}:{e.lineno}:{e.colno}: {e.msg}") from None


def _parse(data: Any, message: Any, what: str) -> Any:
    try:
        return json_format.ParseDict(data, message)
    except json_format.ParseError as e:
        raise ValueError(f"{what}: {e}") from None


def to_material(material: MaterialLike) -> pb.Material:
    """A ``glint.v1.Material`` from a message, a proto3-JSON dict or a JSON file path."""
    if isinstance(material, pb.Material):
        return material
    if isinstance(material, (str, os.PathLike)):
        return _parse(_read_json_file(material, "material"), pb.Material(), f"material ({os.fspath(material)})")
    if isinstance(material, Mapping):
        return _parse(dict(material), pb.Material(), "material")
    raise TypeError(
        f"material: expected a glint.v1.Material, a dict in its proto3 JSON form or a JSON file "
        f"path, got {type(material).__name__}"
    )


def to_lights(lights: LightsLike) -> List[pb.Light]:
    """The lights of a request from a ``LightList`` (message, ``{"lights": [...]}`` dict or JSON
    file path), a list of ``Light`` messages / dicts, or None (a BRDF probe batch)."""
    if lights is None:
        return []
    if isinstance(lights, pb.LightList):
        return list(lights.lights)
    if isinstance(lights, (str, os.PathLike)):
        data = _read_json_file(lights, "lights")
        return list(_parse(data, pb.LightList(), f"lights ({os.fspath(lights)})").lights)
    if isinstance(lights, Mapping):
        return list(_parse(dict(lights), pb.LightList(), "lights").lights)
    if isinstance(lights, Sequence):
        out = []
        for i, light in enumerate(lights):
            if isinstance(light, pb.Light):
                out.append(light)
            elif isinstance(light, Mapping):
                out.append(_parse(dict(light), pb.Light(), f"lights[{i}]"))
            else:
                raise TypeError(
                    f"lights[{i}]: expected a glint.v1.Light or a dict in its proto3 JSON form, "
                    f"got {type(light).__name__}"
                )
        return out
    raise TypeError(
        f"lights: expected a glint.v1.LightList, a dict {{'lights': [...]}}, a list of lights or "
        f"a JSON file path, got {type(lights).__name__}"
    )


def _enum(value: Any, names: Mapping[str, int], enum: Any, what: str) -> int:
    if isinstance(value, str):
        key = value.strip().lower()
        if key in names:
            return names[key]
        if value.upper() in enum.keys():
            return enum.Value(value.upper())
        raise ValueError(f"{what}: '{value}' is not one of {', '.join(sorted(names))}")
    if isinstance(value, int) and value in enum.values():
        return value
    raise ValueError(f"{what}: expected one of {', '.join(sorted(names))}, got {value!r}")


def to_precision(precision: Any) -> int:
    return _enum(precision, _PRECISIONS, pb.Precision, "precision")


def to_area_method(area_method: Any) -> int:
    return _enum(area_method, _AREA_METHODS, pb.AreaMethod, "area_method")
