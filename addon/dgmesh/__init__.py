"""dgmesh: discrete differential geometry tools.

One package with two faces. In plain Python, ``import dgmesh`` gives the numpy API (no bpy).
Inside Blender, the add-on's ``register()`` imports ``dgmesh.blender`` (operators, panels,
the bpy <-> numpy bridge).

Long functions take ``progress``: a callable(fraction in [0, 1]) called on the calling thread
(at most every 50 ms); a result that is falsy but not None (False, 0, "") cancels with
:class:`Cancelled` and nothing changes, and an exception it raises comes through as it is. The
native work releases the GIL, and Ctrl+C interrupts it with or without a callback. Calls may run
in several threads at once; :func:`set_num_threads` applies to all of them.
"""

__version__ = "0.1.0"

bl_info = {
    "name": "DG Mesh",
    "author": "dgmesh developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > DG Mesh; Object / Mesh menus > DG Mesh",
    "description": "Discrete differential geometry tools: curvature, denoising, fairing, "
    "crest lines, low-stretch UV unwrap, skeletal deformation",
    "category": "Mesh",
}

from . import shapes  # noqa: E402,F401
from .core import (  # noqa: E402  (bl_info must stay a literal at the top for Blender)
    Cancelled,
    Error,
    MeshError,
    MeshIOError,
    SolverError,
    Curvature,
    Topology,
    curvature,
    num_threads,
    read_mesh,
    set_num_threads,
    topology,
    validate,
    write_mesh,
)
from .denoising import (DenoiseMethod, DenoiseOptions, DenoiseResult, NoiseEstimate, NoiseOptions,  # noqa: E402
                        SimilarityOptions, denoise, estimate_noise, similarity)
from .crest import (  # noqa: E402
    CrestKind,
    CrestLines,
    CrestOptions,
    CurvatureDerivatives,
    DecimateOptions,
    DecimateResult,
    DerivativeOptions,
    FeatureOptions,
    SegmentOptions,
    SegmentResult,
    crest_lines,
    curvature_derivatives,
    decimate,
    decimate_feature_defaults,
    segment,
    segment_feature_defaults,
)
from .fairing import (FairBoundary, FairMethod, FairOptions, FairResult, FairScheme, FairStall, FairStartWeights, RegularizeOptions, fair,  # noqa: E402
                   regularize, willmore_energy)
from .unwrapping import (AutoUnwrapOptions, AutoUnwrapResult, UnwrapChartError, UnwrapChartsResult,  # noqa: E402
                         UnwrapOptions, UnwrapResult, UnwrapStep, auto_unwrap,
                         UvBoundary, UvMetrics, UvSolver, UvWeights, unwrap, unwrap_charts, uv_metrics, uv_stretch)
from .skeletal import (  # noqa: E402
    SkeletalDeformOptions,
    SkeletalMesh,
    SkeletalMethod,
    SkeletalRig,
    SkeletalRigOptions,
    SkeletonOptions,
    delaunay_2d,
    delaunay_3d,
    skeletal_mesh,
    union_of_balls_distance,
)
from .multires import Multires, MultiresOptions, MultiresTimings  # noqa: E402
from .remeshing import (RemeshBoundary, RemeshMode, RemeshOptions, RemeshRelaxMetric, RemeshResult,  # noqa: E402
                     point_mesh_distance, remesh, remesh_full)

# The public numpy API (``from dgmesh import *``); register/unregister are Blender's entry points.
__all__ = [
    "Cancelled", "Error", "MeshError", "MeshIOError", "SolverError",
    "Curvature", "Topology", "curvature", "num_threads", "read_mesh", "set_num_threads", "topology", "validate",
    "write_mesh",
    "DenoiseMethod", "DenoiseOptions", "DenoiseResult", "NoiseEstimate", "NoiseOptions", "SimilarityOptions", "denoise",
    "estimate_noise", "similarity",
    "CrestKind", "CrestLines", "CrestOptions", "CurvatureDerivatives", "DecimateOptions", "DecimateResult",
    "DerivativeOptions", "FeatureOptions", "SegmentOptions", "SegmentResult", "crest_lines", "curvature_derivatives",
    "decimate", "decimate_feature_defaults", "segment", "segment_feature_defaults",
    "FairBoundary", "FairMethod", "FairOptions", "FairResult", "FairScheme", "FairStall", "FairStartWeights", "RegularizeOptions", "fair", "regularize",
    "willmore_energy",
    "UnwrapChartError", "UnwrapChartsResult", "UnwrapOptions", "UnwrapResult", "UnwrapStep", "UvBoundary",
    "UvMetrics", "UvSolver", "UvWeights", "unwrap", "unwrap_charts", "uv_metrics", "uv_stretch",
    "AutoUnwrapOptions", "AutoUnwrapResult", "auto_unwrap",
    "SkeletalDeformOptions", "SkeletalMesh", "SkeletalMethod", "SkeletalRig", "SkeletalRigOptions", "SkeletonOptions",
    "delaunay_2d", "delaunay_3d", "skeletal_mesh", "union_of_balls_distance",
    "Multires", "MultiresOptions", "MultiresTimings",
    "RemeshBoundary", "RemeshMode", "RemeshOptions", "RemeshRelaxMetric", "RemeshResult", "point_mesh_distance",
    "remesh", "remesh_full",
    "shapes",
]


def register():
    from . import blender

    blender.register()


def unregister():
    from . import blender

    blender.unregister()
