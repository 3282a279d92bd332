from google.protobuf.internal import containers as _containers
from google.protobuf.internal import enum_type_wrapper as _enum_type_wrapper
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from collections.abc import Iterable as _Iterable, Mapping as _Mapping
from typing import ClassVar as _ClassVar, Optional as _Optional, Union as _Union

DESCRIPTOR: _descriptor.FileDescriptor

class Model(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    MODEL_UNSPECIFIED: _ClassVar[Model]
    SMOOTH: _ClassVar[Model]
    BINOMIAL: _ClassVar[Model]
    KEMPPINEN: _ClassVar[Model]
    CHERMAIN: _ClassVar[Model]
    NORMAL_MAP: _ClassVar[Model]

class Ndf(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    NDF_UNSPECIFIED: _ClassVar[Ndf]
    GGX: _ClassVar[Ndf]
    BECKMANN: _ClassVar[Ndf]

class ReflectionProbability(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    P_MODE_UNSPECIFIED: _ClassVar[ReflectionProbability]
    AREA: _ClassVar[ReflectionProbability]
    HEURISTIC_R: _ClassVar[ReflectionProbability]

class FootprintInterpolation(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    FOOTPRINT_INTERPOLATION_UNSPECIFIED: _ClassVar[FootprintInterpolation]
    TRILINEAR: _ClassVar[FootprintInterpolation]
    TETRAHEDRAL: _ClassVar[FootprintInterpolation]
    STOCHASTIC: _ClassVar[FootprintInterpolation]

class KemppinenNeighborhood(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    KEMPPINEN_NEIGHBORHOOD_UNSPECIFIED: _ClassVar[KemppinenNeighborhood]
    KEMPPINEN_PAPER: _ClassVar[KemppinenNeighborhood]
    KEMPPINEN_ONE_LEVEL: _ClassVar[KemppinenNeighborhood]
    KEMPPINEN_ONE_CELL: _ClassVar[KemppinenNeighborhood]

class AreaMethod(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    AREA_METHOD_UNSPECIFIED: _ClassVar[AreaMethod]
    LTC: _ClassVar[AreaMethod]
    LECOCQ: _ClassVar[AreaMethod]
    LECOCQ_PEARSON: _ClassVar[AreaMethod]
    MONTE_CARLO: _ClassVar[AreaMethod]
    REFERENCE: _ClassVar[AreaMethod]
    AUTO: _ClassVar[AreaMethod]

class Precision(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = ()
    PRECISION_UNSPECIFIED: _ClassVar[Precision]
    FP32: _ClassVar[Precision]
    FP64: _ClassVar[Precision]
MODEL_UNSPECIFIED: Model
SMOOTH: Model
BINOMIAL: Model
KEMPPINEN: Model
CHERMAIN: Model
NORMAL_MAP: Model
NDF_UNSPECIFIED: Ndf
GGX: Ndf
BECKMANN: Ndf
P_MODE_UNSPECIFIED: ReflectionProbability
AREA: ReflectionProbability
HEURISTIC_R: ReflectionProbability
FOOTPRINT_INTERPOLATION_UNSPECIFIED: FootprintInterpolation
TRILINEAR: FootprintInterpolation
TETRAHEDRAL: FootprintInterpolation
STOCHASTIC: FootprintInterpolation
KEMPPINEN_NEIGHBORHOOD_UNSPECIFIED: KemppinenNeighborhood
KEMPPINEN_PAPER: KemppinenNeighborhood
KEMPPINEN_ONE_LEVEL: KemppinenNeighborhood
KEMPPINEN_ONE_CELL: KemppinenNeighborhood
AREA_METHOD_UNSPECIFIED: AreaMethod
LTC: AreaMethod
LECOCQ: AreaMethod
LECOCQ_PEARSON: AreaMethod
MONTE_CARLO: AreaMethod
REFERENCE: AreaMethod
AUTO: AreaMethod
PRECISION_UNSPECIFIED: Precision
FP32: Precision
FP64: Precision

class SchlickFresnel(_message.Message):
    __slots__ = ("f0",)
    F0_FIELD_NUMBER: _ClassVar[int]
    f0: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, f0: _Optional[_Iterable[float]] = ...) -> None: ...

class ConductorFresnel(_message.Message):
    __slots__ = ("eta", "k")
    ETA_FIELD_NUMBER: _ClassVar[int]
    K_FIELD_NUMBER: _ClassVar[int]
    eta: _containers.RepeatedScalarFieldContainer[float]
    k: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, eta: _Optional[_Iterable[float]] = ..., k: _Optional[_Iterable[float]] = ...) -> None: ...

class DielectricFresnel(_message.Message):
    __slots__ = ("ior",)
    IOR_FIELD_NUMBER: _ClassVar[int]
    ior: float
    def __init__(self, ior: _Optional[float] = ...) -> None: ...

class BinomialParams(_message.Message):
    __slots__ = ("density", "p_mode", "r", "normal_threshold", "slope_cell", "footprint_interpolation")
    DENSITY_FIELD_NUMBER: _ClassVar[int]
    P_MODE_FIELD_NUMBER: _ClassVar[int]
    R_FIELD_NUMBER: _ClassVar[int]
    NORMAL_THRESHOLD_FIELD_NUMBER: _ClassVar[int]
    SLOPE_CELL_FIELD_NUMBER: _ClassVar[int]
    FOOTPRINT_INTERPOLATION_FIELD_NUMBER: _ClassVar[int]
    density: float
    p_mode: ReflectionProbability
    r: float
    normal_threshold: float
    slope_cell: float
    footprint_interpolation: FootprintInterpolation
    def __init__(self, density: _Optional[float] = ..., p_mode: _Optional[_Union[ReflectionProbability, str]] = ..., r: _Optional[float] = ..., normal_threshold: _Optional[float] = ..., slope_cell: _Optional[float] = ..., footprint_interpolation: _Optional[_Union[FootprintInterpolation, str]] = ...) -> None: ...

class ChermainParams(_message.Message):
    __slots__ = ("log_density", "relative_area", "density_randomisation", "max_anisotropy", "dictionary_size", "colors")
    LOG_DENSITY_FIELD_NUMBER: _ClassVar[int]
    RELATIVE_AREA_FIELD_NUMBER: _ClassVar[int]
    DENSITY_RANDOMISATION_FIELD_NUMBER: _ClassVar[int]
    MAX_ANISOTROPY_FIELD_NUMBER: _ClassVar[int]
    DICTIONARY_SIZE_FIELD_NUMBER: _ClassVar[int]
    COLORS_FIELD_NUMBER: _ClassVar[int]
    log_density: float
    relative_area: float
    density_randomisation: float
    max_anisotropy: float
    dictionary_size: int
    colors: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, log_density: _Optional[float] = ..., relative_area: _Optional[float] = ..., density_randomisation: _Optional[float] = ..., max_anisotropy: _Optional[float] = ..., dictionary_size: _Optional[int] = ..., colors: _Optional[_Iterable[float]] = ...) -> None: ...

class KemppinenParams(_message.Message):
    __slots__ = ("density", "microroughness", "filter_size", "neighbors", "anisotropy", "colors", "neighborhood")
    DENSITY_FIELD_NUMBER: _ClassVar[int]
    MICROROUGHNESS_FIELD_NUMBER: _ClassVar[int]
    FILTER_SIZE_FIELD_NUMBER: _ClassVar[int]
    NEIGHBORS_FIELD_NUMBER: _ClassVar[int]
    ANISOTROPY_FIELD_NUMBER: _ClassVar[int]
    COLORS_FIELD_NUMBER: _ClassVar[int]
    NEIGHBORHOOD_FIELD_NUMBER: _ClassVar[int]
    density: float
    microroughness: float
    filter_size: float
    neighbors: int
    anisotropy: float
    colors: _containers.RepeatedScalarFieldContainer[float]
    neighborhood: KemppinenNeighborhood
    def __init__(self, density: _Optional[float] = ..., microroughness: _Optional[float] = ..., filter_size: _Optional[float] = ..., neighbors: _Optional[int] = ..., anisotropy: _Optional[float] = ..., colors: _Optional[_Iterable[float]] = ..., neighborhood: _Optional[_Union[KemppinenNeighborhood, str]] = ...) -> None: ...

class NormalMapParams(_message.Message):
    __slots__ = ("digest", "intrinsic_roughness", "cutoff_sigma", "subdivision")
    DIGEST_FIELD_NUMBER: _ClassVar[int]
    INTRINSIC_ROUGHNESS_FIELD_NUMBER: _ClassVar[int]
    CUTOFF_SIGMA_FIELD_NUMBER: _ClassVar[int]
    SUBDIVISION_FIELD_NUMBER: _ClassVar[int]
    digest: str
    intrinsic_roughness: float
    cutoff_sigma: float
    subdivision: int
    def __init__(self, digest: _Optional[str] = ..., intrinsic_roughness: _Optional[float] = ..., cutoff_sigma: _Optional[float] = ..., subdivision: _Optional[int] = ...) -> None: ...

class Material(_message.Message):
    __slots__ = ("model", "ndf", "alpha_x", "alpha_y", "schlick", "conductor", "dielectric", "binomial", "kemppinen", "chermain", "normal_map")
    MODEL_FIELD_NUMBER: _ClassVar[int]
    NDF_FIELD_NUMBER: _ClassVar[int]
    ALPHA_X_FIELD_NUMBER: _ClassVar[int]
    ALPHA_Y_FIELD_NUMBER: _ClassVar[int]
    SCHLICK_FIELD_NUMBER: _ClassVar[int]
    CONDUCTOR_FIELD_NUMBER: _ClassVar[int]
    DIELECTRIC_FIELD_NUMBER: _ClassVar[int]
    BINOMIAL_FIELD_NUMBER: _ClassVar[int]
    KEMPPINEN_FIELD_NUMBER: _ClassVar[int]
    CHERMAIN_FIELD_NUMBER: _ClassVar[int]
    NORMAL_MAP_FIELD_NUMBER: _ClassVar[int]
    model: Model
    ndf: Ndf
    alpha_x: float
    alpha_y: float
    schlick: SchlickFresnel
    conductor: ConductorFresnel
    dielectric: DielectricFresnel
    binomial: BinomialParams
    kemppinen: KemppinenParams
    chermain: ChermainParams
    normal_map: NormalMapParams
    def __init__(self, model: _Optional[_Union[Model, str]] = ..., ndf: _Optional[_Union[Ndf, str]] = ..., alpha_x: _Optional[float] = ..., alpha_y: _Optional[float] = ..., schlick: _Optional[_Union[SchlickFresnel, _Mapping]] = ..., conductor: _Optional[_Union[ConductorFresnel, _Mapping]] = ..., dielectric: _Optional[_Union[DielectricFresnel, _Mapping]] = ..., binomial: _Optional[_Union[BinomialParams, _Mapping]] = ..., kemppinen: _Optional[_Union[KemppinenParams, _Mapping]] = ..., chermain: _Optional[_Union[ChermainParams, _Mapping]] = ..., normal_map: _Optional[_Union[NormalMapParams, _Mapping]] = ...) -> None: ...

class DirectionalLight(_message.Message):
    __slots__ = ("direction", "irradiance", "cone_half_angle_deg")
    DIRECTION_FIELD_NUMBER: _ClassVar[int]
    IRRADIANCE_FIELD_NUMBER: _ClassVar[int]
    CONE_HALF_ANGLE_DEG_FIELD_NUMBER: _ClassVar[int]
    direction: _containers.RepeatedScalarFieldContainer[float]
    irradiance: _containers.RepeatedScalarFieldContainer[float]
    cone_half_angle_deg: float
    def __init__(self, direction: _Optional[_Iterable[float]] = ..., irradiance: _Optional[_Iterable[float]] = ..., cone_half_angle_deg: _Optional[float] = ...) -> None: ...

class PointLight(_message.Message):
    __slots__ = ("position", "intensity", "radius")
    POSITION_FIELD_NUMBER: _ClassVar[int]
    INTENSITY_FIELD_NUMBER: _ClassVar[int]
    RADIUS_FIELD_NUMBER: _ClassVar[int]
    position: _containers.RepeatedScalarFieldContainer[float]
    intensity: _containers.RepeatedScalarFieldContainer[float]
    radius: float
    def __init__(self, position: _Optional[_Iterable[float]] = ..., intensity: _Optional[_Iterable[float]] = ..., radius: _Optional[float] = ...) -> None: ...

class PolygonLight(_message.Message):
    __slots__ = ("vertices", "radiance", "two_sided")
    VERTICES_FIELD_NUMBER: _ClassVar[int]
    RADIANCE_FIELD_NUMBER: _ClassVar[int]
    TWO_SIDED_FIELD_NUMBER: _ClassVar[int]
    vertices: _containers.RepeatedScalarFieldContainer[float]
    radiance: _containers.RepeatedScalarFieldContainer[float]
    two_sided: bool
    def __init__(self, vertices: _Optional[_Iterable[float]] = ..., radiance: _Optional[_Iterable[float]] = ..., two_sided: bool = ...) -> None: ...

class Light(_message.Message):
    __slots__ = ("directional", "point", "polygon")
    DIRECTIONAL_FIELD_NUMBER: _ClassVar[int]
    POINT_FIELD_NUMBER: _ClassVar[int]
    POLYGON_FIELD_NUMBER: _ClassVar[int]
    directional: DirectionalLight
    point: PointLight
    polygon: PolygonLight
    def __init__(self, directional: _Optional[_Union[DirectionalLight, _Mapping]] = ..., point: _Optional[_Union[PointLight, _Mapping]] = ..., polygon: _Optional[_Union[PolygonLight, _Mapping]] = ...) -> None: ...

class LightList(_message.Message):
    __slots__ = ("lights",)
    LIGHTS_FIELD_NUMBER: _ClassVar[int]
    lights: _containers.RepeatedCompositeFieldContainer[Light]
    def __init__(self, lights: _Optional[_Iterable[_Union[Light, _Mapping]]] = ...) -> None: ...

class QueryBatch(_message.Message):
    __slots__ = ("count", "uv", "footprint", "wo", "wi", "position", "normal", "tangent")
    COUNT_FIELD_NUMBER: _ClassVar[int]
    UV_FIELD_NUMBER: _ClassVar[int]
    FOOTPRINT_FIELD_NUMBER: _ClassVar[int]
    WO_FIELD_NUMBER: _ClassVar[int]
    WI_FIELD_NUMBER: _ClassVar[int]
    POSITION_FIELD_NUMBER: _ClassVar[int]
    NORMAL_FIELD_NUMBER: _ClassVar[int]
    TANGENT_FIELD_NUMBER: _ClassVar[int]
    count: int
    uv: _containers.RepeatedScalarFieldContainer[float]
    footprint: _containers.RepeatedScalarFieldContainer[float]
    wo: _containers.RepeatedScalarFieldContainer[float]
    wi: _containers.RepeatedScalarFieldContainer[float]
    position: _containers.RepeatedScalarFieldContainer[float]
    normal: _containers.RepeatedScalarFieldContainer[float]
    tangent: _containers.RepeatedScalarFieldContainer[float]
    def __init__(self, count: _Optional[int] = ..., uv: _Optional[_Iterable[float]] = ..., footprint: _Optional[_Iterable[float]] = ..., wo: _Optional[_Iterable[float]] = ..., wi: _Optional[_Iterable[float]] = ..., position: _Optional[_Iterable[float]] = ..., normal: _Optional[_Iterable[float]] = ..., tangent: _Optional[_Iterable[float]] = ...) -> None: ...

class EvaluateRequest(_message.Message):
    __slots__ = ("material", "lights", "queries", "precision", "seed", "area_method", "area_samples", "shared_memory", "max_relative_error")
    MATERIAL_FIELD_NUMBER: _ClassVar[int]
    LIGHTS_FIELD_NUMBER: _ClassVar[int]
    QUERIES_FIELD_NUMBER: _ClassVar[int]
    PRECISION_FIELD_NUMBER: _ClassVar[int]
    SEED_FIELD_NUMBER: _ClassVar[int]
    AREA_METHOD_FIELD_NUMBER: _ClassVar[int]
    AREA_SAMPLES_FIELD_NUMBER: _ClassVar[int]
    SHARED_MEMORY_FIELD_NUMBER: _ClassVar[int]
    MAX_RELATIVE_ERROR_FIELD_NUMBER: _ClassVar[int]
    material: Material
    lights: _containers.RepeatedCompositeFieldContainer[Light]
    queries: QueryBatch
    precision: Precision
    seed: int
    area_method: AreaMethod
    area_samples: int
    shared_memory: SharedMemoryIo
    max_relative_error: float
    def __init__(self, material: _Optional[_Union[Material, _Mapping]] = ..., lights: _Optional[_Iterable[_Union[Light, _Mapping]]] = ..., queries: _Optional[_Union[QueryBatch, _Mapping]] = ..., precision: _Optional[_Union[Precision, str]] = ..., seed: _Optional[int] = ..., area_method: _Optional[_Union[AreaMethod, str]] = ..., area_samples: _Optional[int] = ..., shared_memory: _Optional[_Union[SharedMemoryIo, _Mapping]] = ..., max_relative_error: _Optional[float] = ...) -> None: ...

class EvaluateStats(_message.Message):
    __slots__ = ("queue_ms", "compute_ms", "device", "batch_requests", "compile_ms")
    QUEUE_MS_FIELD_NUMBER: _ClassVar[int]
    COMPUTE_MS_FIELD_NUMBER: _ClassVar[int]
    DEVICE_FIELD_NUMBER: _ClassVar[int]
    BATCH_REQUESTS_FIELD_NUMBER: _ClassVar[int]
    COMPILE_MS_FIELD_NUMBER: _ClassVar[int]
    queue_ms: float
    compute_ms: float
    device: str
    batch_requests: int
    compile_ms: float
    def __init__(self, queue_ms: _Optional[float] = ..., compute_ms: _Optional[float] = ..., device: _Optional[str] = ..., batch_requests: _Optional[int] = ..., compile_ms: _Optional[float] = ...) -> None: ...

class EvaluateResponse(_message.Message):
    __slots__ = ("count", "radiance", "stats")
    COUNT_FIELD_NUMBER: _ClassVar[int]
    RADIANCE_FIELD_NUMBER: _ClassVar[int]
    STATS_FIELD_NUMBER: _ClassVar[int]
    count: int
    radiance: _containers.RepeatedScalarFieldContainer[float]
    stats: EvaluateStats
    def __init__(self, count: _Optional[int] = ..., radiance: _Optional[_Iterable[float]] = ..., stats: _Optional[_Union[EvaluateStats, _Mapping]] = ...) -> None: ...

class EvaluateChunk(_message.Message):
    __slots__ = ("chunk_index", "request")
    CHUNK_INDEX_FIELD_NUMBER: _ClassVar[int]
    REQUEST_FIELD_NUMBER: _ClassVar[int]
    chunk_index: int
    request: EvaluateRequest
    def __init__(self, chunk_index: _Optional[int] = ..., request: _Optional[_Union[EvaluateRequest, _Mapping]] = ...) -> None: ...

class EvaluateChunkResult(_message.Message):
    __slots__ = ("chunk_index", "first_query", "result")
    CHUNK_INDEX_FIELD_NUMBER: _ClassVar[int]
    FIRST_QUERY_FIELD_NUMBER: _ClassVar[int]
    RESULT_FIELD_NUMBER: _ClassVar[int]
    chunk_index: int
    first_query: int
    result: EvaluateResponse
    def __init__(self, chunk_index: _Optional[int] = ..., first_query: _Optional[int] = ..., result: _Optional[_Union[EvaluateResponse, _Mapping]] = ...) -> None: ...

class GetCapabilitiesRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class Capabilities(_message.Message):
    __slots__ = ("server_version", "device_name", "device_vendor", "device_opencl_version", "driver_version", "platform_name", "compute_units", "fp64", "models", "ndfs", "fresnel_kinds", "light_kinds", "max_batch", "max_message_bytes", "max_lights", "max_pending_requests", "unit_vector_tolerance", "max_normal_map_upload_bytes", "max_normal_map_texels", "normal_map_budget_bytes", "max_shared_memory_regions", "max_shared_memory_bytes", "max_request_cost", "max_query_cost", "slice_ms", "batch_delay_us", "batch_max_queries")
    SERVER_VERSION_FIELD_NUMBER: _ClassVar[int]
    DEVICE_NAME_FIELD_NUMBER: _ClassVar[int]
    DEVICE_VENDOR_FIELD_NUMBER: _ClassVar[int]
    DEVICE_OPENCL_VERSION_FIELD_NUMBER: _ClassVar[int]
    DRIVER_VERSION_FIELD_NUMBER: _ClassVar[int]
    PLATFORM_NAME_FIELD_NUMBER: _ClassVar[int]
    COMPUTE_UNITS_FIELD_NUMBER: _ClassVar[int]
    FP64_FIELD_NUMBER: _ClassVar[int]
    MODELS_FIELD_NUMBER: _ClassVar[int]
    NDFS_FIELD_NUMBER: _ClassVar[int]
    FRESNEL_KINDS_FIELD_NUMBER: _ClassVar[int]
    LIGHT_KINDS_FIELD_NUMBER: _ClassVar[int]
    MAX_BATCH_FIELD_NUMBER: _ClassVar[int]
    MAX_MESSAGE_BYTES_FIELD_NUMBER: _ClassVar[int]
    MAX_LIGHTS_FIELD_NUMBER: _ClassVar[int]
    MAX_PENDING_REQUESTS_FIELD_NUMBER: _ClassVar[int]
    UNIT_VECTOR_TOLERANCE_FIELD_NUMBER: _ClassVar[int]
    MAX_NORMAL_MAP_UPLOAD_BYTES_FIELD_NUMBER: _ClassVar[int]
    MAX_NORMAL_MAP_TEXELS_FIELD_NUMBER: _ClassVar[int]
    NORMAL_MAP_BUDGET_BYTES_FIELD_NUMBER: _ClassVar[int]
    MAX_SHARED_MEMORY_REGIONS_FIELD_NUMBER: _ClassVar[int]
    MAX_SHARED_MEMORY_BYTES_FIELD_NUMBER: _ClassVar[int]
    MAX_REQUEST_COST_FIELD_NUMBER: _ClassVar[int]
    MAX_QUERY_COST_FIELD_NUMBER: _ClassVar[int]
    SLICE_MS_FIELD_NUMBER: _ClassVar[int]
    BATCH_DELAY_US_FIELD_NUMBER: _ClassVar[int]
    BATCH_MAX_QUERIES_FIELD_NUMBER: _ClassVar[int]
    server_version: str
    device_name: str
    device_vendor: str
    device_opencl_version: str
    driver_version: str
    platform_name: str
    compute_units: int
    fp64: bool
    models: _containers.RepeatedScalarFieldContainer[str]
    ndfs: _containers.RepeatedScalarFieldContainer[str]
    fresnel_kinds: _containers.RepeatedScalarFieldContainer[str]
    light_kinds: _containers.RepeatedScalarFieldContainer[str]
    max_batch: int
    max_message_bytes: int
    max_lights: int
    max_pending_requests: int
    unit_vector_tolerance: float
    max_normal_map_upload_bytes: int
    max_normal_map_texels: int
    normal_map_budget_bytes: int
    max_shared_memory_regions: int
    max_shared_memory_bytes: int
    max_request_cost: float
    max_query_cost: float
    slice_ms: float
    batch_delay_us: int
    batch_max_queries: int
    def __init__(self, server_version: _Optional[str] = ..., device_name: _Optional[str] = ..., device_vendor: _Optional[str] = ..., device_opencl_version: _Optional[str] = ..., driver_version: _Optional[str] = ..., platform_name: _Optional[str] = ..., compute_units: _Optional[int] = ..., fp64: bool = ..., models: _Optional[_Iterable[str]] = ..., ndfs: _Optional[_Iterable[str]] = ..., fresnel_kinds: _Optional[_Iterable[str]] = ..., light_kinds: _Optional[_Iterable[str]] = ..., max_batch: _Optional[int] = ..., max_message_bytes: _Optional[int] = ..., max_lights: _Optional[int] = ..., max_pending_requests: _Optional[int] = ..., unit_vector_tolerance: _Optional[float] = ..., max_normal_map_upload_bytes: _Optional[int] = ..., max_normal_map_texels: _Optional[int] = ..., normal_map_budget_bytes: _Optional[int] = ..., max_shared_memory_regions: _Optional[int] = ..., max_shared_memory_bytes: _Optional[int] = ..., max_request_cost: _Optional[float] = ..., max_query_cost: _Optional[float] = ..., slice_ms: _Optional[float] = ..., batch_delay_us: _Optional[int] = ..., batch_max_queries: _Optional[int] = ...) -> None: ...

class SampleRequest(_message.Message):
    __slots__ = ("material", "queries", "samples_per_query", "seed", "precision")
    MATERIAL_FIELD_NUMBER: _ClassVar[int]
    QUERIES_FIELD_NUMBER: _ClassVar[int]
    SAMPLES_PER_QUERY_FIELD_NUMBER: _ClassVar[int]
    SEED_FIELD_NUMBER: _ClassVar[int]
    PRECISION_FIELD_NUMBER: _ClassVar[int]
    material: Material
    queries: QueryBatch
    samples_per_query: int
    seed: int
    precision: Precision
    def __init__(self, material: _Optional[_Union[Material, _Mapping]] = ..., queries: _Optional[_Union[QueryBatch, _Mapping]] = ..., samples_per_query: _Optional[int] = ..., seed: _Optional[int] = ..., precision: _Optional[_Union[Precision, str]] = ...) -> None: ...

class SampleResponse(_message.Message):
    __slots__ = ("count", "samples_per_query", "wi", "pdf", "weight", "stats")
    COUNT_FIELD_NUMBER: _ClassVar[int]
    SAMPLES_PER_QUERY_FIELD_NUMBER: _ClassVar[int]
    WI_FIELD_NUMBER: _ClassVar[int]
    PDF_FIELD_NUMBER: _ClassVar[int]
    WEIGHT_FIELD_NUMBER: _ClassVar[int]
    STATS_FIELD_NUMBER: _ClassVar[int]
    count: int
    samples_per_query: int
    wi: _containers.RepeatedScalarFieldContainer[float]
    pdf: _containers.RepeatedScalarFieldContainer[float]
    weight: _containers.RepeatedScalarFieldContainer[float]
    stats: EvaluateStats
    def __init__(self, count: _Optional[int] = ..., samples_per_query: _Optional[int] = ..., wi: _Optional[_Iterable[float]] = ..., pdf: _Optional[_Iterable[float]] = ..., weight: _Optional[_Iterable[float]] = ..., stats: _Optional[_Union[EvaluateStats, _Mapping]] = ...) -> None: ...

class NormalMapChunk(_message.Message):
    __slots__ = ("filename", "data")
    FILENAME_FIELD_NUMBER: _ClassVar[int]
    DATA_FIELD_NUMBER: _ClassVar[int]
    filename: str
    data: bytes
    def __init__(self, filename: _Optional[str] = ..., data: _Optional[bytes] = ...) -> None: ...

class NormalMapInfo(_message.Message):
    __slots__ = ("digest", "width", "height", "bytes", "already_present", "filename")
    DIGEST_FIELD_NUMBER: _ClassVar[int]
    WIDTH_FIELD_NUMBER: _ClassVar[int]
    HEIGHT_FIELD_NUMBER: _ClassVar[int]
    BYTES_FIELD_NUMBER: _ClassVar[int]
    ALREADY_PRESENT_FIELD_NUMBER: _ClassVar[int]
    FILENAME_FIELD_NUMBER: _ClassVar[int]
    digest: str
    width: int
    height: int
    bytes: int
    already_present: bool
    filename: str
    def __init__(self, digest: _Optional[str] = ..., width: _Optional[int] = ..., height: _Optional[int] = ..., bytes: _Optional[int] = ..., already_present: bool = ..., filename: _Optional[str] = ...) -> None: ...

class ListNormalMapsRequest(_message.Message):
    __slots__ = ("page_size", "page_token")
    PAGE_SIZE_FIELD_NUMBER: _ClassVar[int]
    PAGE_TOKEN_FIELD_NUMBER: _ClassVar[int]
    page_size: int
    page_token: str
    def __init__(self, page_size: _Optional[int] = ..., page_token: _Optional[str] = ...) -> None: ...

class ListNormalMapsResponse(_message.Message):
    __slots__ = ("maps", "next_page_token")
    MAPS_FIELD_NUMBER: _ClassVar[int]
    NEXT_PAGE_TOKEN_FIELD_NUMBER: _ClassVar[int]
    maps: _containers.RepeatedCompositeFieldContainer[NormalMapInfo]
    next_page_token: str
    def __init__(self, maps: _Optional[_Iterable[_Union[NormalMapInfo, _Mapping]]] = ..., next_page_token: _Optional[str] = ...) -> None: ...

class DeleteNormalMapRequest(_message.Message):
    __slots__ = ("digest",)
    DIGEST_FIELD_NUMBER: _ClassVar[int]
    digest: str
    def __init__(self, digest: _Optional[str] = ...) -> None: ...

class DeleteNormalMapResponse(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class RegisterSharedMemoryRequest(_message.Message):
    __slots__ = ("name", "key", "offset", "byte_size")
    NAME_FIELD_NUMBER: _ClassVar[int]
    KEY_FIELD_NUMBER: _ClassVar[int]
    OFFSET_FIELD_NUMBER: _ClassVar[int]
    BYTE_SIZE_FIELD_NUMBER: _ClassVar[int]
    name: str
    key: str
    offset: int
    byte_size: int
    def __init__(self, name: _Optional[str] = ..., key: _Optional[str] = ..., offset: _Optional[int] = ..., byte_size: _Optional[int] = ...) -> None: ...

class RegisterSharedMemoryResponse(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class SharedMemoryRegion(_message.Message):
    __slots__ = ("name", "key", "offset", "byte_size")
    NAME_FIELD_NUMBER: _ClassVar[int]
    KEY_FIELD_NUMBER: _ClassVar[int]
    OFFSET_FIELD_NUMBER: _ClassVar[int]
    BYTE_SIZE_FIELD_NUMBER: _ClassVar[int]
    name: str
    key: str
    offset: int
    byte_size: int
    def __init__(self, name: _Optional[str] = ..., key: _Optional[str] = ..., offset: _Optional[int] = ..., byte_size: _Optional[int] = ...) -> None: ...

class ListSharedMemoryRequest(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class ListSharedMemoryResponse(_message.Message):
    __slots__ = ("regions",)
    REGIONS_FIELD_NUMBER: _ClassVar[int]
    regions: _containers.RepeatedCompositeFieldContainer[SharedMemoryRegion]
    def __init__(self, regions: _Optional[_Iterable[_Union[SharedMemoryRegion, _Mapping]]] = ...) -> None: ...

class UnregisterSharedMemoryRequest(_message.Message):
    __slots__ = ("name",)
    NAME_FIELD_NUMBER: _ClassVar[int]
    name: str
    def __init__(self, name: _Optional[str] = ...) -> None: ...

class UnregisterSharedMemoryResponse(_message.Message):
    __slots__ = ()
    def __init__(self) -> None: ...

class SharedMemoryIo(_message.Message):
    __slots__ = ("count", "input_region", "input_offset", "input_byte_size", "uv", "footprint", "wi", "frame", "output_region", "output_offset")
    COUNT_FIELD_NUMBER: _ClassVar[int]
    INPUT_REGION_FIELD_NUMBER: _ClassVar[int]
    INPUT_OFFSET_FIELD_NUMBER: _ClassVar[int]
    INPUT_BYTE_SIZE_FIELD_NUMBER: _ClassVar[int]
    UV_FIELD_NUMBER: _ClassVar[int]
    FOOTPRINT_FIELD_NUMBER: _ClassVar[int]
    WI_FIELD_NUMBER: _ClassVar[int]
    FRAME_FIELD_NUMBER: _ClassVar[int]
    OUTPUT_REGION_FIELD_NUMBER: _ClassVar[int]
    OUTPUT_OFFSET_FIELD_NUMBER: _ClassVar[int]
    count: int
    input_region: str
    input_offset: int
    input_byte_size: int
    uv: bool
    footprint: bool
    wi: bool
    frame: bool
    output_region: str
    output_offset: int
    def __init__(self, count: _Optional[int] = ..., input_region: _Optional[str] = ..., input_offset: _Optional[int] = ..., input_byte_size: _Optional[int] = ..., uv: bool = ..., footprint: bool = ..., wi: bool = ..., frame: bool = ..., output_region: _Optional[str] = ..., output_offset: _Optional[int] = ...) -> None: ...
