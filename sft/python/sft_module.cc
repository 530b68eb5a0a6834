// polyfit._sft: PolySfT for Python (the package `polyfit` wraps it as
// polyfit.polysft). Options are PolySfT's settings (polysft_settings.h),
// the keys `polysft --config` reads, so a Python run and a command-line
// run with the same settings are the same run.
#include <optional>
#include <string>

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "polyfit/python/python_util.h"
#include "sft/scene/scene.h"
#include "sft/solver/polysft.h"
#include "sft/solver/polysft_settings.h"

namespace polyfit::python {
namespace {

using namespace pybind11::literals;

void BindSummaries(py::module_& m) {
  py::class_<SftFrameSummary>(m, "SftFrameSummary")
      .def_readonly("index", &SftFrameSummary::index)
      .def_property_readonly(
          "vertices", [](py::object self) { return ColumnsAsRows(self.cast<SftFrameSummary&>().vertices, self); },
          "(#V, 3), camera frame, the template's vertex order.")
      .def_readonly("time_s", &SftFrameSummary::time_s)
      .def_readonly("cost", &SftFrameSummary::cost)
      .def_readonly("iterations", &SftFrameSummary::iterations)
      .def_readonly("patches", &SftFrameSummary::patches)
      .def_readonly("flow_matches", &SftFrameSummary::flow_matches)
      .def_readonly("flow_start", &SftFrameSummary::flow_start)
      .def_readonly("keypoint_matches", &SftFrameSummary::keypoint_matches)
      .def_readonly("relocalized", &SftFrameSummary::relocalized)
      .def_readonly("e3d", &SftFrameSummary::e3d)
      .def_readonly("normal_error_deg", &SftFrameSummary::normal_error_deg)
      .def_readonly("rmse_mm", &SftFrameSummary::rmse_mm)
      .def_readonly("chamfer_1e4", &SftFrameSummary::chamfer_1e4);
  py::class_<SftIterationSummary>(m, "SftIterationSummary")
      .def_readonly("frame", &SftIterationSummary::frame)
      .def_readonly("window", &SftIterationSummary::window)
      .def_readonly("iteration", &SftIterationSummary::iteration)
      .def_readonly("time_s", &SftIterationSummary::time_s)
      .def_readonly("cost", &SftIterationSummary::cost)
      .def_readonly("e3d", &SftIterationSummary::e3d);
  py::class_<PolySftSummary>(m, "PolySftSummary")
      .def_readonly("termination_type", &PolySftSummary::termination_type)
      .def_readonly("message", &PolySftSummary::message)
      .def_readonly("frames", &PolySftSummary::frames)
      .def_readonly("trace", &PolySftSummary::trace)
      .def_readonly("deformation", &PolySftSummary::deformation)
      .def_readonly("terms", &PolySftSummary::terms)
      .def_readonly("warnings", &PolySftSummary::warnings)
      .def_readonly("silhouette_band_px", &PolySftSummary::silhouette_band_px)
      .def_readonly("pyramid_levels", &PolySftSummary::pyramid_levels)
      .def_readonly("coarse_moves_checked", &PolySftSummary::coarse_moves_checked)
      .def_readonly("coarse_moves_undone", &PolySftSummary::coarse_moves_undone)
      .def_readonly("total_time_s", &PolySftSummary::total_time_s)
      .def_readonly("mean_time_per_frame_s", &PolySftSummary::mean_time_per_frame_s)
      .def_readonly("mean_e3d", &PolySftSummary::mean_e3d)
      .def_readonly("mean_normal_error_deg", &PolySftSummary::mean_normal_error_deg)
      .def_readonly("mean_rmse_mm", &PolySftSummary::mean_rmse_mm)
      .def_readonly("mean_chamfer_1e4", &PolySftSummary::mean_chamfer_1e4)
      .def_readonly("template_e3d", &PolySftSummary::template_e3d)
      .def_readonly("template_rmse_mm", &PolySftSummary::template_rmse_mm)
      .def("is_solution_usable", &PolySftSummary::IsSolutionUsable)
      .def("brief_report", &PolySftSummary::BriefReport)
      .def("__repr__", &PolySftSummary::BriefReport);
}

PolySftSummary RunPolySft(const std::string& scene_dir, const std::optional<std::string>& out_dir,
                          const std::optional<std::string>& config, const py::dict& settings, py::object on_frame) {
  PolySftOptions options;
  if (config) ApplyPolySftSettingsFile(*config, &options);
  ApplyPolySftSettings(PythonToJson(settings), "keyword arguments", &options);
  options.rasterizer.num_threads = options.num_threads;  // as `polysft` does
  DeferredCallback<const SftFrameSummary&> callback(on_frame);
  PolySftSummary summary;
  {
    py::gil_scoped_release release;
    const SftScene scene = LoadScene(scene_dir);
    summary = SolvePolySft(options, scene, callback.Function());
    if (out_dir && !callback.failed()) WriteSftOutputs(*out_dir, scene, options, summary);
  }
  callback.Rethrow();
  return summary;
}

}  // namespace
}  // namespace polyfit::python

PYBIND11_MODULE(_sft, m) {
  namespace pp = polyfit::python;
  m.doc() = "PolySfT (use polyfit.polysft).";
  pybind11::module_::import("polyfit._core");  // TriangleMesh, TerminationType, the errors
  pp::BindSummaries(m);
  m.def("_default_settings",
        [] { return pp::JsonToPython(polyfit::PolySftSettingsToJson(polyfit::PolySftOptions())); });
  using pybind11::arg;
  m.def("_polysft", &pp::RunPolySft, arg("scene_dir"), arg("out_dir"), arg("config"), arg("settings"), arg("on_frame"));
}
