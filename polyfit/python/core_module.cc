// polyfit._core: the PolyFit library for Python (the package `polyfit`
// re-exports it; polyfit/python/polyfit/__init__.py). Meshes, n-jets,
// batched jet fitting, models and their files, FitMesh and the batch fit
// over files. Options and summaries are the C++ structs (defaults from
// their constructors); points are N by 3 NumPy arrays viewing PolyFit's
// 3 by N storage (numpy_eigen.h). Every long call releases the GIL.
#include <Python.h>

#include <cstdint>
#include <exception>
#include <optional>
#include <string>
#include <vector>

#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include "polyfit/jet/jet_basis.h"
#include "polyfit/jet/jet_surface.h"
#include "polyfit/mesh/mesh_io.h"
#include "polyfit/mesh/ordered_io.h"
#include "polyfit/mesh/primitives.h"
#include "polyfit/mesh/triangle_mesh.h"
#include "polyfit/model/polyfit_model.h"
#include "polyfit/model/reconstruction.h"
#include "polyfit/patch/jet_fit.h"
#include "polyfit/pipeline/batch_fit.h"
#include "polyfit/pipeline/fit_mesh.h"
#include "polyfit/python/python_util.h"
#include "polyfit/util/status.h"

namespace polyfit::python {
namespace {

using namespace pybind11::literals;

// ---------------------------------------------------------------- errors

// polyfit.Error (a RuntimeError) and one subclass per ErrorKind; the
// invalid-argument one is also a ValueError. The objects live as long as
// the interpreter.
PyObject* g_error = nullptr;
PyObject* g_input_error = nullptr;
PyObject* g_output_error = nullptr;
PyObject* g_invalid_argument_error = nullptr;

PyObject* NewException(py::module_& m, const char* name, PyObject* bases, const char* doc) {
  PyObject* type = PyErr_NewExceptionWithDoc((std::string("polyfit.") + name).c_str(), doc, bases, nullptr);
  if (type == nullptr) throw py::error_already_set();
  m.attr(name) = py::handle(type);
  return type;
}

void BindErrors(py::module_& m) {
  py::enum_<TerminationType>(m, "TerminationType")
      .value("CONVERGENCE", TerminationType::kConvergence)
      .value("NO_CONVERGENCE", TerminationType::kNoConvergence)
      .value("FAILURE", TerminationType::kFailure);
  g_error =
      NewException(m, "Error", PyExc_RuntimeError, "Base of PolyFit's errors; the message names the file or key.");
  py::tuple input_bases = py::make_tuple(py::handle(g_error));
  g_input_error =
      NewException(m, "InputError", input_bases.ptr(), "A file or key that cannot be read or is malformed.");
  g_output_error = NewException(m, "OutputError", input_bases.ptr(), "An output that cannot be written.");
  py::tuple invalid_bases = py::make_tuple(py::handle(g_error), py::handle(PyExc_ValueError));
  g_invalid_argument_error =
      NewException(m, "InvalidArgumentError", invalid_bases.ptr(), "Options or arguments out of range.");
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      PyObject* type = e.kind() == ErrorKind::kInput    ? g_input_error
                       : e.kind() == ErrorKind::kOutput ? g_output_error
                                                        : g_invalid_argument_error;
      PyErr_SetString(type, e.what());
    }
  });
}

// Options whose Validate() says what is wrong.
template <typename Class>
void AddValidate(Class& c) {
  using T = typename Class::type;
  c.def("validate", &T::Validate, "Empty when valid, else the first problem.");
}

// ---------------------------------------------------------------- meshes

void BindMesh(py::module_& m) {
  py::class_<TriangleMesh> mesh(m, "TriangleMesh",
                                "A triangle mesh. vertices (#V, 3) float64 and faces (#F, 3) int32 are views of the "
                                "C++ storage (no copy); assigning replaces them (earlier views then dangle).");
  mesh.def(py::init<>())
      .def(py::init([](const CArray<double>& vertices, const CArray<int>& faces) {
             TriangleMesh t;
             t.vertices = RowsAsColumns<3>(vertices, "vertices");
             t.faces = RowsAsColumns<3>(faces, "faces");
             return t;
           }),
           "vertices"_a, "faces"_a)
      .def_property(
          "vertices", [](py::object self) { return ColumnsAsRows(self.cast<TriangleMesh&>().vertices, self); },
          [](TriangleMesh& t, const CArray<double>& v) { t.vertices = RowsAsColumns<3>(v, "vertices"); })
      .def_property(
          "faces", [](py::object self) { return ColumnsAsRows(self.cast<TriangleMesh&>().faces, self); },
          [](TriangleMesh& t, const CArray<int>& f) { t.faces = RowsAsColumns<3>(f, "faces"); })
      .def_property(
          "corner_texcoords",
          [](py::object self) { return ColumnsAsRows(self.cast<TriangleMesh&>().corner_texcoords, self); },
          [](TriangleMesh& t, const CArray<double>& uv) {
            t.corner_texcoords = RowsAsColumns<2>(uv, "corner_texcoords");
          },
          "(3 #F, 2): row 3 f + c is corner c of face f; empty without texture coordinates.")
      .def_property_readonly("num_vertices", &TriangleMesh::num_vertices)
      .def_property_readonly("num_faces", &TriangleMesh::num_faces)
      .def("validate", &TriangleMesh::Validate, "Empty when usable, else the first problem.")
      .def("face_areas", [](const TriangleMesh& t) { return Eigen::VectorXd(FaceAreas(t)); })
      .def("vertex_areas", [](const TriangleMesh& t) { return Eigen::VectorXd(VertexAreas(t)); })
      .def("surface_area", &SurfaceArea)
      .def("__repr__", [](const TriangleMesh& t) {
        return "TriangleMesh(" + std::to_string(t.num_vertices()) + " vertices, " + std::to_string(t.num_faces()) +
               " faces)";
      });
  AddCopy(mesh);

  py::class_<MeshReadSummary>(m, "MeshReadSummary")
      .def_readonly("num_dropped_degenerate_faces", &MeshReadSummary::num_dropped_degenerate_faces)
      .def_readonly("num_dropped_unreferenced_vertices", &MeshReadSummary::num_dropped_unreferenced_vertices)
      .def_readonly("num_meshes", &MeshReadSummary::num_meshes)
      .def_readonly("loader_messages", &MeshReadSummary::loader_messages);

  m.def(
      "read_mesh", [](const std::string& path) { return ReadTriangleMesh(path); }, "path"_a,
      py::call_guard<py::gil_scoped_release>(),
      "The mesh in the file (OBJ, PLY, OFF, STL, glTF, ...; welded, triangulated). Raises InputError naming it.");
  m.def(
      "read_mesh_with_summary",
      [](const std::string& path) {
        MeshReadSummary summary;
        TriangleMesh mesh;
        {
          py::gil_scoped_release release;
          mesh = ReadTriangleMesh(path, &summary);
        }
        return py::make_tuple(std::move(mesh), summary);
      },
      "path"_a, "The mesh in the file (welded, triangulated) and what reading it repaired. Raises InputError.");
  m.def(
      "write_ply", [](const std::string& path, const TriangleMesh& mesh) { WritePly(path, mesh); }, "path"_a, "mesh"_a,
      py::call_guard<py::gil_scoped_release>(), "Binary PLY, written atomically.");
  m.def("write_obj", &WriteObj, "path"_a, "mesh"_a, py::call_guard<py::gil_scoped_release>(),
        "OBJ (with texture coordinates when present), written atomically.");
  m.def(
      "read_ply_vertices", [](const std::string& path) { return ColumnsAsRows(ReadPlyVertices(path)); }, "path"_a,
      "(#V, 3): a PLY's vertices in file order (polysft's and onefit's per-frame meshes).");
  m.def("read_obj_template", &ReadObjTemplate, "path"_a, py::call_guard<py::gil_scoped_release>(),
        "An OBJ in its own vertex order, with per-corner texture coordinates (a PolySfT template).");
  m.def("make_icosphere", &MakeIcosphere, "levels"_a, "radius"_a = 1.0);
  m.def("make_grid", &MakeGrid, "nx"_a, "ny"_a, "size"_a = 1.0);
  m.def("make_bumpy_torus", &MakeBumpyTorus, "nu"_a, "nv"_a, "bumps"_a = 0.15);
}

// ---------------------------------------------------------------- jets

// u and v as equally long flat arrays; ValueError otherwise.
std::pair<CArray<double>, CArray<double>> FlatUv(py::object u, py::object v) {
  CArray<double> uu = CArray<double>::ensure(u);
  CArray<double> vv = CArray<double>::ensure(v);
  if (!uu || !vv) throw py::value_error("u and v must be numbers or arrays of numbers");
  if (uu.size() != vv.size()) {
    throw py::value_error("u and v differ in size (" + std::to_string(uu.size()) + " and " + std::to_string(vv.size()) +
                          ")");
  }
  return {uu, vv};
}

// The coefficients of an order-n jet; ValueError naming what is wrong.
CArray<double> CheckedCoefficients(int order, const CArray<double>& alpha) {
  if (order < 0 || order > kMaxJetOrder) {
    throw py::value_error("order must be in [0, " + std::to_string(kMaxJetOrder) + "], got " + std::to_string(order));
  }
  if (alpha.ndim() != 1 || alpha.shape(0) != NumJetCoefficients(order)) {
    throw py::value_error("an order-" + std::to_string(order) + " jet has " +
                          std::to_string(NumJetCoefficients(order)) + " coefficients, got an array of " +
                          std::to_string(alpha.size()));
  }
  return alpha;
}

// An array shaped like `like` (a 0-d one for a scalar).
py::array_t<double> ShapedLike(const CArray<double>& like) {
  std::vector<py::ssize_t> shape(like.shape(), like.shape() + like.ndim());
  return py::array_t<double>(shape);
}

void BindJets(py::module_& m) {
  m.attr("MAX_JET_ORDER") = kMaxJetOrder;
  m.def("num_jet_coefficients", &NumJetCoefficients, "order"_a, "(n + 1)(n + 2) / 2");
  m.def("jet_coefficient_index", &JetCoefficientIndex, "a"_a, "b"_a, "Index of the coefficient of u^a v^b.");
  m.def(
      "jet_monomials",
      [](int order, py::object u, py::object v) {
        auto [uu, vv] = FlatUv(u, v);
        if (order < 0 || order > kMaxJetOrder) throw py::value_error("order out of range");
        const py::ssize_t n = uu.size(), c = NumJetCoefficients(order);
        py::array_t<double> out({n, c});
        double* o = out.mutable_data();
        for (py::ssize_t i = 0; i < n; ++i) JetMonomials(order, uu.data()[i], vv.data()[i], o + i * c);
        return out;
      },
      "order"_a, "u"_a, "v"_a, "(N, #coefficients): u^a v^b at each (u, v), in coefficient order.");
  m.def(
      "jet_height",
      [](int order, const CArray<double>& alpha, py::object u, py::object v) {
        CheckedCoefficients(order, alpha);
        auto [uu, vv] = FlatUv(u, v);
        py::array_t<double> z = ShapedLike(uu);
        double* out = z.mutable_data();
        for (py::ssize_t i = 0; i < uu.size(); ++i)
          out[i] = EvaluateJetHeight(order, alpha.data(), uu.data()[i], vv.data()[i]);
        return z;
      },
      "order"_a, "coefficients"_a, "u"_a, "v"_a, "z(u, v) = sum alpha_ab u^a v^b, shaped like u.");
  m.def(
      "jet_derivatives",
      [](int order, const CArray<double>& alpha, py::object u, py::object v) {
        CheckedCoefficients(order, alpha);
        auto [uu, vv] = FlatUv(u, v);
        const char* names[6] = {"z", "z_u", "z_v", "z_uu", "z_uv", "z_vv"};
        py::array_t<double> arrays[6];
        double* out[6];
        for (int k = 0; k < 6; ++k) {
          arrays[k] = ShapedLike(uu);
          out[k] = arrays[k].mutable_data();
        }
        for (py::ssize_t i = 0; i < uu.size(); ++i) {
          const auto d = EvaluateJetDerivatives(order, alpha.data(), uu.data()[i], vv.data()[i]);
          const double values[6] = {d.z, d.z_u, d.z_v, d.z_uu, d.z_uv, d.z_vv};
          for (int k = 0; k < 6; ++k) out[k][i] = values[k];
        }
        py::dict result;
        for (int k = 0; k < 6; ++k) result[names[k]] = arrays[k];
        return result;
      },
      "order"_a, "coefficients"_a, "u"_a, "v"_a, "z and its first and second partial derivatives, by name.");
  m.def(
      "jet_curvatures",
      [](int order, const CArray<double>& alpha, py::object u, py::object v) {
        CheckedCoefficients(order, alpha);
        auto [uu, vv] = FlatUv(u, v);
        py::array_t<double> gaussian = ShapedLike(uu), mean = ShapedLike(uu);
        for (py::ssize_t i = 0; i < uu.size(); ++i) {
          const auto d = EvaluateJetDerivatives(order, alpha.data(), uu.data()[i], vv.data()[i]);
          JetCurvatures(d, gaussian.mutable_data() + i, mean.mutable_data() + i);
        }
        return py::make_tuple(gaussian, mean);
      },
      "order"_a, "coefficients"_a, "u"_a, "v"_a, "(Gaussian, mean) curvature of the height graph.");
}

// ---------------------------------------------------------------- patches

// Applies f(patch, u, v, out) per point; `width` outputs per point.
template <typename F>
py::array_t<double> PerPoint(py::object u, py::object v, int width, F f) {
  auto [uu, vv] = FlatUv(u, v);
  const py::ssize_t n = uu.size();
  py::array_t<double> out = width == 1 ? ShapedLike(uu) : py::array_t<double>({n, py::ssize_t(width)});
  double* o = out.mutable_data();
  for (py::ssize_t i = 0; i < n; ++i) f(uu.data()[i], vv.data()[i], o + i * width);
  return out;
}

void BindPatchFrame(py::module_& m) {
  py::class_<PatchFrame> frame(m, "PatchFrame", "x_world = scale * rotation @ x_patch + translation.");
  frame.def(py::init<>())
      .def_readwrite("scale", &PatchFrame::scale)
      .def_property(
          "rotation", [](const PatchFrame& f) { return Eigen::Matrix3d(f.rotation); },
          [](PatchFrame& f, const Eigen::Matrix3d& r) { f.rotation = r; }, "Columns: the u axis, v axis, normal.")
      .def_property(
          "translation", [](const PatchFrame& f) { return Eigen::Vector3d(f.translation); },
          [](PatchFrame& f, const Eigen::Vector3d& t) { f.translation = t; })
      .def(
          "point_to_world",
          [](const PatchFrame& f, const CArray<double>& points) {
            return ColumnsAsRows(Eigen::Matrix3Xd(
                (f.scale * f.rotation * RowsAsColumns<3>(points, "points_in_patch")).colwise() + f.translation));
          },
          "points_in_patch"_a)
      .def(
          "point_to_patch",
          [](const PatchFrame& f, const CArray<double>& points) {
            return ColumnsAsRows(
                Eigen::Matrix3Xd(f.rotation.transpose() *
                                 (RowsAsColumns<3>(points, "points_in_world").colwise() - f.translation) / f.scale));
          },
          "points_in_world"_a);
  AddCopy(frame);
}

// A patch: its frame, order, coefficients, and its surface by (u, v).
void BindJetPatch(py::module_& m) {
  m.def("jet_fit_flags_to_string", &JetFitFlagsToString, "flags"_a);
  py::class_<JetPatch> patch(m, "JetPatch", "A patch: its frame and the n-jet height function over it.");
  patch.def(py::init<>())
      .def_readwrite("frame", &JetPatch::frame)
      .def_readwrite("order", &JetPatch::order)
      .def_property(
          "coefficients",
          [](const JetPatch& p) {
            return std::vector<double>(p.coefficients.begin(), p.coefficients.begin() + NumJetCoefficients(p.order));
          },
          [](JetPatch& p, const CArray<double>& alpha) {
            CheckedCoefficients(p.order, alpha);
            p.coefficients.fill(0.0);
            std::copy(alpha.data(), alpha.data() + alpha.size(), p.coefficients.begin());
          },
          "alpha, num_jet_coefficients(order) values (set the order first).")
      .def_readwrite("flags", &JetPatch::flags)
      .def_property_readonly("flag_names", [](const JetPatch& p) { return JetFitFlagsToString(p.flags); })
      .def_readwrite("num_points", &JetPatch::num_points)
      .def_readwrite("rms_residual", &JetPatch::rms_residual)
      .def_readwrite("refinement_iterations", &JetPatch::refinement_iterations)
      .def(
          "height",
          [](const JetPatch& p, py::object u, py::object v) {
            return PerPoint(u, v, 1, [&](double a, double b, double* o) { *o = p.Height(a, b); });
          },
          "u"_a, "v"_a)
      .def(
          "point_in_world",
          [](const JetPatch& p, py::object u, py::object v) {
            return PerPoint(u, v, 3, [&](double a, double b, double* o) {
              Eigen::Map<Eigen::Vector3d> out(o);
              out = p.PointInWorld(a, b);
            });
          },
          "u"_a, "v"_a, "(N, 3)")
      .def(
          "normal_in_world",
          [](const JetPatch& p, py::object u, py::object v) {
            return PerPoint(u, v, 3, [&](double a, double b, double* o) {
              Eigen::Map<Eigen::Vector3d> out(o);
              out = p.NormalInWorld(a, b);
            });
          },
          "u"_a, "v"_a, "(N, 3)")
      .def("__repr__", [](const JetPatch& p) {
        return "JetPatch(order " + std::to_string(p.order) + ", " + std::to_string(p.num_points) + " points, rms " +
               std::to_string(p.rms_residual) + ", " + JetFitFlagsToString(p.flags) + ")";
      });
  AddCopy(patch);
}

void BindJetFitting(py::module_& m) {
  py::enum_<OrientationSolver>(m, "OrientationSolver")
      .value("VARPRO_LM", OrientationSolver::kVarProLM)
      .value("CERES", OrientationSolver::kCeres);
  py::class_<OrientationRefinementOptions> refinement(m, "OrientationRefinementOptions");
  refinement.def(py::init<>())
      .def_readwrite("solver", &OrientationRefinementOptions::solver)
      .def_readwrite("max_iterations", &OrientationRefinementOptions::max_iterations)
      .def_readwrite("function_tolerance", &OrientationRefinementOptions::function_tolerance);
  AddCopy(refinement);
  py::class_<JetFitOptions> jet_fit(m, "JetFitOptions");
  jet_fit.def(py::init<>())
      .def_readwrite("order", &JetFitOptions::order)
      .def_readwrite("refine_orientation", &JetFitOptions::refine_orientation)
      .def_readwrite("refinement", &JetFitOptions::refinement)
      .def_readwrite("not_height_field_threshold", &JetFitOptions::not_height_field_threshold)
      .def_readwrite("num_threads", &JetFitOptions::num_threads);
  AddCopy(jet_fit);
  AddValidate(jet_fit);
  py::class_<JetFitSummary>(m, "JetFitSummary")
      .def_readonly("num_patches", &JetFitSummary::num_patches)
      .def_readonly("num_points", &JetFitSummary::num_points)
      .def_readonly("num_reduced_order", &JetFitSummary::num_reduced_order)
      .def_readonly("num_rank_deficient", &JetFitSummary::num_rank_deficient)
      .def_readonly("num_degenerate", &JetFitSummary::num_degenerate)
      .def_readonly("num_dropped_non_finite", &JetFitSummary::num_dropped_non_finite)
      .def_readonly("num_not_height_field", &JetFitSummary::num_not_height_field)
      .def_readonly("num_threads", &JetFitSummary::num_threads)
      .def_readonly("total_time_s", &JetFitSummary::total_time_s)
      .def_readonly("rms_residual", &JetFitSummary::rms_residual)
      .def("brief_report", &JetFitSummary::BriefReport)
      .def("__repr__", &JetFitSummary::BriefReport);

  m.def(
      "fit_jet_patches",
      [](const JetFitOptions& options, const CArray<double>& points, std::vector<int> patch_offsets,
         std::optional<CArray<double>> weights) {
        Eigen::Matrix3Xd points_in_world = RowsAsColumns<3>(points, "points");
        std::vector<double> w;
        if (weights) {
          if (weights->size() != points_in_world.cols()) {
            throw py::value_error("weights: expected one per point (" + std::to_string(points_in_world.cols()) +
                                  "), got " + std::to_string(weights->size()));
          }
          w.assign(weights->data(), weights->data() + weights->size());
        }
        std::vector<JetPatch> patches;
        JetFitSummary summary;
        {
          py::gil_scoped_release release;
          summary = FitJetPatches(options, points_in_world, patch_offsets, weights ? &w : nullptr, &patches);
        }
        return py::make_tuple(patches, summary);
      },
      "options"_a, "points"_a, "patch_offsets"_a, "weights"_a = py::none(),
      "Fits patch p to points[patch_offsets[p]:patch_offsets[p + 1]] (N by 3), in parallel. Returns (patches, "
      "summary).");
}

// ---------------------------------------------------------------- models

void BindModel(py::module_& m) {
  py::enum_<SeamMode>(m, "SeamMode").value("OWNER", SeamMode::kOwner).value("AVERAGE", SeamMode::kAverage);
  py::class_<ReconstructionOptions> reconstruction(m, "ReconstructionOptions");
  reconstruction.def(py::init<>())
      .def_readwrite("seam_mode", &ReconstructionOptions::seam_mode)
      .def_readwrite("boundary_smoothing_iterations", &ReconstructionOptions::boundary_smoothing_iterations)
      .def_readwrite("boundary_smoothing_step", &ReconstructionOptions::boundary_smoothing_step);
  AddCopy(reconstruction);
  AddValidate(reconstruction);
  py::class_<ReconstructionSummary>(m, "ReconstructionSummary")
      .def_readonly("num_boundary_vertices", &ReconstructionSummary::num_boundary_vertices)
      .def_readonly("mean_seam_gap", &ReconstructionSummary::mean_seam_gap)
      .def_readonly("max_seam_gap", &ReconstructionSummary::max_seam_gap);

  py::class_<PolyFitModel> model(m, "PolyFitModel",
                                 "Patches, the fitted mesh's faces and every vertex's (u, v) on its patches.");
  model.def(py::init<>())
      .def_readwrite("patches", &PolyFitModel::patches, "A list of JetPatch (a copy: assign to change).")
      .def_property_readonly("faces",
                             [](py::object self) { return ColumnsAsRows(self.cast<PolyFitModel&>().faces, self); })
      .def_property_readonly("face_patch", [](const PolyFitModel& x) { return VectorToArray(x.face_patch); })
      .def_property_readonly("membership_offsets",
                             [](const PolyFitModel& x) { return VectorToArray(x.membership_offsets); })
      .def_property_readonly("membership_patch",
                             [](const PolyFitModel& x) { return VectorToArray(x.membership_patch); })
      .def_property_readonly(
          "membership_uv",
          [](py::object self) { return ColumnsAsRows(self.cast<PolyFitModel&>().membership_uv, self); },
          "(#memberships, 2); vertex v's are rows membership_offsets[v]:membership_offsets[v + 1], its owner first.")
      .def_property_readonly("num_vertices", &PolyFitModel::num_vertices)
      .def_property_readonly("num_patches", &PolyFitModel::num_patches)
      .def_property_readonly("num_memberships", &PolyFitModel::num_memberships)
      .def("validate", &PolyFitModel::Validate)
      .def(
          "save", [](const PolyFitModel& x, const std::string& path) { SavePolyFitModel(path, x); }, "path"_a,
          py::call_guard<py::gil_scoped_release>(), "Writes a .pfm file atomically (docs/model-format.md).")
      .def(
          "reconstruct",
          [](const PolyFitModel& x, const ReconstructionOptions& options) {
            ReconstructionSummary summary;
            Eigen::Matrix3Xd vertices;
            {
              py::gil_scoped_release release;
              vertices = ReconstructVertices(x, options, &summary);
            }
            return py::make_tuple(ColumnsAsRows(std::move(vertices)), summary);
          },
          "options"_a = ReconstructionOptions(), "(#V by 3 vertices, ReconstructionSummary).")
      .def("__repr__", [](const PolyFitModel& x) {
        return "PolyFitModel(" + std::to_string(x.num_patches()) + " patches, " + std::to_string(x.num_vertices()) +
               " vertices)";
      });
  AddCopy(model);
  m.def("load_model", &LoadPolyFitModel, "path"_a, py::call_guard<py::gil_scoped_release>(),
        "Reads a .pfm file; ModelIoError (an InputError) names it when it cannot.");
}

// ---------------------------------------------------------------- fitting

void BindClustering(py::module_& m) {
  py::enum_<SubdivisionScheme>(m, "SubdivisionScheme")
      .value("MIDPOINT", SubdivisionScheme::kMidpoint)
      .value("LOOP", SubdivisionScheme::kLoop);
  py::class_<ClusteringOptions> clustering(m, "ClusteringOptions");
  clustering.def(py::init<>())
      .def_readwrite("num_patches", &ClusteringOptions::num_patches, "0: from the area (auto_*)")
      .def_readwrite("auto_area_per_patch", &ClusteringOptions::auto_area_per_patch)
      .def_readwrite("auto_min_patches", &ClusteringOptions::auto_min_patches)
      .def_readwrite("auto_max_patches", &ClusteringOptions::auto_max_patches)
      .def_readwrite("normal_weight", &ClusteringOptions::normal_weight)
      .def_readwrite("max_iterations", &ClusteringOptions::max_iterations)
      .def_readwrite("debris_fraction", &ClusteringOptions::debris_fraction)
      .def_readwrite("seed", &ClusteringOptions::seed);
  AddCopy(clustering);
  AddValidate(clustering);
  py::class_<ClusteringSummary>(m, "ClusteringSummary")
      .def_readonly("requested_patches", &ClusteringSummary::requested_patches)
      .def_readonly("num_patches", &ClusteringSummary::num_patches)
      .def_readonly("num_components", &ClusteringSummary::num_components)
      .def_readonly("num_debris_faces", &ClusteringSummary::num_debris_faces)
      .def_readonly("soup_fallback", &ClusteringSummary::soup_fallback)
      .def_readonly("iterations", &ClusteringSummary::iterations)
      .def_readonly("min_relative_area", &ClusteringSummary::min_relative_area)
      .def_readonly("max_relative_area", &ClusteringSummary::max_relative_area)
      .def_readonly("relative_area_stddev", &ClusteringSummary::relative_area_stddev)
      .def_readonly("time_s", &ClusteringSummary::time_s);
  py::class_<SubdivisionSummary>(m, "SubdivisionSummary")
      .def_readonly("levels", &SubdivisionSummary::levels)
      .def_readonly("scheme_used", &SubdivisionSummary::scheme_used)
      .def_readonly("fallback_reason", &SubdivisionSummary::fallback_reason);
}

void BindFitMesh(py::module_& m) {
  py::class_<MeshFitOptions> options(m, "MeshFitOptions");
  options.def(py::init<>())
      .def_readwrite("clustering", &MeshFitOptions::clustering)
      .def_readwrite("min_vertices_per_patch", &MeshFitOptions::min_vertices_per_patch)
      .def_readwrite("max_subdivision_levels", &MeshFitOptions::max_subdivision_levels)
      .def_readwrite("subdivision_scheme", &MeshFitOptions::subdivision_scheme)
      .def_readwrite("jet_fit", &MeshFitOptions::jet_fit)
      .def_readwrite("reconstruction", &MeshFitOptions::reconstruction)
      .def_readwrite("evaluate", &MeshFitOptions::evaluate)
      .def_readwrite("evaluation_samples", &MeshFitOptions::evaluation_samples)
      .def_readwrite("evaluation_seed", &MeshFitOptions::evaluation_seed)
      .def_readwrite("num_threads", &MeshFitOptions::num_threads);
  AddCopy(options);
  AddValidate(options);
  py::class_<MeshFitSummary>(m, "MeshFitSummary")
      .def_readonly("input_vertices", &MeshFitSummary::input_vertices)
      .def_readonly("input_faces", &MeshFitSummary::input_faces)
      .def_readonly("fitted_vertices", &MeshFitSummary::fitted_vertices)
      .def_readonly("fitted_faces", &MeshFitSummary::fitted_faces)
      .def_readonly("subdivision", &MeshFitSummary::subdivision)
      .def_readonly("clustering", &MeshFitSummary::clustering)
      .def_readonly("jet_fit", &MeshFitSummary::jet_fit)
      .def_readonly("reconstruction", &MeshFitSummary::reconstruction)
      .def_readonly("subdivide_time_s", &MeshFitSummary::subdivide_time_s)
      .def_readonly("cluster_time_s", &MeshFitSummary::cluster_time_s)
      .def_readonly("fit_time_s", &MeshFitSummary::fit_time_s)
      .def_readonly("reconstruct_time_s", &MeshFitSummary::reconstruct_time_s)
      .def_readonly("total_time_s", &MeshFitSummary::total_time_s)
      .def_readonly("evaluate_time_s", &MeshFitSummary::evaluate_time_s)
      .def_readonly("chamfer", &MeshFitSummary::chamfer)
      .def_readonly("chamfer_floor", &MeshFitSummary::chamfer_floor)
      .def_readonly("surface_chamfer", &MeshFitSummary::surface_chamfer)
      .def_readonly("height_rmse", &MeshFitSummary::height_rmse)
      .def_readonly("normal_error_deg", &MeshFitSummary::normal_error_deg)
      .def("brief_report", &MeshFitSummary::BriefReport)
      .def("__repr__", &MeshFitSummary::BriefReport);

  m.def(
      "fit_mesh",
      [](const MeshFitOptions& options, const TriangleMesh& mesh) {
        PolyFitModel model;
        TriangleMesh reconstruction;
        MeshFitSummary summary;
        {
          py::gil_scoped_release release;
          summary = FitMesh(options, mesh, &model, &reconstruction);
        }
        return py::make_tuple(std::move(model), std::move(reconstruction), summary);
      },
      "options"_a, "mesh"_a, "Returns (model, reconstruction, summary).");
}

// ---------------------------------------------------------------- batch

void BindBatchFit(py::module_& m) {
  py::class_<BatchFitOptions> options(m, "BatchFitOptions");
  options.def(py::init<>())
      .def_readwrite("fit", &BatchFitOptions::fit)
      .def_readwrite("output_dir", &BatchFitOptions::output_dir)
      .def_readwrite("force", &BatchFitOptions::force)
      .def_readwrite("num_threads", &BatchFitOptions::num_threads);
  AddCopy(options);
  AddValidate(options);
  py::enum_<BatchItemStatus>(m, "BatchItemStatus")
      .value("FITTED", BatchItemStatus::kFitted)
      .value("SKIPPED", BatchItemStatus::kSkipped)
      .value("FAILED", BatchItemStatus::kFailed);
  py::class_<BatchFitItemSummary>(m, "BatchFitItemSummary")
      .def_readonly("input", &BatchFitItemSummary::input)
      .def_readonly("name", &BatchFitItemSummary::name)
      .def_readonly("status", &BatchFitItemSummary::status)
      .def_readonly("error", &BatchFitItemSummary::error)
      .def_readonly("read_time_s", &BatchFitItemSummary::read_time_s)
      .def_readonly("summary", &BatchFitItemSummary::summary);
  py::class_<BatchFitSummary>(m, "BatchFitSummary")
      .def_readonly("items", &BatchFitSummary::items)
      .def_readonly("num_fitted", &BatchFitSummary::num_fitted)
      .def_readonly("num_skipped", &BatchFitSummary::num_skipped)
      .def_readonly("num_failed", &BatchFitSummary::num_failed)
      .def_readonly("total_time_s", &BatchFitSummary::total_time_s)
      .def("__repr__", [](const BatchFitSummary& s) {
        return "BatchFitSummary(" + std::to_string(s.num_fitted) + " fitted, " + std::to_string(s.num_skipped) +
               " skipped, " + std::to_string(s.num_failed) + " failed)";
      });

  m.def("expand_mesh_inputs", &ExpandMeshInputs, "inputs"_a);
  m.def(
      "fit_mesh_files",
      [](const BatchFitOptions& options, const std::vector<std::string>& inputs, py::object progress) {
        DeferredCallback<int, int, const BatchFitItemSummary&> callback(progress);
        BatchFitSummary summary;
        {
          py::gil_scoped_release release;
          summary = FitMeshFiles(options, inputs, callback.Function());
        }
        callback.Rethrow();
        return summary;
      },
      "options"_a, "inputs"_a, "progress"_a = py::none(),
      "Fits every input into options.output_dir (resumable). progress(done, total, item) after each.");
}

}  // namespace
}  // namespace polyfit::python

PYBIND11_MODULE(_core, m) {
  namespace pp = polyfit::python;
  m.doc() = "PolyFit's C++ library (use the package `polyfit`).";
  pp::BindErrors(m);
  pp::BindMesh(m);
  pp::BindJets(m);
  pp::BindPatchFrame(m);
  pp::BindJetPatch(m);
  pp::BindJetFitting(m);
  pp::BindModel(m);
  pp::BindClustering(m);
  pp::BindFitMesh(m);
  pp::BindBatchFit(m);
}
