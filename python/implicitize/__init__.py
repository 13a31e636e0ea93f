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

import inspect as _inspect
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

#: Every keyword of :func:`fit` that the library defines (``name``, ``kind``, ``choices``,
#: ``value_name``, ``unit``, ``default`` as text or None, ``excludes``, ``help``), the settings
#: ``implicitize fit --config FILE`` reads by the same names.
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


def fit(
    mesh: Any, *, progress: bool = False, memory_limit: _Memory = None, **settings: Any
) -> Model:
    # The keywords and this docstring are made from the library's table (FIT_SETTINGS) below.
    return _fit(_mesh_arg(mesh), progress=bool(progress), memory_limit=memory_limit, **settings)


#: The annotation of a setting's keyword, by its kind (FIT_SETTINGS' ``kind``).
_KIND_TYPES = {
    "count": Optional[int],
    "number": Optional[float],
    "counts3": Optional[Sequence[int]],
    "switch": bool,
    "choice": Optional[str],
    "text": Union[float, str, None],
}


def _fit_signature() -> _inspect.Signature:
    """``fit(mesh, *, <every setting>, progress=False, memory_limit=None)``."""
    keyword = _inspect.Parameter.KEYWORD_ONLY
    settings = [
        _inspect.Parameter(
            s["name"],
            keyword,
            default=False if s["kind"] == "switch" else None,
            annotation=_KIND_TYPES[s["kind"]],
        )
        for s in FIT_SETTINGS
    ]
    return _inspect.Signature(
        [_inspect.Parameter("mesh", _inspect.Parameter.POSITIONAL_OR_KEYWORD, annotation=Any)]
        + settings
        + [
            _inspect.Parameter("progress", keyword, default=False, annotation=bool),
            _inspect.Parameter("memory_limit", keyword, default=None, annotation=_Memory),
        ],
        return_annotation=Model,
    )


def _fit_doc() -> str:
    """The docstring of :func:`fit`: each setting's unit, default and help from the table."""
    lines = []
    for s in FIT_SETTINGS:
        default = "" if s["default"] is None else f"; default {s['default']}"
        lines.append(f"``{s['name']}`` ({s['unit']}{default}): {s['help']}.")
    return (
        "Fits a variational implicit surface to ``mesh``, as ``implicitize fit``.\n\n"
        "The fit's settings are keywords (``FIT_SETTINGS``, the names ``implicitize fit --config"
        " FILE`` reads); one left out or ``None`` takes the library's default:\n\n"
        + "\n".join(lines)
        + "\n\n``progress`` prints one line per iteration on stderr; ``memory_limit`` as in "
        ":func:`voxelize`. A keyword that is no setting raises ``TypeError``, a value out of "
        "its range ``ValueError``; a mesh so open that its inside is a guess over more than a "
        "fifth of the grid raises ``ValueError`` unless ``shell`` or ``solid`` is given, and "
        "a budget below the smallest model names its size. The GIL is released while fitting. "
        "An open mesh and thin walls the fit goes ahead with are reported as ``UserWarning``.\n"
    )


fit.__signature__ = _fit_signature()  # type: ignore[attr-defined]
fit.__doc__ = _fit_doc()


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
