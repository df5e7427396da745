"""Type stubs of the orogen package (see ``__init__.py`` for the docs)."""

import os
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

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
    dem: DemInput, *, transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ...,
) -> Any: ...
def fill_epsilon(
    dem: DemInput, *, transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ...,
) -> Any: ...
def breach(
    dem: DemInput, *, method: str = ..., max_depth: Optional[float] = ..., max_length: Optional[int] = ...,
    dist: int = ..., fill_remaining: bool = ..., epsilon: bool = ...,
    transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ...,
) -> Any: ...
def flow(
    dem: DemInput, *, method: str = ..., seed: int = ...,
    transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ...,
) -> Any: ...
def accumulate(
    src: DemInput, *, method: str = ..., exponent: float = ..., weights: Optional[PathLike] = ...,
    transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ...,
) -> Any: ...
def watersheds(
    dirs: DemInput, *, transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ...,
) -> Any: ...
def slope(
    dem: DemInput, *, units: str = ..., z_factor: float = ..., compute_edges: bool = ...,
    transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ...,
) -> Any: ...
def aspect(
    dem: DemInput, *, zero_for_flat: bool = ..., compute_edges: bool = ...,
    transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ...,
) -> Any: ...
def hillshade(
    dem: DemInput, *, azimuth: float = ..., altitude: float = ..., z_factor: float = ..., compute_edges: bool = ...,
    transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ...,
) -> Any: ...
def export(
    dem: DemInput, output: PathLike, *, transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ...,
    memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ...,
) -> Raster: ...
def metrics(
    dem: DemInput, metric: Union[str, Sequence[str]], *,
    transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    format: Optional[Mapping[str, Any]] = ..., file_format: str = ...,
) -> Dict[str, Any]: ...
def peaks(
    dem: DemInput, *, min_prominence: float = ..., edge: str = ..., no_isolation: bool = ..., tiled: bool = ...,
    line_parents: bool = ..., transform: Transform = ..., crs: CrsLike = ..., nodata: Optional[float] = ...,
    output: Optional[PathLike] = ..., memory: Optional[str] = ..., tile: Optional[int] = ..., threads: int = ...,
    as_dataframe: bool = ...,
) -> Any: ...

from . import synth as synth
