"""PolyFit for Python: patch-wise polynomial jets, PolySfT and OneFit.

Points are NumPy arrays of shape (N, 3), float64; faces (F, 3), int32.
Meshes, models and results view the C++ storage where the layout allows
(no copies). Options are the C++ structs, with the C++ defaults: pass an
options object, or set fields by keyword, nested ones with a double
underscore (or a dot, through **{...}):

    import polyfit
    mesh = polyfit.read_mesh("bunny.obj")
    model, recon, summary = polyfit.fit_mesh(mesh, jet_fit__order=3)
    print(summary.chamfer, summary.total_time_s)

Errors are polyfit.Error (InputError naming the file or key, OutputError,
InvalidArgumentError, also a ValueError), with the C++ messages. Long calls
release the GIL, so threads run them side by side.
"""

import copy as _copy

from . import _core
from ._core import *  # noqa: F401,F403  (the bound classes and functions)

try:
    from . import _sft
except ImportError:  # built without PolySfT's module
    _sft = None
try:
    from . import _drape
except ImportError:  # built without OneFit's module
    _drape = None

__all__ = [name for name in dir(_core) if not name.startswith("_")] + [
    "make_options", "fit_jet_patches", "fit_mesh", "fit_mesh_files", "polysft", "polysft_settings",
    "onefit_simulate", "onefit_drape"]


def make_options(options_type, options=None, **settings):
    """A copy of `options` (default: options_type()) with `settings` applied.

    Keys name fields; nested fields join names with '__' or '.':
    make_options(MeshFitOptions, jet_fit__order=3). An unknown key raises
    TypeError naming it and the fields that exist there.
    """
    result = options_type() if options is None else _copy.copy(options)
    if not isinstance(result, options_type):
        raise TypeError(f"options must be a {options_type.__name__}, got {type(options).__name__}")
    for key, value in settings.items():
        path = key.replace(".", "__").split("__")
        target = result
        for i, name in enumerate(path):
            fields = [f for f in dir(target) if not f.startswith("_") and not callable(getattr(target, f))]
            if name not in fields:
                where = options_type.__name__ + "".join("." + p for p in path[:i])
                raise TypeError(f"{where} has no field '{name}' (setting '{key}'); fields: {', '.join(fields)}")
            if i + 1 < len(path):
                target = getattr(target, name)
            else:
                setattr(target, name, value)
    return result


def fit_jet_patches(points, patch_offsets, weights=None, options=None, **settings):
    """Fits patch p to points[patch_offsets[p]:patch_offsets[p+1]], in parallel.

    points: (N, 3). Returns (list of JetPatch, JetFitSummary).
    """
    return _core.fit_jet_patches(make_options(JetFitOptions, options, **settings), points,  # noqa: F405
                                 list(patch_offsets), weights)


def fit_mesh(mesh, options=None, **settings):
    """PolyFit on a mesh (a TriangleMesh or a file path).

    Returns (PolyFitModel, reconstruction TriangleMesh, MeshFitSummary).
    """
    if isinstance(mesh, str):
        mesh = read_mesh(mesh)  # noqa: F405
    return _core.fit_mesh(make_options(MeshFitOptions, options, **settings), mesh)  # noqa: F405


def fit_mesh_files(inputs, output_dir, options=None, progress=None, **settings):
    """Fits mesh files (paths, directories, globs) into output_dir, resumably.

    Writes <name>.pfm, <name>.recon.ply, <name>.summary.json per input and
    report.csv / report.json. progress(done, total, item) is called after
    each input. Returns a BatchFitSummary; a failing input is reported in
    it (status FAILED, error naming the file) while the others go on.
    """
    if isinstance(inputs, str):
        inputs = [inputs]
    opts = make_options(BatchFitOptions, options, **settings)  # noqa: F405
    opts.output_dir = str(output_dir)
    return _core.fit_mesh_files(opts, [str(i) for i in inputs], progress)


def _need(module, what):
    if module is None:
        raise ImportError(f"polyfit was built without {what}")
    return module


def polysft_settings():
    """PolySfT's settings and their defaults, as `polysft --config` reads them."""
    return _need(_sft, "PolySfT")._default_settings()


def polysft(scene_dir, out_dir=None, config=None, on_frame=None, **settings):
    """Shape from template on a scene directory (../shared/docs/sft-scene-format.md).

    config: a JSON settings file or an earlier metrics.json; settings: keys
    of polysft_settings() (they override config). With out_dir, writes
    meshes/, trace.csv and metrics.json there as `polysft` does.
    on_frame(frame) is called as each frame is final. Returns a
    PolySftSummary: frames (each with vertices (V, 3) and metrics), the
    trace, termination_type, message, times.
    """
    sft = _need(_sft, "PolySfT")
    return sft._polysft(str(scene_dir), None if out_dir is None else str(out_dir),
                        None if config is None else str(config), dict(settings), on_frame)


def onefit_simulate(garment, motion, out_dir, body_dir="", options=None, **settings):
    """The reference drape (`onefit simulate`) of a garment through a BVH clip.

    Writes what `onefit simulate` writes into out_dir and returns a
    DrapeSimulationSummary whose `positions` holds every frame's garment
    vertices (V, 3) and `records` the per-frame metrics.
    """
    drape = _need(_drape, "OneFit")
    opts = make_options(drape.DrapeSimulationOptions, options, **settings)
    opts.garment_path, opts.motion_path, opts.out_dir = str(garment), str(motion), str(out_dir)
    if body_dir:
        opts.body_dir = str(body_dir)
    return drape._simulate(opts)


def onefit_drape(model, garment, motion, out_dir, body_dir="", options=None, **settings):
    """A trained OneFit network (`onefit drape`) on a garment through a clip.

    The same outputs and summary as onefit_simulate; refine_iterations > 0
    polishes each prediction with the reference drape's solver.
    """
    return onefit_simulate(garment, motion, out_dir, body_dir, options, model_path=str(model), **settings)
