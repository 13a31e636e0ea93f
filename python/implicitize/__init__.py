"""implicitize: turn polygon meshes into compact, smooth variational implicit surfaces.

A Python front end to the Rust library and command-line tool of the same name (Yngve and
Turk, "Robust creation of implicit surfaces from polygonal meshes", IEEE TVCG 2002).

Meshes are given as a path (OBJ, PLY, STL or OFF), as ``(vertices, faces)`` arrays, or as any
object with ``.vertices`` and ``.faces`` (a ``trimesh.Trimesh``). Values are positive inside
and negative outside, positions in the mesh's own units, errors in voxels.

Every keyword left at ``None`` takes the library's default (``DEFAULTS`` lists them). Work whose
memory estimate exceeds ``memory_limit`` (bytes, or a size such as ``"2G"``; by default what the
machine has available) raises ``MemoryError`` before it allocates, naming the largest
``resolution`` that fits.

>>> import implicitize, numpy as np
>>> model = implicitize.fit("bunny.obj", resolution=100)        # doctest: +SKIP
>>> model(np.zeros((1, 3)))                                     # doctest: +SKIP
"""

from __future__ import annotations

import os as _os
from dataclasses import dataclass as _dataclass
from typing import Any, Optional, Sequence, Tuple, Union

import numpy as _np

from ._implicitize import Model
from ._implicitize import csg as _csg
from ._implicitize import defaults as _defaults
from ._implicitize import distance as _distance
from ._implicitize import fit as _fit
from ._implicitize import fit_settings as _fit_settings
from ._implicitize import load as _load
from ._implicitize import sample as _sample
from ._implicitize import volume as _volume

__all__ = [
    "DEFAULTS",
    "FIT_SETTINGS",
    "Model",
    "Volume",
    "voxelize",
    "signed_distance",
    "distance",
    "sample",
    "fit",
    "load",
    "union",
    "intersection",
    "difference",
]

#: The library's defaults of the keywords left at ``None`` (``resolution``, ``target_error``,
#: ``seed``, ``max_iterations``, ``max_constraints``, ``naive_max_constraints``, ``method``,
#: ``near_surface``, ``uniform``).
DEFAULTS = dict(_defaults())

#: Every keyword of :func:`fit` that the library defines (``name``, ``unit``, ``default`` as
#: text or None, ``help``), the settings ``implicitize fit --config FILE`` reads by the same names.
FIT_SETTINGS = [dict(setting) for setting in _fit_settings()]

_Memory = Union[int, str, None]


def __dir__() -> list:
    return sorted(__all__)


@_dataclass(frozen=True)
class Volume:
    """A volume on a voxel grid, as the CLI writes it (``.npy`` and its ``.json``).

    ``values`` is float32, indexed ``[i, j, k]`` in C order; voxel ``(i, j, k)`` is centred at
    ``origin + voxel_size * (i, j, k)``, in mesh units.
    """

    values: _np.ndarray
    origin: Tuple[float, float, float]
    voxel_size: float

    @property
    def dims(self) -> Tuple[int, int, int]:
        """The grid's size ``(nx, ny, nz)``."""
        nx, ny, nz = self.values.shape
        return (nx, ny, nz)


def _mesh_arg(mesh: Any) -> Any:
    """A path as a string, or ``(vertices, faces)`` as float64 and int64 arrays."""
    if isinstance(mesh, (str, _os.PathLike)):
        return _os.fspath(mesh)
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        vertices, faces = mesh.vertices, mesh.faces
    elif isinstance(mesh, (tuple, list)) and len(mesh) == 2:
        vertices, faces = mesh
    else:
        raise TypeError(
            "mesh: expected a path, (vertices, faces) arrays or an object with "
            f".vertices and .faces, not {type(mesh).__name__}"
        )
    try:
        vertices = _np.ascontiguousarray(vertices, dtype=_np.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(f"vertices: not an array of numbers: {e}") from None
    faces = _np.asarray(faces)
    if faces.size and not _np.issubdtype(faces.dtype, _np.integer):
        raise ValueError(f"faces: expected integer vertex indices, got {faces.dtype}")
    return vertices, _np.ascontiguousarray(faces, dtype=_np.int64)


def _grid_args(resolution: Optional[int], dims: Optional[Sequence[int]]) -> Any:
    return resolution, (None if dims is None else [int(d) for d in dims])


def _documented(function: Any) -> Any:
    """Fills the library's defaults into ``function``'s docstring."""
    function.__doc__ = function.__doc__.format(**DEFAULTS)
    return function


@_documented
def voxelize(
    mesh: Any,
    resolution: Optional[int] = None,
    dims: Optional[Sequence[int]] = None,
    *,
    memory_limit: _Memory = None,
) -> Volume:
    """Densities in [0, 1], 1 inside (paper 4.1), as ``implicitize voxelize``.

    ``resolution`` voxels along the mesh's longest axis, margins included (default
    {resolution}), or an exact ``dims=(nx, ny, nz)``; ``memory_limit`` in bytes or as ``"2G"``
    (default: the available memory).
    """
    values, origin, voxel_size = _volume(
        _mesh_arg(mesh), "density", *_grid_args(resolution, dims), memory_limit=memory_limit
    )
    return Volume(values, origin, voxel_size)


@_documented
def signed_distance(
    mesh: Any,
    resolution: Optional[int] = None,
    dims: Optional[Sequence[int]] = None,
    *,
    exact: bool = False,
    band: Optional[float] = None,
    memory_limit: _Memory = None,
) -> Volume:
    """The signed distance at the voxel centres, inside positive, as ``implicitize sdf``.

    By default the Euclidean distance of the voxelization, in voxels (paper 4.2). With
    ``exact=True``, as ``implicitize sdf --exact``: the exact distance from each voxel centre to
    the mesh's triangles, in mesh units (computed in float64, stored as float32), signed as the
    voxelization decides inside; with ``band=K`` (voxels, only with ``exact``) only voxels
    within K voxels of the surface are measured and every value is clamped to plus or minus
    K voxels (``K * voxel_size``). ``resolution`` (default {resolution}), ``dims`` and
    ``memory_limit`` as in :func:`voxelize`. The GIL is released while it works.
    """
    values, origin, voxel_size = _volume(
        _mesh_arg(mesh),
        "exact_signed_distance" if exact else "signed_distance",
        *_grid_args(resolution, dims),
        memory_limit=memory_limit,
        band=None if band is None else float(band),
    )
    return Volume(values, origin, voxel_size)


def distance(
    mesh: Any,
    points: Any,
    signed: bool = True,
    closest: bool = False,
    *,
    memory_limit: _Memory = None,
) -> Union[_np.ndarray, Tuple[_np.ndarray, _np.ndarray]]:
    """Exact distances from ``points`` (N x 3) to the mesh's triangles, as ``implicitize distance``.

    float64, mesh units; positive inside as ``voxelize`` decides it (rays along the three axes,
    the generalized winding number where they disagree), unless ``signed`` is false. With ``closest``, a tuple: the distances and each point's closest point
    of the surface (N x 3). ``memory_limit`` as in :func:`voxelize`. The GIL is released while
    measuring.
    """
    values, nearest = _distance(
        _mesh_arg(mesh), points, bool(signed), bool(closest), memory_limit=memory_limit
    )
    return (values, nearest) if closest else values


@_documented
def sample(
    mesh: Any,
    n: int,
    near_surface: Optional[Sequence[float]] = None,
    uniform: Optional[float] = None,
    seed: Optional[int] = None,
    *,
    memory_limit: _Memory = None,
) -> dict:
    """``n`` samples of the mesh's exact signed distance, as ``implicitize sample``.

    Surface points (by area) moved by Gaussian noise of each standard deviation in
    ``near_surface`` (fractions of the bounding box's diagonal, default {near_surface}), and a
    fraction ``uniform`` (default {uniform}) uniform in the box padded by 10% of its size;
    ``seed`` (default {seed}) decides them all. A dict of numpy arrays, as the ``.npz`` holds
    them: ``points`` (n x 3 float64), ``sdf`` (n float64, mesh units, positive inside), and
    DeepSDF's ``pos`` and ``neg`` (rows x, y, z, sdf as float32, negative inside; ``pos``
    outside). ``memory_limit`` as in :func:`voxelize`. The GIL is released while sampling.
    """
    points, sdf, pos, neg = _sample(
        _mesh_arg(mesh),
        int(n),
        near_surface=None if near_surface is None else [float(s) for s in near_surface],
        uniform=None if uniform is None else float(uniform),
        seed=None if seed is None else int(seed),
        memory_limit=memory_limit,
    )
    return {"points": points, "sdf": sdf, "pos": pos, "neg": neg}


@_documented
def fit(
    mesh: Any,
    resolution: Optional[int] = None,
    target_error: Optional[float] = None,
    seed: Optional[int] = None,
    max_constraints: Optional[int] = None,
    method: Optional[str] = None,
    progress: bool = False,
    *,
    dims: Optional[Sequence[int]] = None,
    max_iterations: Optional[int] = None,
    subvoxel: bool = False,
    full_resolution: bool = False,
    levels: Optional[int] = None,
    shell: Union[float, str, None] = None,
    solid: bool = False,
    max_bytes: Optional[int] = None,
    memory_limit: _Memory = None,
) -> Model:
    """Fits a variational implicit surface to ``mesh``, as ``implicitize fit``.

    ``resolution`` voxels along the longest axis (default {resolution}; or ``dims=``); stops once
    the max error E is at most ``target_error`` voxels (default {target_error}); ``seed``
    (default {seed}) seeds every random choice (same seed, same model file); ``method`` is
    ``"iterative"`` (paper 5, the default) or ``"naive"`` (paper 3.2); at most
    ``max_constraints`` constraints (default {max_constraints}, {naive_max_constraints} for the
    naive method) and ``max_iterations`` iterations (default {max_iterations}); on grids of
    {levels_min_axis} voxels or more, and for every ``shell``, at most ``levels`` detail levels
    (default {levels}; 0 fits one function as the paper does; above {levels_max_goal_axis}
    voxels the goal is voxelized at half the resolution and the levels reach the grid through
    points on the mesh); ``progress`` prints one line per
    iteration on stderr;
    ``shell`` fits the surface thickened to that thickness in all (a number of voxels, or a
    string such as ``"0.01u"`` in mesh units), for open shells and walls too thin for the grid;
    a mesh so open that its inside is a guess over more than a fifth of the grid (winding
    numbers near one half) raises ``ValueError`` unless ``shell`` is given or ``solid`` is true,
    which fits the guessed solid anyway;
    ``max_bytes`` returns the most accurate model whose binary file (``Model.save``) has at most
    that many bytes, choosing the resolution, target and detail levels (the report's
    ``byte_budget`` lists the fits tried), and raises ``ValueError`` naming the smallest size
    when no model fits;
    ``memory_limit`` as in :func:`voxelize`. The GIL is released while fitting. An open mesh
    and thin walls the fit goes ahead with are reported as ``UserWarning``.
    """
    return _fit(
        _mesh_arg(mesh),
        *_grid_args(resolution, dims),
        target_error=None if target_error is None else float(target_error),
        seed=None if seed is None else int(seed),
        max_constraints=max_constraints,
        method=method,
        max_iterations=max_iterations,
        subvoxel=subvoxel,
        full_resolution=full_resolution,
        levels=None if levels is None else int(levels),
        shell=shell,
        solid=bool(solid),
        max_bytes=None if max_bytes is None else int(max_bytes),
        progress=progress,
        memory_limit=memory_limit,
    )


def load(path: Union[str, "_os.PathLike[str]"]) -> Model:
    """Reads a model file written by the CLI (``fit``, ``solve``, ``csg``) or ``Model.save``."""
    return _load(_os.fspath(path))


def union(a: Model, b: Model, blend: float = 0.0) -> Model:
    """Inside either model; a fillet of about ``blend`` mesh units where they meet (0: sharp)."""
    return _csg("union", a, b, float(blend))


def intersection(a: Model, b: Model, blend: float = 0.0) -> Model:
    """Inside both models; ``blend`` as in :func:`union`."""
    return _csg("intersection", a, b, float(blend))


def difference(a: Model, b: Model, blend: float = 0.0) -> Model:
    """Inside ``a`` and outside ``b``; ``blend`` as in :func:`union`."""
    return _csg("difference", a, b, float(blend))


def _model_from_state(json: bytes, report: Optional[str]) -> Model:
    """Rebuilds a pickled model (see ``Model.__reduce__``)."""
    return Model._from_state(json, report)
