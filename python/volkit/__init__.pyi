"""Type stubs for volkit (the extension module volkit._volkit)."""

import os
from typing import Any, Callable, Optional, Sequence, Tuple, Union, overload

import numpy as np
import numpy.typing as npt

__version__: str

PathLike = Union[str, "os.PathLike[str]"]
Vec3 = Tuple[float, float, float]
Mat3 = Sequence[Sequence[float]]

class Volume:
    """An open volume. Geometry is in numpy's axis order (z, y, x); slicing
    with slices gives a Volume whose geometry follows."""

    @property
    def shape(self) -> Tuple[int, int, int]:
        """Voxels per axis, (z, y, x)."""
    @property
    def dtype(self) -> np.dtype[Any]:
        """uint8, uint16, int16 or float32."""
    @property
    def spacing(self) -> Vec3:
        """World distance between neighbouring voxels, (z, y, x)."""
    @property
    def origin(self) -> Vec3:
        """World position of voxel (0, 0, 0): its LPS z, y and x."""
    @property
    def direction(self) -> Tuple[Vec3, Vec3, Vec3]:
        """3x3 direction cosines; column j is array axis j's world
        direction, rows and columns both in (z, y, x) order."""
    @property
    def unit(self) -> Optional[str]:
        """The unit of length of spacing and origin by its NGFF name ("micrometer", "millimeter", ...), or None when the file states none."""
    @property
    def path(self) -> Optional[str]:
        """The file the volume was opened from, or None."""
    @property
    def layout(self) -> str:
        """``sliced`` or ``bricked:B``."""
    @property
    def compression(self) -> str:
        """``none`` or ``zstd:LEVEL``."""
    @property
    def range(self) -> Optional[Tuple[float, float]]:
        """Smallest and largest sample (None when unknown or all NaN)."""
    @property
    def mapped(self) -> bool:
        """Whether the samples are a memory map of the file (then
        ``array()`` is a read-only view of it)."""
    @property
    def affine(self) -> npt.NDArray[np.float64]:
        """4x4 affine from index (z, y, x, 1) to world (LPS z, y, x, 1):
        direction times spacing, origin in the last column (napari's
        ``affine``)."""
    def array(self) -> npt.NDArray[Any]:
        """The samples, shape (z, y, x): a read-only view of the memory map
        when ``mapped`` (no copy), else a new writable array."""
    @overload
    def __getitem__(self, key: Union[slice, Tuple[slice, ...]]) -> "Volume":
        """Slices: a new Volume in memory whose origin, spacing and
        direction follow the slice (start, step, reversal)."""
    @overload
    def __getitem__(self, key: Any) -> npt.NDArray[Any]:
        """Any other key (an integer dropping an axis, ...): the numpy
        array's item, without geometry."""
    def __array__(self, dtype: Any = ..., copy: Optional[bool] = ...) -> npt.NDArray[Any]: ...

class Index:
    """A volume's min/max macrocell index."""

    @property
    def shape(self) -> Tuple[int, int, int]: ...
    @property
    def cell(self) -> int: ...
    @property
    def cells(self) -> int: ...
    @property
    def levels(self) -> int: ...
    @property
    def range(self) -> Optional[Tuple[float, float]]: ...
    @property
    def empty_fraction(self) -> float: ...
    @property
    def nan_count(self) -> int: ...
    @property
    def fingerprint(self) -> int: ...
    def histogram(self) -> Tuple[npt.NDArray[np.uint64], float, float]:
        """(counts, lo, hi): equal bins over [lo, hi)."""
    def save(self, path: PathLike) -> int:
        """Write a .vidx file atomically; returns the bytes written."""

def open(
    path: PathLike,
    *,
    raw_dims: Optional[str] = ...,
    shape: Optional[Sequence[int]] = ...,
    raw_type: Optional[str] = ...,
    raw_endian: Optional[str] = ...,
    raw_skip: Optional[int] = ...,
    channel: Optional[int] = ...,
    luma: bool = ...,
    time_point: Optional[int] = ...,
    series: Union[None, int, str] = ...,
    echo: Optional[int] = ...,
    philips_scale: Optional[str] = ...,
    level: Optional[int] = ...,
    in_memory: bool = ...,
) -> Volume:
    """Open anything vol-convert reads, with its selection options
    (``raw_dims`` is vol-convert's text ``"X,Y,Z"``; ``shape`` the same in
    numpy order; ``echo`` an echo of a multi-echo DICOM series;
    ``philips_scale`` ``"displayed"`` or ``"precise"`` for a Philips
    series with a private scale slope; ``level`` a level of an OME-Zarr
    pyramid, 0 by default).
    A keyword the input has nothing to pick with (``channel`` of a NIfTI,
    ``series`` of anything but DICOM, ``level`` of anything but OME-Zarr)
    raises ValueError."""

def from_array(
    array: npt.ArrayLike,
    spacing: Optional[Sequence[float]] = ...,
    origin: Optional[Sequence[float]] = ...,
    direction: Optional[Mat3] = ...,
) -> Volume:
    """A Volume in memory from a (z, y, x) array of uint8, uint16, int16 or
    float32 (a copy, in logical order whatever the array's memory layout;
    a 2D array is one slice), with ``spacing``, ``origin`` and
    ``direction`` in numpy order (z, y, x); unset they are 1, 0 and the
    identity."""

def save(
    data: Union[Volume, npt.ArrayLike],
    path: PathLike,
    *,
    spacing: Optional[Sequence[float]] = ...,
    origin: Optional[Sequence[float]] = ...,
    direction: Optional[Mat3] = ...,
    layout: str = ...,
    compress: str = ...,
    type: Optional[str] = ...,
    window: Optional[str] = ...,
    pyramid: int = ...,
    downsample: str = ...,
    ngff: Optional[str] = ...,
    orient: Optional[str] = ...,
    resample: Optional[str] = ...,
    kernel: Optional[str] = ...,
    no_antialias: bool = ...,
    background: Optional[float] = ...,
    smooth: Optional[str] = ...,
    median: Optional[int] = ...,
    clamp: Optional[str] = ...,
    threshold: Optional[str] = ...,
    mask: Optional[PathLike] = ...,
) -> dict[str, Any]:
    """Write any format vol-convert writes (by the path's extension), with
    vol-convert's options and preprocessing stages, atomically."""

def preprocess(
    data: Union[Volume, npt.ArrayLike],
    *,
    type: Optional[str] = ...,
    orient: Optional[str] = ...,
    resample: Optional[str] = ...,
    kernel: Optional[str] = ...,
    no_antialias: bool = ...,
    background: Optional[float] = ...,
    smooth: Optional[str] = ...,
    median: Optional[int] = ...,
    clamp: Optional[str] = ...,
    threshold: Optional[str] = ...,
    mask: Optional[PathLike] = ...,
) -> Volume:
    """The samples save would write with these preprocessing keywords,
    as a new Volume in memory."""

def generate(
    scene: str,
    dims: Sequence[int],
    *,
    type: Optional[str] = ...,
    spacing: Optional[Sequence[float]] = ...,
    **options: Any,
) -> Volume:
    """vol-gen's scene ``scene`` of ``dims`` (z, y, x) voxels in memory;
    ``options`` are vol-gen's scene options (seed, count, size, value, ...)."""

def index(
    volume: Union[PathLike, Volume, npt.ArrayLike],
    output: Union[None, bool, PathLike] = ...,
    *,
    cell: int = ...,
    bins: int = ...,
) -> Index:
    """Build the min/max index as vol-index does; write it to ``output``
    (True: the volume's path + .vidx)."""

def psnr(
    a: Union[PathLike, Volume, npt.ArrayLike],
    b: Union[PathLike, Volume, npt.ArrayLike],
    *,
    range: Optional[float] = ...,
    alpha: bool = ...,
    luma: bool = ...,
    kind: Optional[str] = ...,
) -> dict[str, Any]:
    """The figures of ``vol-psnr --json`` for images or volumes. A Volume
    is a volume; an (N, M, 3) or (N, M, 4) array is what the other side
    is, else ``kind`` ("image" or "volume") must say."""

def render(
    volume: Union[None, PathLike, Volume, npt.ArrayLike] = ...,
    *,
    progress: Union[None, bool, Callable[[int, Optional[float]], Any]] = ...,
    **options: Any,
) -> Tuple[npt.NDArray[np.float32], dict[str, Any]]:
    """Render with vol-render's options (by the same names; a ``scene``
    file gives the rest): the linear float image (H, W, 3), or (H, W, 4)
    with ``alpha=True``, and the ``--json`` figures. ``eye``, ``look_at``,
    ``up`` and ``light`` are (z, y, x); ``help(volkit.render)`` lists
    every option."""
