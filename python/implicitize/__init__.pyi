"""Type stubs of implicitize: see the docstrings in __init__.py and the extension module."""

import os
from typing import Any, Literal, Optional, Sequence, Tuple, Union, overload

import numpy as np
import numpy.typing as npt

_Path = Union[str, "os.PathLike[str]"]
_Memory = Union[int, str, None]

DEFAULTS: dict[str, Any]
"""The library's defaults of the keywords left at None."""
FIT_SETTINGS: list[dict[str, Any]]
"""Every setting of fit (name, unit, default as text or None, help), the library's table."""
_Points = npt.ArrayLike
_Vec3 = Tuple[float, float, float]

class Volume:
    """A volume on a voxel grid: float32 ``values[i, j, k]`` (C order), voxel (i, j, k)
    centred at ``origin + voxel_size * (i, j, k)``."""

    values: npt.NDArray[np.float32]
    origin: _Vec3
    voxel_size: float
    def __init__(
        self, values: npt.NDArray[np.float32], origin: _Vec3, voxel_size: float
    ) -> None: ...
    @property
    def dims(self) -> Tuple[int, int, int]:
        """The grid's size (nx, ny, nz)."""

class Model:
    """A variational implicit surface: positive inside, negative outside, mesh units."""

    def __call__(self, points: _Points) -> npt.NDArray[np.float64]:
        """Values at (N, 3) points, float64; the same numbers as ``implicitize eval``."""
    def gradient(self, points: _Points) -> npt.NDArray[np.float64]:
        """Gradients at (N, 3) points, (N, 3) float64, pointing inside."""
    @property
    def dim(self) -> int:
        """The number of coordinates the model reads: 3 (2 for a curve, 4 for a morph)."""
    @property
    def bounds(self) -> Tuple[_Vec3, _Vec3]:
        """The shape's bounds: ((xmin, ymin, zmin), (xmax, ymax, zmax))."""
    @property
    def report(self) -> Optional[dict[str, Any]]:
        """The fit report (the CLI's report.json), or None."""
    def save(self, path: _Path) -> None:
        """Writes the model file, as ``implicitize fit -o``."""
    def to_mesh(
        self,
        resolution: Optional[int] = None,
        dense: bool = False,
        memory_limit: _Memory = None,
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.uint32]]:
        """The zero set polygonized: (vertices (N, 3), faces (M, 3)), as ``implicitize mesh``;
        ``resolution`` None is DEFAULTS["resolution"]."""
    def render(
        self,
        size: Optional[Tuple[int, int]] = None,
        view: Optional[Tuple[float, float]] = None,
        color: str = "plain",
    ) -> npt.NDArray[np.uint8]:
        """A picture (height, width, 3) of the surface on white, as ``implicitize render``;
        ``size`` and ``view`` None are its defaults."""

def voxelize(
    mesh: Any,
    resolution: Optional[int] = None,
    dims: Optional[Sequence[int]] = None,
    *,
    memory_limit: _Memory = None,
) -> Volume:
    """Densities in [0, 1], 1 inside, as ``implicitize voxelize``; None is DEFAULTS' value,
    MemoryError beyond ``memory_limit``."""

def signed_distance(
    mesh: Any,
    resolution: Optional[int] = None,
    dims: Optional[Sequence[int]] = None,
    *,
    memory_limit: _Memory = None,
) -> Volume:
    """The signed distance in voxels, inside positive, as ``implicitize sdf``; None is
    DEFAULTS' value, MemoryError beyond ``memory_limit``."""

@overload
def distance(
    mesh: Any,
    points: _Points,
    signed: bool = True,
    closest: Literal[False] = False,
    *,
    memory_limit: _Memory = None,
) -> npt.NDArray[np.float64]:
    """Exact distances to the mesh, mesh units, signed (inside positive) unless ``signed`` is
    false, as ``implicitize distance``; MemoryError beyond ``memory_limit``."""

@overload
def distance(
    mesh: Any,
    points: _Points,
    signed: bool = True,
    *,
    closest: Literal[True],
    memory_limit: _Memory = None,
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The distances and each point's closest point of the surface (N x 3)."""

def sample(
    mesh: Any,
    n: int,
    near_surface: Optional[Sequence[float]] = None,
    uniform: Optional[float] = None,
    seed: Optional[int] = None,
    *,
    memory_limit: _Memory = None,
) -> dict[str, npt.NDArray[Any]]:
    """``points``, ``sdf`` (inside positive) and DeepSDF's ``pos`` and ``neg``, as
    ``implicitize sample``; None is DEFAULTS' value, MemoryError beyond ``memory_limit``."""

# the fit's settings: made by tests/settings.rs from the library's table (IMPLICITIZE_BLESS=1)
def fit(
    mesh: Any,
    *,
    resolution: Optional[int] = None,
    dims: Optional[Sequence[int]] = None,
    target_error: Optional[float] = None,
    seed: Optional[int] = None,
    max_constraints: Optional[int] = None,
    method: Optional[str] = None,
    max_iterations: Optional[int] = None,
    subvoxel: bool = False,
    full_resolution: bool = False,
    levels: Optional[int] = None,
    shell: Union[float, str, None] = None,
    solid: bool = False,
    max_bytes: Optional[int] = None,
    progress: bool = False,
    memory_limit: _Memory = None,
) -> Model:
    """Fits a variational implicit surface to ``mesh``, as ``implicitize fit``; None is the
    library's default (FIT_SETTINGS), MemoryError beyond ``memory_limit``."""
# end of the fit's settings

def load(path: _Path) -> Model:
    """Reads a model file."""

def union(a: Model, b: Model, blend: float = 0.0) -> Model:
    """Inside either model, sharp or with a fillet of about ``blend`` mesh units."""

def intersection(a: Model, b: Model, blend: float = 0.0) -> Model:
    """Inside both models."""

def difference(a: Model, b: Model, blend: float = 0.0) -> Model:
    """Inside ``a`` and outside ``b``."""
