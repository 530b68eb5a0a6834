#include "drape/simulate/drape_simulation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <memory>
#include <sstream>

#include <nlohmann/json.hpp>

#include "drape/body/procedural_body.h"
#include "drape/garment/mhclo_garment.h"
#include "drape/motion/retarget.h"
#include "drape/render/mesh_render.h"
#include "polyfit/mesh/mesh_io.h"
#include "polyfit/util/atomic_file.h"

namespace polyfit {
namespace {

namespace fs = std::filesystem;

std::string FrameName(const char* stem, int frame, const char* extension) {
  char name[64];
  std::snprintf(name, sizeof(name), "%s_%04d.%s", stem, frame, extension);
  return name;
}

}  // namespace

std::string DrapeSimulationOptions::Validate() const {
  if (garment_path.empty()) return "a garment is needed";
  if (motion_path.empty()) return "a motion clip is needed";
  if (out_dir.empty()) return "an output folder is needed";
  if (!(bvh_units_to_metres > 0.0)) return "bvh_units_to_metres must be positive";
  if (first_frame < 0) return "first_frame must be >= 0";
  if (num_frames == 0 || num_frames < -1) return "num_frames must be positive (or -1 for all)";
  if (lead_in_frames < 0 || render_every < 0) return "lead_in_frames and render_every must be >= 0";
  if (render_height < 32) return "render_height must be >= 32";
  const std::string shape_problem = shape.Validate();
  if (!shape_problem.empty()) return "shape: " + shape_problem;
  if (body_dir.empty() && !shape.IsNeutral()) return "a shape needs the MakeHuman body (body_dir)";
  const std::string problem = solver.Validate();
  if (!problem.empty()) return "solver: " + problem;
  return {};
}

DrapeSimulationSummary RunDrapeSimulation(const DrapeSimulationOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const std::string problem = options.Validate();
  if (!problem.empty()) throw DrapeInputError("onefit simulate: " + problem);

  // Inputs, all checked before anything is written.
  SkinnedBody body;
  try {
    if (options.body_dir.empty()) {
      body = MakeProceduralBody();
    } else {
      body = LoadMakeHumanBody(options.body_dir);
      ApplyBodyShape(options.body_dir, options.shape, &body);
    }
  } catch (const BodyError& e) {
    throw DrapeInputError(e.what());
  }
  TriangleMesh garment;
  const std::string extension = fs::path(options.garment_path).extension().string();
  if (!fs::exists(options.garment_path)) throw DrapeInputError(options.garment_path + ": no such garment file");
  try {
    if (extension == ".mhclo") {
      if (options.body_dir.empty()) throw DrapeInputError(options.garment_path + ": a .mhclo garment needs the MakeHuman body");
      garment = LoadGarment(options.garment_path, body.base_vertices, 0.1);
    } else {
      garment = ReadTriangleMesh(options.garment_path);
    }
  } catch (const GarmentError& e) {
    throw DrapeInputError(e.what());
  } catch (const MeshIoError& e) {
    throw DrapeInputError(e.what());
  }
  MotionClip clip;
  try {
    clip = ReadBvh(options.motion_path, options.bvh_units_to_metres).Resampled(options.solver.fps);
  } catch (const BvhError& e) {
    throw DrapeInputError(e.what());
  }
  std::unique_ptr<MotionRetargeter> retargeter;
  try {
    retargeter = std::make_unique<MotionRetargeter>(clip, body.skeleton);
  } catch (const BvhError& e) {
    throw DrapeInputError(options.motion_path + ": " + e.what());
  }
  if (options.first_frame >= retargeter->num_frames()) {
    throw DrapeInputError(options.motion_path + ": first frame " + std::to_string(options.first_frame) + " is past the clip's " +
                          std::to_string(retargeter->num_frames()) + " frames at " + std::to_string(options.solver.fps) + " fps");
  }
  const int last = options.num_frames < 0 ? retargeter->num_frames()
                                          : std::min(retargeter->num_frames(), options.first_frame + options.num_frames);

  DrapeSimulationSummary summary;
  // A garment the solver cannot take (zero-area faces, NaN) is named here,
  // still before anything is written.
  std::unique_ptr<DrapeSolver> solver_owner;
  try {
    const SkinWeights weights = TransferSkinWeights(body, garment, options.skin);
    solver_owner = std::make_unique<DrapeSolver>(body, garment, weights, options.solver);
  } catch (const std::invalid_argument& e) {
    throw DrapeInputError(options.garment_path + ": " + e.what());
  }
  DrapeSolver& solver = *solver_owner;
  const ClothRest rest = PrepareClothRest(solver.rest_garment());
  summary.garment_vertices = garment.num_vertices();
  summary.garment_faces = static_cast<int>(garment.faces.cols());
  summary.patches = solver.num_patches();
  summary.fit_error_mean = solver.fit_error_mean();
  summary.fit_error_max = solver.fit_error_max();
  {
    // A garment starting inside the body is handled, but worth knowing.
    const Eigen::VectorXd d = solver.SignedDistances();
    const double inside = 100.0 * (d.array() < 0.0).count() / static_cast<double>(d.size());
    if (inside > 1.0) {
      std::ostringstream warning;
      warning << std::fixed << std::setprecision(1) << inside << "% of the garment starts inside the body";
      summary.warnings.push_back(warning.str());
    }
  }

  const fs::path out(options.out_dir);
  std::error_code error;
  fs::create_directories(out, error);
  if (error) throw std::runtime_error(options.out_dir + ": cannot create the folder: " + error.message());
  if (options.write_meshes) fs::create_directories(out / "meshes");
  if (options.render_every > 0) fs::create_directories(out / "renders");

  // Lead-in: the rest pose blended into the first frame's.
  int step = 0;
  for (int k = 0; k < options.lead_in_frames; ++k, ++step) {
    const double blend = static_cast<double>(k + 1) / (options.lead_in_frames + 1);
    solver.Step(retargeter->Pose(options.first_frame, blend), options.solver.k_ext(step));
  }
  TriangleMesh posed = garment;
  TriangleMesh posed_body = body.mesh;
  for (int f = options.first_frame; f < last; ++f, ++step) {
    const DrapeStepReport report = solver.Step(retargeter->Pose(f), options.solver.k_ext(step));
    DrapeFrameRecord record;
    record.frame = f;
    record.time_s = report.time_s;
    record.solve_time_s = report.solve_time_s;
    record.iterations = report.iterations;
    record.passes = report.passes;
    record.cost = report.final_cost;
    record.finite = report.finite;
    const Eigen::VectorXd raw = solver.SignedDistances();
    record.inside_unprojected_percent = 100.0 * (raw.array() < 0.0).count() / static_cast<double>(raw.size());
    const bool project = options.project_offset >= 0.0;
    const auto project_start = std::chrono::steady_clock::now();
    posed.vertices = project ? solver.ProjectedOutOfBody(options.project_offset) : solver.positions();
    record.time_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - project_start).count();
    const Eigen::VectorXd exact = project ? solver.SignedDistances(posed.vertices) : raw;
    const Eigen::VectorXd nearest = solver.NearestVertexDistances(posed.vertices);
    record.inside_percent = 100.0 * (exact.array() < 0.0).count() / static_cast<double>(exact.size());
    record.inside_nearest_percent = 100.0 * (nearest.array() < 0.0).count() / static_cast<double>(nearest.size());
    record.min_distance = exact.minCoeff();
    const ClothMeasures measures = MeasureCloth(rest, posed.vertices, options.solver.material);
    record.edge_strain_percent = measures.edge_strain_percent;
    record.area_change_percent = measures.area_change_percent;
    record.max_edge_strain_percent = measures.max_edge_strain_percent;
    record.stretch_energy = measures.stretch_energy;
    record.bending_energy = measures.bending_energy;
    summary.records.push_back(record);

    if (options.write_meshes) WritePly((out / "meshes" / FrameName("frame", f, "ply")).string(), posed);
    if (options.render_every > 0 && (f - options.first_frame) % options.render_every == 0) {
      posed_body.vertices = solver.body_vertices();
      RenderOptions render;
      render.view_height = options.render_height;
      WriteImage((out / "renders" / FrameName("frame", f, "png")).string(), RenderBodyAndGarment(posed_body, posed, render));
    }
  }

  summary.frames = static_cast<int>(summary.records.size());
  for (const DrapeFrameRecord& r : summary.records) {
    const double n = static_cast<double>(summary.frames);
    summary.mean_time_s += r.time_s / n;
    summary.max_time_s = std::max(summary.max_time_s, r.time_s);
    summary.mean_inside_percent += r.inside_percent / n;
    summary.max_inside_percent = std::max(summary.max_inside_percent, r.inside_percent);
    summary.mean_edge_strain_percent += r.edge_strain_percent / n;
    summary.max_edge_strain_percent = std::max(summary.max_edge_strain_percent, r.edge_strain_percent);
    summary.mean_area_change_percent += r.area_change_percent / n;
    summary.all_finite = summary.all_finite && r.finite;
  }
  if (!summary.all_finite) summary.warnings.push_back("the solver produced non-finite values; those frames kept the previous state");
  summary.total_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  // frames.csv and metrics.json.
  WriteFileAtomically((out / "frames.csv").string(), [&](std::ostream& csv) {
    csv << "frame,time_s,solve_time_s,iterations,passes,inside_percent,inside_nearest_percent,inside_unprojected_percent,min_distance_m,"
           "edge_strain_percent,area_change_percent,max_edge_strain_percent,stretch_energy_J,bending_energy_J,cost,finite\n";
    csv << std::setprecision(6);
    for (const DrapeFrameRecord& r : summary.records) {
      csv << r.frame << ',' << r.time_s << ',' << r.solve_time_s << ',' << r.iterations << ',' << r.passes << ','
          << r.inside_percent << ',' << r.inside_nearest_percent << ',' << r.inside_unprojected_percent << ','
          << r.min_distance << ',' << r.edge_strain_percent
          << ',' << r.area_change_percent << ',' << r.max_edge_strain_percent << ',' << r.stretch_energy << ','
          << r.bending_energy << ',' << r.cost << ',' << (r.finite ? 1 : 0) << '\n';
    }
  });
  nlohmann::json j;
  j["body"] = options.body_dir.empty() ? "procedural" : options.body_dir;
  j["shape"] = options.shape.ToString();
  j["garment"] = options.garment_path;
  j["motion"] = options.motion_path;
  j["fps"] = options.solver.fps;
  j["first_frame"] = options.first_frame;
  j["lead_in_frames"] = options.lead_in_frames;
  j["project_offset_m"] = options.project_offset;
  j["garment_vertices"] = summary.garment_vertices;
  j["garment_faces"] = summary.garment_faces;
  j["patches"] = summary.patches;
  j["fit_error_mean_m"] = summary.fit_error_mean;
  j["fit_error_max_m"] = summary.fit_error_max;
  j["frames"] = summary.frames;
  const DrapingWeights& w = options.solver.weights;
  j["weights"] = {{"k_b", w.boundary},        {"k_mi", w.inextensibility}, {"k_g", w.gravity},
                  {"k_c", w.collision},       {"k_i", w.inertia},          {"eps_m", w.collision_margin},
                  {"kappa_N_per_m", options.solver.collision_stiffness}, {"boundary_base", options.solver.boundary_base},
                  {"stretch_base", options.solver.stretch_base},
                  {"k_ext_start", options.solver.k_ext.start}, {"k_ext_ramp_steps", options.solver.k_ext.ramp_steps}};
  j["summary"] = {{"mean_time_per_frame_s", summary.mean_time_s},
                  {"max_time_per_frame_s", summary.max_time_s},
                  {"mean_inside_percent", summary.mean_inside_percent},
                  {"max_inside_percent", summary.max_inside_percent},
                  {"mean_edge_strain_percent", summary.mean_edge_strain_percent},
                  {"max_edge_strain_percent", summary.max_edge_strain_percent},
                  {"mean_area_change_percent", summary.mean_area_change_percent},
                  {"all_finite", summary.all_finite},
                  {"total_time_s", summary.total_time_s}};
  j["warnings"] = summary.warnings;
  WriteFileAtomically((out / "metrics.json").string(), [&](std::ostream& stream) { stream << j.dump(2) << '\n'; });
  return summary;
}

}  // namespace polyfit
