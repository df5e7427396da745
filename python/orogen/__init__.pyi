"""Type stubs of the orogen package (see ``__init__.py`` for the docs)."""

import os
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from ._orogen import (
    CorruptInputError as CorruptInputError,
    InternalError as InternalError,
    InvalidInputError as InvalidInputError,
    MemoryBudgetError as MemoryBudgetError,
    OrogenError as OrogenError,
    StorageError as StorageError,
    UnsupportedFormatError as UnsupportedFormatError,
)

__version__: str

PathLike = Union[str, os.PathLike]
# A numpy array, an xarray DataArray, a path or an opened Raster.
DemInput = Any
# A GDAL 6-tuple or an affine.Affine.
Transform = Any
# An EPSG code, "EPSG:n", WKT, or a pyproj / rasterio CRS.
CrsLike = Any
Window = Tuple[int, int, int, int]
# A callback (step, done, total) -> False to stop, or True for a tqdm bar.
Progress = Union[None, bool, Callable[[str, int, int], Optional[bool]]]

class Raster:
    def __init__(self, path: PathLike) -> None: ...
    @property
    def path(self) -> str: ...
    @property
    def shape(self) -> Tuple[int, int]: ...
    @property
    def dtype(self) -> np.dtype: ...
    @property
    def transform(self) -> Optional[Tuple[float, float, float, float, float, float]]: ...
    @property
    def crs(self) -> Optional[int]: ...
    @property
    def nodata(self) -> Optional[float]: ...
    def read(self, window: Optional[Window] = ...) -> np.ndarray: ...
    def to_xarray(self, window: Optional[Window] = ...) -> Any: ...

def open(path: PathLike) -> Raster: ...
def defaults(op: str) -> Dict[str, Any]: ...
def fill(
    dem: DemInput, *, sinks: Optional[PathLike] = ..., transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ..., sea_level: Optional[float] = ..., mask: Optional[Union[PathLike, Raster]] = ..., allow_sparse: bool = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ..., progress: Progress = ...,
) -> Any: ...
def fill_epsilon(
    dem: DemInput, *, transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ..., sea_level: Optional[float] = ..., mask: Optional[Union[PathLike, Raster]] = ..., allow_sparse: bool = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ..., progress: Progress = ...,
) -> Any: ...
def breach(
    dem: DemInput, *, method: str = ..., max_depth: Optional[float] = ..., max_length: Optional[int] = ...,
    dist: int = ..., fill_remaining: bool = ..., epsilon: bool = ...,
    transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ..., sea_level: Optional[float] = ..., mask: Optional[Union[PathLike, Raster]] = ..., allow_sparse: bool = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ..., progress: Progress = ...,
) -> Any: ...
def flow(
    dem: DemInput, *, method: str = ..., seed: int = ...,
    sinks: Optional[PathLike] = ..., transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ..., sea_level: Optional[float] = ..., mask: Optional[Union[PathLike, Raster]] = ..., allow_sparse: bool = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ..., progress: Progress = ...,
) -> Any: ...
def accumulate(
    src: DemInput, *, method: str = ..., exponent: float = ..., weights: Optional[PathLike] = ...,
    units: str = ..., transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ..., sea_level: Optional[float] = ..., mask: Optional[Union[PathLike, Raster]] = ..., allow_sparse: bool = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ..., progress: Progress = ...,
) -> Any: ...
def watersheds(
    dirs: DemInput, *, transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ..., sea_level: Optional[float] = ..., mask: Optional[Union[PathLike, Raster]] = ..., allow_sparse: bool = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ..., progress: Progress = ...,
) -> Any: ...
def slope(
    dem: DemInput, *, units: str = ..., z_factor: float = ..., compute_edges: bool = ...,
    transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ..., sea_level: Optional[float] = ..., mask: Optional[Union[PathLike, Raster]] = ..., allow_sparse: bool = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ..., progress: Progress = ...,
) -> Any: ...
def aspect(
    dem: DemInput, *, zero_for_flat: bool = ..., compute_edges: bool = ...,
    transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ..., sea_level: Optional[float] = ..., mask: Optional[Union[PathLike, Raster]] = ..., allow_sparse: bool = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ..., progress: Progress = ...,
) -> Any: ...
def hillshade(
    dem: DemInput, *, azimuth: float = ..., altitude: float = ..., z_factor: float = ..., compute_edges: bool = ...,
    transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ..., sea_level: Optional[float] = ..., mask: Optional[Union[PathLike, Raster]] = ..., allow_sparse: bool = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ..., progress: Progress = ...,
) -> Any: ...
def export(
    dem: DemInput, output: PathLike, *, transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ..., sea_level: Optional[float] = ..., mask: Optional[Union[PathLike, Raster]] = ..., allow_sparse: bool = ...,
    memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ..., progress: Progress = ...,
) -> Raster: ...
def metrics(
    dem: DemInput, metric: Union[str, Sequence[str]], *,
    transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ..., sea_level: Optional[float] = ..., mask: Optional[Union[PathLike, Raster]] = ..., allow_sparse: bool = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ..., file_format: str = ..., progress: Progress = ...,
) -> Dict[str, Any]: ...
def peaks(
    dem: DemInput, *, min_prominence: float = ..., edge: str = ..., no_isolation: bool = ..., tiled: bool = ...,
    line_parents: bool = ..., transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ..., sea_level: Optional[float] = ..., mask: Optional[Union[PathLike, Raster]] = ..., allow_sparse: bool = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    as_dataframe: bool = ..., progress: Progress = ..., geojson_crs: str = ...,
) -> Any: ...

def erode(
    dem: DemInput, model: str = ..., steps: Optional[int] = ..., *, water: Union[bool, PathLike] = ...,
    sediment: Union[bool, PathLike] = ..., set: Optional[Mapping[str, Any]] = ...,
    transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ..., sea_level: Optional[float] = ..., mask: Optional[Union[PathLike, Raster]] = ..., allow_sparse: bool = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ..., progress: Progress = ..., **params: Any,
) -> Any: ...

# The registry commands (orogen._commands): every keyword beyond these is an
# option of `orogen <command> --help` with `_` for `-`.
def run_command(
    command: str, inputs: Sequence[Any] = ..., output: Optional[PathLike] = ..., *, progress: Progress = ...,
    transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ..., **options: Any,
) -> List[Tuple[str, str]]: ...
def fill_nodata(
    dem: DemInput, *, output: Optional[PathLike] = ..., progress: Progress = ..., transform: Transform = ...,
    crs: CrsLike = ..., nodata: Optional[float] = ..., **options: Any,
) -> Any: ...
def basins(
    dirs: DemInput, *, output: Optional[PathLike] = ..., progress: Progress = ..., transform: Transform = ...,
    crs: CrsLike = ..., nodata: Optional[float] = ..., **options: Any,
) -> Any: ...
def streams(
    dirs: DemInput, *, output: PathLike, progress: Progress = ..., transform: Transform = ...,
    crs: CrsLike = ..., nodata: Optional[float] = ..., **options: Any,
) -> List[str]: ...
def hydro_index(
    index: str, *, output: Optional[PathLike] = ..., progress: Progress = ..., transform: Transform = ...,
    crs: CrsLike = ..., nodata: Optional[float] = ..., **options: Any,
) -> Any: ...
def viewshed(
    dem: DemInput, *, output: Optional[PathLike] = ..., progress: Progress = ..., transform: Transform = ...,
    crs: CrsLike = ..., nodata: Optional[float] = ..., **options: Any,
) -> Any: ...
def render(
    dem: DemInput, *, output: PathLike, progress: Progress = ..., transform: Transform = ...,
    crs: CrsLike = ..., nodata: Optional[float] = ..., **options: Any,
) -> List[str]: ...
def tiles(
    dem: DemInput, *, output: PathLike, progress: Progress = ..., transform: Transform = ...,
    crs: CrsLike = ..., nodata: Optional[float] = ..., **options: Any,
) -> List[str]: ...
def ridges(
    dem: DemInput, *, output: PathLike, progress: Progress = ..., transform: Transform = ...,
    crs: CrsLike = ..., nodata: Optional[float] = ..., **options: Any,
) -> List[str]: ...
def orostats(
    dem: DemInput, *, output: PathLike, progress: Progress = ..., transform: Transform = ...,
    crs: CrsLike = ..., nodata: Optional[float] = ..., **options: Any,
) -> List[str]: ...
def compare(
    a: DemInput, b: DemInput, *, output: PathLike, progress: Progress = ..., transform: Transform = ...,
    crs: CrsLike = ..., nodata: Optional[float] = ..., **options: Any,
) -> Dict[str, Any]: ...
def ingest(
    inputs: Union[PathLike, Sequence[PathLike]], *, output: PathLike, progress: Progress = ..., **options: Any,
) -> Raster: ...
def info(
    src: DemInput, *, stats: bool = ..., transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ...,
) -> Dict[str, Any]: ...
def run_job(
    path: PathLike, *, memory: Optional[str] = ..., threads: Optional[int] = ..., dry_run: bool = ...,
) -> List[str]: ...

from . import synth as synth
