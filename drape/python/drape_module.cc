// polyfit._drape: OneFit's reference drape and network for Python (the
// package `polyfit` wraps them as polyfit.onefit_simulate and
// polyfit.onefit_drape). Options and summaries are the C++ structs of
// drape_simulation.h and drape_solver.h, with their defaults.
#include <string>
#include <vector>

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "drape/simulate/drape_simulation.h"
#include "polyfit/python/python_util.h"

namespace polyfit::python {
namespace {

using namespace pybind11::literals;

void BindPhysics(py::module_& m) {
  py::class_<DrapingWeights> weights(m, "DrapingWeights");
  weights.def(py::init<>())
      .def_readwrite("boundary", &DrapingWeights::boundary)
      .def_readwrite("inextensibility", &DrapingWeights::inextensibility)
      .def_readwrite("gravity", &DrapingWeights::gravity)
      .def_readwrite("collision", &DrapingWeights::collision)
      .def_readwrite("inertia", &DrapingWeights::inertia)
      .def_readwrite("collision_margin", &DrapingWeights::collision_margin);
  AddCopy(weights);
  py::class_<KextOptions> k_ext(m, "KextOptions");
  k_ext.def(py::init<>())
      .def_readwrite("max_depth", &KextOptions::max_depth)
      .def_readwrite("max_epoch", &KextOptions::max_epoch);
  AddCopy(k_ext);
  py::class_<ClothMaterial> material(m, "ClothMaterial");
  material.def(py::init<>())
      .def_readwrite("area_density", &ClothMaterial::area_density)
      .def_readwrite("mu", &ClothMaterial::mu)
      .def_readwrite("lambda_", &ClothMaterial::lambda)
      .def_readwrite("bending", &ClothMaterial::bending);
  AddCopy(material);
  py::class_<DrapePhysicsOptions> physics(m, "DrapePhysicsOptions");
  physics.def(py::init<>())
      .def_readwrite("weights", &DrapePhysicsOptions::weights)
      .def_readwrite("k_ext", &DrapePhysicsOptions::k_ext)
      .def_readwrite("material", &DrapePhysicsOptions::material)
      .def_readwrite("collision_stiffness", &DrapePhysicsOptions::collision_stiffness)
      .def_readwrite("boundary_base", &DrapePhysicsOptions::boundary_base)
      .def_readwrite("stretch_base", &DrapePhysicsOptions::stretch_base)
      .def_readwrite("collision_band", &DrapePhysicsOptions::collision_band)
      .def_readwrite("gravity", &DrapePhysicsOptions::gravity)
      .def_readwrite("fps", &DrapePhysicsOptions::fps);
  AddCopy(physics);
}

void BindSolverOptions(py::module_& m) {
  py::class_<GarmentPatchOptions> patching(m, "GarmentPatchOptions");
  patching.def(py::init<>())
      .def_readwrite("jet_order", &GarmentPatchOptions::jet_order)
      .def_readwrite("patch_area", &GarmentPatchOptions::patch_area)
      .def_readwrite("face_subdivisions", &GarmentPatchOptions::face_subdivisions)
      .def_readwrite("max_fit_error", &GarmentPatchOptions::max_fit_error)
      .def_readwrite("max_splits", &GarmentPatchOptions::max_splits)
      .def_readwrite("align_frames", &GarmentPatchOptions::align_frames)
      .def_readwrite("curved_faces", &GarmentPatchOptions::curved_faces)
      .def_readwrite("seed", &GarmentPatchOptions::seed);
  AddCopy(patching);
  py::class_<DrapeSlideOptions> slide(m, "DrapeSlideOptions");
  slide.def(py::init<>())
      .def_readwrite("enabled", &DrapeSlideOptions::enabled)
      .def_readwrite("agreement", &DrapeSlideOptions::agreement)
      .def_readwrite("warp_order", &DrapeSlideOptions::warp_order);
  AddCopy(slide);
  py::enum_<DrapeLinearSolver>(m, "DrapeLinearSolver")
      .value("AUTO", DrapeLinearSolver::kAuto)
      .value("SPARSE_CHOLESKY", DrapeLinearSolver::kSparseCholesky)
      .value("CONJUGATE_GRADIENTS", DrapeLinearSolver::kConjugateGradients);
  // Ceres' own Solver::Options stay C++-only; these are the drape's.
  py::class_<DrapeSolveOptions> solve(m, "DrapeSolveOptions");
  solve.def(py::init<>())
      .def_readwrite("max_iterations", &DrapeSolveOptions::max_iterations)
      .def_readwrite("max_refine_iterations", &DrapeSolveOptions::max_refine_iterations)
      .def_readwrite("max_passes", &DrapeSolveOptions::max_passes)
      .def_readwrite("parameter_prior", &DrapeSolveOptions::parameter_prior)
      .def_readwrite("initial_trust_region_radius", &DrapeSolveOptions::initial_trust_region_radius)
      .def_readwrite("linear_solver", &DrapeSolveOptions::linear_solver)
      .def_readwrite("conjugate_gradients_min_vertices", &DrapeSolveOptions::conjugate_gradients_min_vertices)
      .def_readwrite("conjugate_gradients_tolerance", &DrapeSolveOptions::conjugate_gradients_tolerance)
      .def_readwrite("max_conjugate_gradients_iterations", &DrapeSolveOptions::max_conjugate_gradients_iterations);
  AddCopy(solve);
  py::class_<DrapeSolverOptions> solver(m, "DrapeSolverOptions");
  solver.def(py::init<>())
      .def_readwrite("physics", &DrapeSolverOptions::physics)
      .def_readwrite("patching", &DrapeSolverOptions::patching)
      .def_readwrite("slide", &DrapeSolverOptions::slide)
      .def_readwrite("solve", &DrapeSolverOptions::solve)
      .def_readwrite("num_threads", &DrapeSolverOptions::num_threads)
      .def("validate", &DrapeSolverOptions::Validate);
  AddCopy(solver);
  py::enum_<SkinSmoothing>(m, "SkinSmoothing")
      .value("SURFACE", SkinSmoothing::kSurface)
      .value("EDGE_STEPS", SkinSmoothing::kEdgeSteps);
  py::class_<SkinTransferOptions> skin(m, "SkinTransferOptions");
  skin.def(py::init<>())
      .def_readwrite("smoothing", &SkinTransferOptions::smoothing)
      .def_readwrite("smoothing_length", &SkinTransferOptions::smoothing_length)
      .def_readwrite("smoothing_iterations", &SkinTransferOptions::smoothing_iterations)
      .def_readwrite("anchor_distance", &SkinTransferOptions::anchor_distance)
      .def_readwrite("loose_distance", &SkinTransferOptions::loose_distance)
      .def_readwrite("resample_edge_length", &SkinTransferOptions::resample_edge_length);
  AddCopy(skin);
  py::class_<BodyShape> shape(m, "BodyShape", "MakeHuman's macro shape, each in [0, 1] (0.5 neutral).");
  shape.def(py::init<>())
      .def_readwrite("gender", &BodyShape::gender)
      .def_readwrite("muscle", &BodyShape::muscle)
      .def_readwrite("weight", &BodyShape::weight)
      .def_readwrite("height", &BodyShape::height)
      .def_readwrite("proportions", &BodyShape::proportions)
      .def_static("parse", &BodyShape::Parse, "text"_a, "'gender=0.2,weight=0.9'")
      .def("__repr__", &BodyShape::ToString);
  AddCopy(shape);
}

void BindSimulationOptions(py::module_& m) {
  py::class_<DrapeSimulationOptions> options(m, "DrapeSimulationOptions");
  options.def(py::init<>())
      .def_readwrite("body_dir", &DrapeSimulationOptions::body_dir)
      .def_readwrite("shape", &DrapeSimulationOptions::shape)
      .def_readwrite("garment_path", &DrapeSimulationOptions::garment_path)
      .def_readwrite("motion_path", &DrapeSimulationOptions::motion_path)
      .def_readwrite("bvh_units_to_metres", &DrapeSimulationOptions::bvh_units_to_metres)
      .def_readwrite("out_dir", &DrapeSimulationOptions::out_dir)
      .def_readwrite("model_path", &DrapeSimulationOptions::model_path)
      .def_readwrite("refine_iterations", &DrapeSimulationOptions::refine_iterations)
      .def_readwrite("first_frame", &DrapeSimulationOptions::first_frame)
      .def_readwrite("num_frames", &DrapeSimulationOptions::num_frames)
      .def_readwrite("lead_in_frames", &DrapeSimulationOptions::lead_in_frames)
      .def_readwrite("render_every", &DrapeSimulationOptions::render_every)
      .def_readwrite("render_height", &DrapeSimulationOptions::render_height)
      .def_readwrite("write_meshes", &DrapeSimulationOptions::write_meshes)
      .def_readwrite("project_offset", &DrapeSimulationOptions::project_offset)
      .def_readwrite("strain_limit_passes", &DrapeSimulationOptions::strain_limit_passes)
      .def_readwrite("relax_passes", &DrapeSimulationOptions::relax_passes)
      .def_readwrite("solver", &DrapeSimulationOptions::solver)
      .def_readwrite("skin", &DrapeSimulationOptions::skin)
      .def("validate", &DrapeSimulationOptions::Validate);
  AddCopy(options);
}

// Per-frame and whole-run summaries, and the run itself.
void BindSimulationRun(py::module_& m) {
  py::class_<DrapeFrameSummary>(m, "DrapeFrameSummary")
      .def_readonly("frame", &DrapeFrameSummary::frame)
      .def_readonly("termination_type", &DrapeFrameSummary::termination_type)
      .def_readonly("time_s", &DrapeFrameSummary::time_s)
      .def_readonly("solve_time_s", &DrapeFrameSummary::solve_time_s)
      .def_readonly("iterations", &DrapeFrameSummary::iterations)
      .def_readonly("passes", &DrapeFrameSummary::passes)
      .def_readonly("inside_percent", &DrapeFrameSummary::inside_percent)
      .def_readonly("inside_unprojected_percent", &DrapeFrameSummary::inside_unprojected_percent)
      .def_readonly("inside_nearest_percent", &DrapeFrameSummary::inside_nearest_percent)
      .def_readonly("inside_area_percent", &DrapeFrameSummary::inside_area_percent)
      .def_readonly("min_distance", &DrapeFrameSummary::min_distance)
      .def_readonly("edge_strain_percent", &DrapeFrameSummary::edge_strain_percent)
      .def_readonly("area_change_percent", &DrapeFrameSummary::area_change_percent)
      .def_readonly("max_edge_strain_percent", &DrapeFrameSummary::max_edge_strain_percent)
      .def_readonly("stretch_energy", &DrapeFrameSummary::stretch_energy)
      .def_readonly("bending_energy", &DrapeFrameSummary::bending_energy)
      .def_readonly("cost", &DrapeFrameSummary::cost)
      .def_readonly("finite", &DrapeFrameSummary::finite);

  py::class_<DrapeSimulationSummary>(m, "DrapeSimulationSummary")
      .def_readonly("termination_type", &DrapeSimulationSummary::termination_type)
      .def_readonly("message", &DrapeSimulationSummary::message)
      .def_readonly("garment_vertices", &DrapeSimulationSummary::garment_vertices)
      .def_readonly("garment_faces", &DrapeSimulationSummary::garment_faces)
      .def_readonly("patches", &DrapeSimulationSummary::patches)
      .def_readonly("fit_error_mean", &DrapeSimulationSummary::fit_error_mean)
      .def_readonly("fit_error_max", &DrapeSimulationSummary::fit_error_max)
      .def_readonly("frames", &DrapeSimulationSummary::frames)
      .def_readonly("records", &DrapeSimulationSummary::records)
      .def_property_readonly(
          "positions",
          [](py::object self) {
            py::list frames;
            for (Eigen::Matrix3Xd& x : self.cast<DrapeSimulationSummary&>().positions) {
              frames.append(ColumnsAsRows(x, self));
            }
            return frames;
          },
          "Per record, the garment as written, (#V, 3) each (views).")
      .def_readonly("mean_time_s", &DrapeSimulationSummary::mean_time_s)
      .def_readonly("max_time_s", &DrapeSimulationSummary::max_time_s)
      .def_readonly("mean_inside_percent", &DrapeSimulationSummary::mean_inside_percent)
      .def_readonly("max_inside_percent", &DrapeSimulationSummary::max_inside_percent)
      .def_readonly("mean_edge_strain_percent", &DrapeSimulationSummary::mean_edge_strain_percent)
      .def_readonly("max_edge_strain_percent", &DrapeSimulationSummary::max_edge_strain_percent)
      .def_readonly("mean_area_change_percent", &DrapeSimulationSummary::mean_area_change_percent)
      .def_readonly("all_finite", &DrapeSimulationSummary::all_finite)
      .def_readonly("total_time_s", &DrapeSimulationSummary::total_time_s)
      .def_readonly("warnings", &DrapeSimulationSummary::warnings)
      .def("brief_report", &DrapeSimulationSummary::BriefReport)
      .def("__repr__", &DrapeSimulationSummary::BriefReport);

  m.def(
      "_simulate",
      [](DrapeSimulationOptions options) {
        options.keep_positions = true;  // Python gets every frame's vertices
        return RunDrapeSimulation(options);
      },
      "options"_a, py::call_guard<py::gil_scoped_release>());
}

}  // namespace
}  // namespace polyfit::python

PYBIND11_MODULE(_drape, m) {
  namespace pp = polyfit::python;
  m.doc() = "OneFit's drape (use polyfit.onefit_simulate and polyfit.onefit_drape).";
  pybind11::module_::import("polyfit._core");  // TerminationType, the errors
  pp::BindPhysics(m);
  pp::BindSolverOptions(m);
  pp::BindSimulationOptions(m);
  pp::BindSimulationRun(m);
}
