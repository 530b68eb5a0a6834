#include "drape/simulate/drape_simulation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <memory>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "drape/network/onefit_draper.h"
#include "drape/render/mesh_render.h"
#include "drape/simulate/drape_inputs.h"
#include "polyfit/mesh/mesh_io.h"
#include "polyfit/util/atomic_file.h"
#include "polyfit/util/json_number.h"

namespace polyfit {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

std::string FrameName(const char* stem, int frame, const char* extension) {
  char name[64];
  std::snprintf(name, sizeof(name), "%s_%04d.%s", stem, frame, extension);
  return name;
}

double PercentNegative(const Eigen::VectorXd& d) {
  return 100.0 * (d.array() < 0.0).count() / static_cast<double>(d.size());
}

// The % of `area` (per vertex) where d < 0.
double PercentAreaNegative(const Eigen::VectorXd& d, const Eigen::VectorXd& area) {
  const double total = area.sum();
  return total > 0.0 ? 100.0 * (d.array() < 0.0).select(area, 0.0).sum() / total : 0.0;
}

// Everything read from disk, checked before anything is written.
struct DrapeInputs {
  SkinnedBody body;
  TriangleMesh garment;
  std::unique_ptr<MotionRetargeter> retargeter;
  int last_frame = 0;  // one past the last frame to simulate
};

DrapeInputs LoadInputs(const DrapeSimulationOptions& options) {
  DrapeInputs in;
  in.body = LoadDrapeBody(options.body_dir, options.shape);
  in.garment = LoadDrapeGarment(options.garment_path, in.body, !options.body_dir.empty());
  in.retargeter = LoadRetargetedClip(options.motion_path, options.bvh_units_to_metres, options.solver.physics.fps,
                                     in.body.skeleton);
  const int frames = in.retargeter->num_frames();
  if (options.first_frame >= frames) {
    throw DrapeInputError(options.motion_path + ": first frame " + std::to_string(options.first_frame) +
                          " is past the clip's " + std::to_string(frames) + " frames at " +
                          std::to_string(options.solver.physics.fps) + " fps");
  }
  in.last_frame = options.num_frames < 0 ? frames : std::min(frames, options.first_frame + options.num_frames);
  return in;
}

// A garment the solver cannot take (zero-area faces, NaN) is named here,
// still before anything is written.
std::unique_ptr<DrapeSolver> CreateSolver(const DrapeSimulationOptions& options, const DrapeInputs& in,
                                          SkinWeights* weights) {
  try {
    *weights = TransferSkinWeights(in.body, in.garment, options.skin);
    return std::make_unique<DrapeSolver>(in.body, in.garment, *weights, options.solver);
  } catch (const std::invalid_argument& e) {
    throw DrapeInputError(options.garment_path + ": " + e.what());
  }
}

void DescribeGarment(const DrapeInputs& in, const DrapeSolver& solver, DrapeSimulationSummary* summary) {
  summary->garment_vertices = in.garment.num_vertices();
  summary->garment_faces = in.garment.num_faces();
  summary->patches = solver.num_patches();
  summary->fit_error_mean = solver.fit_error_mean();
  summary->fit_error_max = solver.fit_error_max();
  // A garment starting inside the body is handled, but worth knowing.
  const double inside = PercentNegative(solver.SignedDistances());
  if (inside > 1.0) {
    std::ostringstream warning;
    warning << std::fixed << std::setprecision(1) << inside << "% of the garment starts inside the body";
    summary->warnings.push_back(warning.str());
  }
}

void CreateOutputFolders(const DrapeSimulationOptions& options) {
  const fs::path out(options.out_dir);
  std::error_code error;
  fs::create_directories(out, error);
  if (!error && options.write_meshes) fs::create_directories(out / "meshes", error);
  if (!error && options.render_every > 0) fs::create_directories(out / "renders", error);
  if (error) throw Error(ErrorKind::kOutput, options.out_dir + ": cannot create the folder: " + error.message());
}

// The garment at rest as its patches rebuild it: what strain is measured
// against, so that anyone can check the metrics.
void WriteRestGarment(const DrapeSimulationOptions& options, const DrapeSolver& solver) {
  if (options.write_meshes) WritePly((fs::path(options.out_dir) / "rest_garment.ply").string(), solver.rest_garment());
}

// The garment's metrics at a frame: the solver's state, or its projection
// out of the body (options.project_offset) into `posed`.
DrapeFrameSummary MeasureFrame(const DrapeSimulationOptions& options, const DrapeSolver& solver, const ClothRest& rest,
                               const DrapeStepSummary& step, int frame, TriangleMesh* posed) {
  DrapeFrameSummary record;
  record.frame = frame;
  record.termination_type = step.termination_type;
  record.time_s = step.time_s;
  record.solve_time_s = step.solve_time_s;
  record.iterations = step.iterations;
  record.passes = step.passes;
  record.cost = step.final_cost;
  record.finite = step.IsSolutionUsable();
  const Eigen::VectorXd raw = solver.SignedDistances();
  record.inside_unprojected_percent = PercentNegative(raw);
  record.inside_area_percent =
      PercentAreaNegative(raw, VertexAreas(TriangleMesh{solver.positions(), posed->faces, {}}));
  const bool project = options.project_offset >= 0.0;
  const auto project_start = Clock::now();
  posed->vertices =
      project ? solver.PostProcessed(options.project_offset, options.strain_limit_passes, rest) : solver.positions();
  record.time_s += Seconds(project_start);
  const Eigen::VectorXd exact = project ? solver.SignedDistances(posed->vertices) : raw;
  record.inside_percent = PercentNegative(exact);
  record.inside_nearest_percent = PercentNegative(solver.NearestVertexDistances(posed->vertices));
  record.min_distance = exact.minCoeff();
  const ClothMeasures measures = MeasureCloth(rest, posed->vertices, options.solver.physics.material);
  record.edge_strain_percent = measures.edge_strain_percent;
  record.edge_strain_unprojected_percent =
      project ? MeasureCloth(rest, solver.positions(), options.solver.physics.material).edge_strain_percent
              : measures.edge_strain_percent;
  record.area_change_percent = measures.area_change_percent;
  record.max_edge_strain_percent = measures.max_edge_strain_percent;
  record.stretch_energy = measures.stretch_energy;
  record.bending_energy = measures.bending_energy;
  return record;
}

void WriteFrame(const DrapeSimulationOptions& options, const DrapeSolver& solver, const SkinnedBody& body, int frame,
                const TriangleMesh& posed) {
  const fs::path out(options.out_dir);
  TriangleMesh posed_body = body.mesh;
  posed_body.vertices = solver.body_vertices();
  if (options.write_meshes) {
    WritePly((out / "meshes" / FrameName("frame", frame, "ply")).string(), posed);
    WritePly((out / "meshes" / FrameName("body", frame, "ply")).string(), posed_body);
  }
  if (options.render_every > 0 && (frame - options.first_frame) % options.render_every == 0) {
    RenderOptions render;
    render.view_height = options.render_height;
    WriteImage((out / "renders" / FrameName("frame", frame, "png")).string(),
               RenderBodyAndGarment(posed_body, posed, render));
  }
}

// The lead-in (the rest pose blended into the first frame's, not written),
// then every frame: solved, measured, written. Each frame is one of k_ext's
// epochs (lead-in included).
void RunFrames(const DrapeSimulationOptions& options, const DrapeInputs& in, DrapeSolver* solver,
               DrapeSimulationSummary* summary) {
  int step = 0;
  for (int k = 0; k < options.lead_in_frames; ++k, ++step) {
    const double blend = static_cast<double>(k + 1) / (options.lead_in_frames + 1);
    solver->Step(in.retargeter->Pose(options.first_frame, blend), step);
  }
  const ClothRest rest = PrepareClothRest(solver->rest_garment());
  TriangleMesh posed = in.garment;
  for (int f = options.first_frame; f < in.last_frame; ++f, ++step) {
    const DrapeStepSummary report = solver->Step(in.retargeter->Pose(f), step);
    summary->records.push_back(MeasureFrame(options, *solver, rest, report, f, &posed));
    if (options.keep_positions) summary->positions.push_back(posed.vertices);
    WriteFrame(options, *solver, in.body, f, posed);
  }
}

// The network's drape: per frame, its prediction from the pose and the two
// before it, posed by the garment's skinning, then relaxed
// (NetworkRelaxation). The time is the inference (body features, network,
// garment skinning and vertices, relaxation); posing the body for the
// metrics is not counted.
void RunNetworkFrames(const DrapeSimulationOptions& options, const DrapeInputs& in, const OneFitDraper& draper,
                      DrapeSolver* solver, DrapeSimulationSummary* summary) {
  const ClothRest rest = PrepareClothRest(solver->rest_garment());
  TriangleMesh posed = in.garment;
  const double fps = options.solver.physics.fps;
  std::vector<double> correction;  // the last re-solve's change to its prediction
  // Bound once per garment, like the network's garment half.
  std::optional<NetworkRelaxation> relaxation;
  if (options.relax_passes > 0 && options.refine_iterations == 0 && options.warp_sweeps == 0) {
    NetworkRelaxationOptions relax;
    relax.passes = options.relax_passes;
    relaxation.emplace(in.body, solver->rest_garment(), relax);
    if (relaxation->passes() < relax.passes) {
      summary->notes.push_back("relaxation: " + std::to_string(relaxation->passes()) + " passes, not " +
                               std::to_string(relax.passes) + ", within its budget of " +
                               std::to_string(relax.max_edge_updates) + " edge updates a frame");
    }
  }
  for (int f = options.first_frame; f < in.last_frame; ++f) {
    const auto pose = [&](int g) { return in.retargeter->Pose(std::max(g, options.first_frame)); };
    const JointTransforms before_previous = pose(f - 2), previous = pose(f - 1), now = pose(f);
    const auto start = Clock::now();
    const std::vector<double> params = draper.Predict(before_previous, previous, now, fps, options.shape);
    DrapeStepSummary step;
    if (options.refine_iterations > 0) {
      // The solver's own step from the prediction (its prior anchors to
      // it); the clip starts at rest in the first prediction.
      if (f == options.first_frame) {
        const Eigen::Matrix3Xd first = solver->PositionsAt(params, now);
        solver->SetHistory(first, first);
      }
      solver->WarmStart(params);
      step = solver->Step(now);
      step.time_s = Seconds(start);
    } else {
      // With re-solved warps the body is posed within the inference (their
      // collision term reads it); else only the garment's skinning is, and
      // the body after it, for the metrics.
      std::vector<double> drape = params;
      Eigen::Matrix3Xd positions;
      if (options.warp_sweeps > 0) {
        solver->Pose(now);
        std::vector<double> from = params;
        if (correction.size() == params.size()) {
          for (size_t i = 0; i < from.size(); ++i) from[i] += options.warp_carry * correction[i];
        }
        drape = solver->SolveWarps(from, options.warp_sweeps, 2, options.warp_translations);
        // SolveWarps holds the jets and scales: only warps and translations
        // differ. A non-finite one is not carried on.
        correction.resize(params.size());
        for (size_t i = 0; i < params.size(); ++i) correction[i] = drape[i] - params[i];
        if (!std::all_of(correction.begin(), correction.end(), [](double c) { return std::isfinite(c); })) {
          correction.clear();
        }
        positions = solver->PositionsOf(drape);
      } else {
        positions = solver->PositionsAt(params, now);
      }
      if (relaxation) relaxation->Apply(now, &positions, draper.posed_body());
      step.time_s = step.solve_time_s = Seconds(start);
      if (options.warp_sweeps == 0) solver->Pose(now);
      solver->Adopt(drape, positions);
      if (!positions.allFinite()) {
        step.termination_type = TerminationType::kFailure;
        step.message = "the network predicted non-finite positions";
      }
    }
    summary->records.push_back(MeasureFrame(options, *solver, rest, step, f, &posed));
    if (options.keep_positions) summary->positions.push_back(posed.vertices);
    WriteFrame(options, *solver, in.body, f, posed);
  }
}

void Summarize(DrapeSimulationSummary* summary) {
  summary->frames = static_cast<int>(summary->records.size());
  const double n = static_cast<double>(summary->frames);
  int failed = 0, unconverged = 0;
  for (const DrapeFrameSummary& r : summary->records) {
    summary->mean_time_s += r.time_s / n;
    summary->max_time_s = std::max(summary->max_time_s, r.time_s);
    summary->mean_inside_percent += r.inside_percent / n;
    summary->max_inside_percent = std::max(summary->max_inside_percent, r.inside_percent);
    summary->mean_edge_strain_percent += r.edge_strain_percent / n;
    summary->max_edge_strain_percent = std::max(summary->max_edge_strain_percent, r.edge_strain_percent);
    summary->mean_area_change_percent += r.area_change_percent / n;
    summary->all_finite = summary->all_finite && r.finite;
    failed += r.termination_type == TerminationType::kFailure ? 1 : 0;
    unconverged += r.termination_type == TerminationType::kNoConvergence ? 1 : 0;
  }
  if (failed > 0) {
    summary->termination_type = TerminationType::kFailure;
    summary->message = std::to_string(failed) + " of " + std::to_string(summary->frames) +
                       " frames were not finite and kept the previous state";
    summary->warnings.push_back("the solver produced non-finite values; those frames kept the previous state");
  } else if (unconverged > 0) {
    summary->termination_type = TerminationType::kNoConvergence;
    summary->message = "the iteration budget ran out on " + std::to_string(unconverged) + " of " +
                       std::to_string(summary->frames) + " frames (a fixed cost per frame, by design)";
  }
}

nlohmann::json FramesJson(const std::vector<DrapeFrameSummary>& records) {
  nlohmann::json frames = nlohmann::json::array();
  for (const DrapeFrameSummary& r : records) {
    frames.push_back({{"frame", r.frame},
                      {"termination", TerminationTypeToString(r.termination_type)},
                      {"time_s", r.time_s},
                      {"inside_percent", r.inside_percent},
                      {"inside_nearest_percent", r.inside_nearest_percent},
                      {"inside_area_percent", r.inside_area_percent},
                      {"edge_strain_percent", r.edge_strain_percent},
                      {"edge_strain_unprojected_percent", r.edge_strain_unprojected_percent},
                      {"area_change_percent", r.area_change_percent},
                      {"min_distance_m", JsonNumber(r.min_distance)},
                      {"stretch_energy_J", JsonNumber(r.stretch_energy)},
                      {"bending_energy_J", JsonNumber(r.bending_energy)},
                      {"cost", JsonNumber(r.cost)}});
  }
  return frames;
}

void WriteOutputs(const DrapeSimulationOptions& options, const DrapeSimulationSummary& summary) {
  const fs::path out(options.out_dir);
  WriteFileAtomically((out / "frames.csv").string(), [&](std::ostream& csv) {
    csv << "frame,time_s,solve_time_s,iterations,passes,inside_percent,inside_nearest_percent,"
           "inside_unprojected_percent,inside_area_percent,min_distance_m,edge_strain_percent,area_change_percent,"
           "max_edge_strain_percent,stretch_energy_J,bending_energy_J,cost,finite,edge_strain_unprojected_percent\n";
    csv << std::setprecision(6);
    for (const DrapeFrameSummary& r : summary.records) {
      csv << r.frame << ',' << r.time_s << ',' << r.solve_time_s << ',' << r.iterations << ',' << r.passes << ','
          << r.inside_percent << ',' << r.inside_nearest_percent << ',' << r.inside_unprojected_percent << ','
          << r.inside_area_percent << ',' << r.min_distance << ',' << r.edge_strain_percent << ','
          << r.area_change_percent << ',' << r.max_edge_strain_percent << ',' << r.stretch_energy << ','
          << r.bending_energy << ',' << r.cost << ',' << (r.finite ? 1 : 0) << ',' << r.edge_strain_unprojected_percent
          << '\n';
    }
  });
  const DrapePhysicsOptions& physics = options.solver.physics;
  const DrapingWeights& w = physics.weights;
  nlohmann::json j;
  j["body"] = options.body_dir.empty() ? "procedural" : options.body_dir;
  j["shape"] = options.shape.ToString();
  j["garment"] = options.garment_path;
  j["drape"] = options.model_path.empty() ? "reference" : "network";
  if (!options.model_path.empty()) {
    j["model"] = options.model_path;
    j["refine_iterations"] = options.refine_iterations;
    j["warp_sweeps"] = options.warp_sweeps;
    j["relax_passes"] = options.refine_iterations > 0 || options.warp_sweeps > 0 ? 0 : options.relax_passes;
    if (options.warp_sweeps > 0) {
      j["warp_translations"] = options.warp_translations;
      j["warp_carry"] = options.warp_carry;
    }
  }
  j["motion"] = options.motion_path;
  j["fps"] = physics.fps;
  j["first_frame"] = options.first_frame;
  j["lead_in_frames"] = options.lead_in_frames;
  j["project_offset_m"] = options.project_offset;
  j["strain_limit_passes"] = options.project_offset >= 0.0 ? options.strain_limit_passes : 0;
  j["garment_vertices"] = summary.garment_vertices;
  j["garment_faces"] = summary.garment_faces;
  j["patches"] = summary.patches;
  j["fit_error_mean_m"] = summary.fit_error_mean;
  j["fit_error_max_m"] = summary.fit_error_max;
  j["frames"] = summary.frames;
  j["termination"] = TerminationTypeToString(summary.termination_type);
  j["message"] = summary.message;
  j["weights"] = {{"k_b", w.boundary},
                  {"k_mi", w.inextensibility},
                  {"k_g", w.gravity},
                  {"k_c", w.collision},
                  {"k_i", w.inertia},
                  {"eps_m", w.collision_margin},
                  {"margin_floor_m", physics.margin_floor},
                  {"kappa_N_per_m", physics.collision_stiffness},
                  {"boundary_base", physics.boundary_base},
                  {"stretch_base", physics.stretch_base},
                  {"k_ext_max_depth", physics.k_ext.max_depth},
                  {"k_ext_max_epoch", physics.k_ext.max_epoch}};
  j["summary"] = {{"mean_time_per_frame_s", summary.mean_time_s},
                  {"max_time_per_frame_s", summary.max_time_s},
                  {"mean_inside_percent", summary.mean_inside_percent},
                  {"max_inside_percent", summary.max_inside_percent},
                  {"mean_edge_strain_percent", summary.mean_edge_strain_percent},
                  {"max_edge_strain_percent", summary.max_edge_strain_percent},
                  {"mean_area_change_percent", summary.mean_area_change_percent},
                  {"all_finite", summary.all_finite},
                  {"total_time_s", summary.total_time_s}};
  j["per_frame"] = FramesJson(summary.records);
  j["warnings"] = summary.warnings;
  j["notes"] = summary.notes;
  WriteFileAtomically((out / "metrics.json").string(), [&](std::ostream& stream) { stream << j.dump(2) << '\n'; });
}

}  // namespace

std::string DrapeSimulationOptions::Validate() const {
  if (garment_path.empty()) return "a garment is needed";
  if (motion_path.empty()) return "a motion clip is needed";
  if (out_dir.empty()) return "an output folder is needed";
  if (!(bvh_units_to_metres > 0.0)) return "bvh_units_to_metres must be positive";
  if (first_frame < 0) return "first_frame must be >= 0";
  if (num_frames == 0 || num_frames < -1) return "num_frames must be positive (or -1 for all)";
  if (refine_iterations < 0) return "refine_iterations must be >= 0";
  if (warp_sweeps < 0) return "warp_sweeps must be >= 0";
  if (relax_passes < 0) return "relax_passes must be >= 0";
  if (warp_sweeps > 0 && model_path.empty()) return "warp_sweeps needs a model";
  if (warp_sweeps > 0 && refine_iterations > 0) return "warp_sweeps and refine_iterations do not go together";
  if (!(warp_carry >= 0.0 && warp_carry <= 1.0)) return "warp_carry must be in [0, 1]";
  if (strain_limit_passes < 0) return "strain_limit_passes must be >= 0";
  if (lead_in_frames < 0 || render_every < 0) return "lead_in_frames and render_every must be >= 0";
  if (render_height < 32) return "render_height must be >= 32";
  const std::string shape_problem = shape.Validate();
  if (!shape_problem.empty()) return "shape: " + shape_problem;
  if (body_dir.empty() && !shape.IsNeutral()) return "a shape needs the MakeHuman body (body_dir)";
  const std::string problem = solver.Validate();
  if (!problem.empty()) return "solver: " + problem;
  return {};
}

std::string DrapeSimulationSummary::BriefReport() const {
  char line[512];
  std::snprintf(line, sizeof(line),
                "%s: %d frames, %d vertices in %d patches: %.1f ms per frame (max %.1f), epsilon_c %.2f%% (max "
                "%.2f%%), epsilon_e %.2f%% (worst frame %.2f%%), epsilon_a %.2f%%",
                TerminationTypeToString(termination_type), frames, garment_vertices, patches, 1e3 * mean_time_s,
                1e3 * max_time_s, mean_inside_percent, max_inside_percent, mean_edge_strain_percent,
                max_edge_strain_percent, mean_area_change_percent);
  return line;
}

DrapeSimulationSummary RunDrapeSimulation(const DrapeSimulationOptions& options) {
  const auto start = Clock::now();
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw DrapeInputError("onefit simulate: " + problem, ErrorKind::kInvalidArgument);
  }
  const DrapeInputs inputs = LoadInputs(options);
  SkinWeights weights;
  DrapeSimulationOptions solver_options = options;
  if (!options.model_path.empty() && options.refine_iterations > 0) {
    solver_options.solver.solve.max_iterations = options.refine_iterations;
    solver_options.solver.solve.max_passes = 1;
  }
  OneFitModel model;
  std::vector<std::string> notes;
  if (!options.model_path.empty()) {
    model = LoadOneFitModel(options.model_path);
    // The solver lays out the patch parameters as the network predicts them.
    PatchLikeModel(model, &solver_options.solver);
    solver_options.skin = model.skin;
    if (options.warp_sweeps > 0 && options.collision_from_model && model.loss_collision.recorded) {
      DrapePhysicsOptions& physics = solver_options.solver.physics;
      physics.weights.collision = model.loss_collision.weight;
      physics.weights.collision_margin = model.loss_collision.margin;
      physics.margin_floor = model.loss_collision.margin_floor;
      std::ostringstream note;
      note << "warps re-solved under the model's training collision settings: k_c " << physics.weights.collision
           << ", eps " << physics.weights.collision_margin << " m, margin floor " << physics.margin_floor << " m";
      notes.push_back(note.str());
    }
    if (options.warp_sweeps > 0 && model.network.warp_order() < 0) {
      throw DrapeInputError("onefit: " + options.model_path + " has no warp head: its warps cannot be re-solved",
                            ErrorKind::kInvalidArgument);
    }
    if (model.network.warp_order() >= 0 && !options.solver.slide.enabled) {
      throw DrapeInputError("onefit: " + options.model_path + " predicts slides (a warp head); slides cannot be off",
                            ErrorKind::kInvalidArgument);
    }
  }
  const std::unique_ptr<DrapeSolver> solver = CreateSolver(solver_options, inputs, &weights);
  std::unique_ptr<OneFitDraper> draper;
  if (!options.model_path.empty())
    draper = std::make_unique<OneFitDraper>(model, *solver, weights, inputs.body.skeleton, &inputs.body);
  DrapeSimulationSummary summary;
  summary.notes = std::move(notes);
  DescribeGarment(inputs, *solver, &summary);
  CreateOutputFolders(options);
  WriteRestGarment(options, *solver);
  if (draper) {
    RunNetworkFrames(options, inputs, *draper, solver.get(), &summary);
  } else {
    RunFrames(options, inputs, solver.get(), &summary);
  }
  Summarize(&summary);
  summary.total_time_s = Seconds(start);
  // The metrics record the physics the drape ran with.
  DrapeSimulationOptions recorded = options;
  recorded.solver.physics = solver_options.solver.physics;
  WriteOutputs(recorded, summary);
  return summary;
}

}  // namespace polyfit
