#include "sft/solver/polysft.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <memory>

#include <ceres/ceres.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "cost_functions/compressed_cost.h"
#include "polyfit/mesh/mesh_io.h"
#include "polyfit/mesh/mesh_topology.h"
#include "sft/scene/sft_metrics.h"
#include "polyfit/util/parallel_for.h"
#include "sft/solver/frame_costs.h"

namespace polyfit {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since) { return std::chrono::duration<double>(Clock::now() - since).count(); }

// One frame's images at every pyramid level (coarsest first).
struct FrameData {
  SftFrame frame;
  std::vector<cv::Mat> images, masks;
  bool mask_empty = false;
  // The parameters (JetDeformationModel layout).
  std::vector<double> theta;
};

// Stops a level once `patience` iterations in a row improved the cost by
// less than the tolerance, and records the trace.
class WindowCallback : public ceres::IterationCallback {
 public:
  WindowCallback(const PolySftOptions& options, std::vector<SftIterationSummary>* trace, SftIterationSummary row,
                 Clock::time_point start, std::function<double()> e3d)
      : options_(options), trace_(trace), row_(row), start_(start), e3d_(std::move(e3d)) {}

  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    SftIterationSummary row = row_;
    row.iteration = iterations_++;
    row.time_s = Seconds(start_);
    row.cost = s.cost;
    if (e3d_) row.e3d = e3d_();
    trace_->push_back(row);
    if (s.iteration > 0) {
      const double improvement = (last_cost_ - s.cost) / std::max(last_cost_, 1e-300);
      stalled_ = improvement < options_.improvement_tolerance ? stalled_ + 1 : 0;
    }
    last_cost_ = s.cost;
    return stalled_ >= options_.patience ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
  }
  int iterations() const { return iterations_; }

 private:
  const PolySftOptions& options_;
  std::vector<SftIterationSummary>* trace_;
  SftIterationSummary row_;
  Clock::time_point start_;
  std::function<double()> e3d_;
  double last_cost_ = 0.0;
  int stalled_ = 0;
  int iterations_ = 0;
};

// Pixels that can matter: the projected mesh and the mask, with a margin.
cv::Rect RegionOfInterest(const ScreenMesh& screen, const cv::Mat& mask, int width, int height, double margin) {
  double min_x = 1e300, min_y = 1e300, max_x = -1e300, max_y = -1e300;
  for (Eigen::Index i = 0; i < screen.pixels.cols(); ++i) {
    min_x = std::min(min_x, screen.pixels(0, i));
    max_x = std::max(max_x, screen.pixels(0, i));
    min_y = std::min(min_y, screen.pixels(1, i));
    max_y = std::max(max_y, screen.pixels(1, i));
  }
  const double pad = margin + 0.1 * std::max(max_x - min_x, max_y - min_y);
  cv::Rect box(static_cast<int>(std::floor(min_x - pad)), static_cast<int>(std::floor(min_y - pad)),
               static_cast<int>(std::ceil(max_x - min_x + 2 * pad)) + 1,
               static_cast<int>(std::ceil(max_y - min_y + 2 * pad)) + 1);
  if (!mask.empty()) {
    cv::Mat bytes;
    mask.convertTo(bytes, CV_8U, 255.0);
    const cv::Rect mask_box = cv::boundingRect(bytes);
    if (mask_box.area() > 0) box |= mask_box;
  }
  return box & cv::Rect(0, 0, width, height);
}

double Mean(const std::vector<SftFrameSummary>& frames, double SftFrameSummary::*field) {
  double sum = 0.0;
  int count = 0;
  for (const SftFrameSummary& f : frames) {
    if (std::isfinite(f.*field)) {
      sum += f.*field;
      ++count;
    }
  }
  return count > 0 ? sum / count : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

std::string PolySftOptions::Validate() const {
  if (std::string p = deformation.Validate(); !p.empty()) return "deformation: " + p;
  if (std::string p = rasterizer.Validate(); !p.empty()) return "rasterizer: " + p;
  if (window_size < 1) return "window_size must be >= 1";
  if (pyramid_levels < 1 || pyramid_levels > 6) return "pyramid_levels must be in [1, 6]";
  if (max_image_width < 0) return "max_image_width must be >= 0";
  if (max_iterations_per_level < 1) return "max_iterations_per_level must be >= 1";
  if (patience < 1) return "patience must be >= 1";
  for (double w : {photometric_weight, silhouette_weight, inextensibility_weight, temporal_weight}) {
    if (!(w >= 0.0) || !std::isfinite(w)) return "term weights must be finite and >= 0";
  }
  if (!(robust_scale > 0.0)) return "robust_scale must be > 0";
  if (max_frames < 0) return "max_frames must be >= 0";
  return {};
}

PolySftSummary SolvePolySft(const PolySftOptions& options, const SftScene& scene, const SftFrameCallback& on_frame) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw std::invalid_argument("PolySftOptions: " + problem);
  }
  const auto start = Clock::now();
  PolySftSummary summary;
  const Eigen::Matrix2Xd vertex_texcoords = VertexTexcoords(
      scene.template_mesh.faces, scene.template_mesh.corner_texcoords, scene.template_mesh.num_vertices());
  const JetDeformationModel model(options.deformation, scene.template_mesh.vertices, &vertex_texcoords);
  const int P = model.num_parameters();
  const int num_frames =
      options.max_frames > 0 ? std::min(options.max_frames, scene.frame_count) : scene.frame_count;
  const int levels = options.pyramid_levels;
  const bool use_masks = scene.has_masks() && options.silhouette_weight > 0.0;
  const bool use_temporal = num_frames > 1 && options.temporal_weight > 0.0;
  const bool use_photometric = options.photometric_weight > 0.0;
  const bool use_inextensibility = options.inextensibility_weight > 0.0;
  if (use_photometric) summary.terms.emplace_back("photometric", options.photometric_weight);
  if (use_masks) summary.terms.emplace_back("silhouette", options.silhouette_weight);
  if (use_inextensibility) summary.terms.emplace_back("inextensibility", options.inextensibility_weight);
  if (use_temporal) summary.terms.emplace_back("temporal", options.temporal_weight);
  {
    // Data terms are normalised to about 1 per unit weight: the regularisers
    // far above them decide the shape alone.
    const double data = std::max(use_photometric ? options.photometric_weight : 0.0,
                                 use_masks ? options.silhouette_weight : 0.0);
    const double stiffest = std::max(use_inextensibility ? options.inextensibility_weight : 0.0,
                                     use_temporal ? options.temporal_weight : 0.0);
    if (data > 0.0 && stiffest >= 1e4 * data) {
      summary.warnings.emplace_back("stiff weights (a regulariser at " + std::to_string(stiffest / data) +
                                    " times the data terms): the images barely move the surface and results may be "
                                    "unreliable");
    }
  }
  if (!use_photometric && !use_masks) {
    throw std::invalid_argument("PolySftOptions: no data term (photometric weight 0 and no masks)");
  }
  summary.deformation = model.texture_space() ? "texture_space" : "patch_jet";
  if (model.texture_space() && !options.deformation.texture_space) {
    summary.warnings.emplace_back(
        "the template is not a height field over one plane: it is deformed by a texture-space field instead of "
        "its patch's jet");
  }
  if (model.template_rms_error() > 1e-3 * BoundingBoxDiagonal(scene.template_mesh.vertices)) {
    char buffer[160];
    std::snprintf(buffer, sizeof(buffer), "the template's jet deviates from it by %.2e m RMS",
                  model.template_rms_error());
    summary.warnings.emplace_back(buffer);
  }

  // Template data shared by every frame.
  ScreenMesh mesh_template;
  mesh_template.faces = scene.template_mesh.faces;
  mesh_template.corner_texcoords = scene.template_mesh.corner_texcoords;
  mesh_template.boundary_edges = MeshBoundaryEdgeFlags(scene.template_mesh.faces);
  const double min_depth = scene.template_mesh.vertices.row(2).minCoeff();
  const double max_depth = scene.template_mesh.vertices.row(2).maxCoeff();
  const double size = BoundingBoxDiagonal(scene.template_mesh.vertices);
  mesh_template.depth_near = std::max(1e-3, min_depth - size);
  mesh_template.depth_far = max_depth + size;
  std::vector<Eigen::Vector2i> edges;
  std::vector<double> rest_lengths;
  {
    const std::vector<std::pair<std::uint64_t, int>> sorted = SortedEdgeCorners(scene.template_mesh);
    for (size_t k = 0; k < sorted.size(); ++k) {
      if (k > 0 && sorted[k].first == sorted[k - 1].first) continue;
      const int a = static_cast<int>(sorted[k].first >> 32), b = static_cast<int>(sorted[k].first & 0xffffffffu);
      const double length = (scene.template_mesh.vertices.col(a) - scene.template_mesh.vertices.col(b)).norm();
      if (length > 0.0) {
        edges.emplace_back(a, b);
        rest_lengths.push_back(length);
      }
    }
  }
  // Pixels the template covers at full size: normalises the image terms.
  double template_pixels = 0.0;
  {
    ScreenMesh screen = mesh_template;
    ProjectVertices(scene.camera, scene.template_mesh.vertices, &screen, nullptr);
    for (int f = 0; f < screen.faces.cols(); ++f) {
      const Eigen::Vector2d a = screen.pixels.col(screen.faces(0, f)), b = screen.pixels.col(screen.faces(1, f)),
                            c = screen.pixels.col(screen.faces(2, f));
      template_pixels += 0.5 * std::abs((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
    }
    template_pixels = std::max(template_pixels, 16.0);
  }
  {
    // Little texture: the photometric term cannot locate the surface.
    cv::Mat grey, dx, dy;
    cv::cvtColor(scene.texture, grey, cv::COLOR_RGB2GRAY);
    cv::Sobel(grey, dx, CV_32F, 1, 0);
    cv::Sobel(grey, dy, CV_32F, 0, 1);
    const double energy = cv::mean(dx.mul(dx) + dy.mul(dy))[0];
    if (energy < 1e-4) {
      summary.warnings.emplace_back("the texture has little detail: shape is constrained mostly by the " +
                                    std::string(use_masks ? "silhouettes" : "regularisers") +
                                    " and results may be unreliable");
    }
  }
  std::vector<PinholeCamera> cameras(levels);
  const double top_scale = options.max_image_width > 0 && options.max_image_width < scene.camera.width
                               ? static_cast<double>(options.max_image_width) / scene.camera.width
                               : 1.0;
  std::vector<double> level_scales(levels);
  for (int l = 0; l < levels; ++l) {
    level_scales[l] = top_scale * std::ldexp(1.0, -(levels - 1 - l));
    cameras[l] = scene.camera.Scaled(level_scales[l]);
  }

  // One rasterizer per level, each with the texture prefiltered to about one
  // texel per image pixel: sampled at a single point per pixel, a finer
  // texture aliases, and its colours match neither the (area-averaged)
  // frames nor their neighbours, which ruins the photometric gradients.
  std::vector<std::unique_ptr<SoftRasterizer>> rasterizers, serial_rasterizers;
  {
    ScreenMesh screen = mesh_template;
    ProjectVertices(scene.camera, scene.template_mesh.vertices, &screen, nullptr);
    // Pixels per unit of texture coordinate, from the template's edges.
    double pixels_per_uv = 0.0;
    for (int f = 0; f < screen.faces.cols(); ++f) {
      for (int c = 0; c < 3; ++c) {
        const double duv = (scene.template_mesh.corner_texcoords.col(3 * f + c) -
                            scene.template_mesh.corner_texcoords.col(3 * f + (c + 1) % 3))
                               .norm();
        const double dpx = (screen.pixels.col(screen.faces(c, f)) - screen.pixels.col(screen.faces((c + 1) % 3, f))).norm();
        if (duv > 0.0) pixels_per_uv = std::max(pixels_per_uv, dpx / duv);
      }
    }
    for (int l = 0; l < levels; ++l) {
      const double level_scale = level_scales[l];
      const double factor = std::min(1.0, level_scale * pixels_per_uv / std::max(scene.texture.cols, scene.texture.rows));
      cv::Mat texture = scene.texture;
      if (factor < 1.0) {
        cv::resize(scene.texture, texture,
                   cv::Size(std::max(2, static_cast<int>(std::lround(scene.texture.cols * factor))),
                            std::max(2, static_cast<int>(std::lround(scene.texture.rows * factor)))),
                   0, 0, cv::INTER_AREA);
      }
      rasterizers.push_back(std::make_unique<SoftRasterizer>(options.rasterizer, texture));
      SoftRasterizerOptions serial = options.rasterizer;
      serial.num_threads = 1;
      serial_rasterizers.push_back(std::make_unique<SoftRasterizer>(serial, texture));
    }
  }
  Eigen::Matrix3Xd template_now;
  {
    std::vector<double> zero(P, 0.0);
    model.Evaluate(zero.data(), &template_now);
  }
  if (scene.ground_truth_kind == GroundTruthKind::kVertices) summary.template_e3d = summary.template_rmse_mm = 0.0;

  std::deque<std::unique_ptr<FrameData>> window;
  Eigen::Matrix3Xd previous_final;  // the frame before the window, once there is one
  bool has_previous_final = false;

  double first_cost = -1.0;
  auto finalize = [&](FrameData& data, double time_s, double cost, int iterations) {
    // A frame that fits far worse than the first has probably lost track.
    if (first_cost < 0.0) {
      first_cost = cost;
    } else if (cost > 4.0 * std::max(first_cost, 1e-12)) {
      char buffer[200];
      std::snprintf(buffer, sizeof(buffer),
                    "frame %d: cost %.3g is %.0f times the first frame's: tracking may be lost (motion too large "
                    "between frames?)",
                    data.frame.index, cost, cost / std::max(first_cost, 1e-12));
      summary.warnings.emplace_back(buffer);
    }
    SftFrameSummary result;
    result.index = data.frame.index;
    model.Evaluate(data.theta.data(), &result.vertices);
    result.time_s = time_s;
    result.cost = cost;
    result.iterations = iterations;
    if (scene.ground_truth_kind == GroundTruthKind::kVertices) {
      const Eigen::Matrix3Xd& gt = data.frame.ground_truth;
      result.e3d = ComputeE3D(result.vertices, gt);
      result.normal_error_deg = ComputeNormalErrorDeg(scene.template_mesh.faces, result.vertices, gt);
      result.rmse_mm = ComputeRmseMm(result.vertices, gt);
      summary.template_e3d += ComputeE3D(scene.template_mesh.vertices, gt);
      summary.template_rmse_mm += ComputeRmseMm(scene.template_mesh.vertices, gt);
    } else if (scene.ground_truth_kind == GroundTruthKind::kPoints) {
      TriangleMesh surface;
      surface.vertices = result.vertices;
      surface.faces = scene.template_mesh.faces;
      result.chamfer_1e4 = ComputePointChamfer1e4(surface, data.frame.ground_truth);
    }
    previous_final = result.vertices;
    has_previous_final = true;
    summary.frames.push_back(result);
    if (on_frame) on_frame(summary.frames.back());
  };

  std::vector<double> frame_time(num_frames, 0.0), frame_cost(num_frames, 0.0);
  std::vector<int> frame_iterations(num_frames, 0);
  for (int t = 0; t < num_frames; ++t) {
    const auto frame_start = Clock::now();
    // Load the new frame and build its pyramid.
    auto data = std::make_unique<FrameData>();
    data->frame = LoadFrame(scene, t);
    data->images.resize(levels);
    data->masks.resize(levels);
    for (int l = 0; l < levels; ++l) {
      const cv::Size size(cameras[l].width, cameras[l].height);
      if (level_scales[l] == 1.0) {
        data->images[l] = data->frame.image;
        data->masks[l] = data->frame.mask;
      } else {
        cv::resize(data->frame.image, data->images[l], size, 0, 0, cv::INTER_AREA);
        if (!data->frame.mask.empty()) cv::resize(data->frame.mask, data->masks[l], size, 0, 0, cv::INTER_AREA);
      }
    }
    if (!data->frame.mask.empty() && cv::countNonZero(data->frame.mask) == 0) {
      data->mask_empty = true;
      summary.warnings.emplace_back("frame " + std::to_string(data->frame.index) +
                                    ": the mask is empty (object not visible?): its image terms are skipped");
    }
    data->theta = window.empty() ? std::vector<double>(P, 0.0) : window.back()->theta;
    window.push_back(std::move(data));

    // Solve the window, coarse to fine.
    double cost = 0.0;
    int iterations = 0;
    for (int l = 0; l < levels; ++l) {
      ceres::Problem::Options problem_options;
      problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
      ceres::Problem problem(problem_options);
      const double level_pixels = template_pixels * level_scales[l] * level_scales[l];
      for (size_t k = 0; k < window.size(); ++k) {
        FrameData& frame = *window[k];
        double* theta = frame.theta.data();
        problem.AddParameterBlock(theta, P);
        if (!frame.mask_empty && (use_photometric || use_masks)) {
          RenderCost::Data d;
          d.model = &model;
          d.rasterizer = window.size() > 1 ? serial_rasterizers[l].get() : rasterizers[l].get();
          d.mesh = mesh_template;
          d.camera = cameras[l];
          d.image = frame.images[l];
          if (use_masks) d.mask = frame.masks[l];
          Eigen::Matrix3Xd vertices;
          model.Evaluate(theta, &vertices);
          ScreenMesh screen = mesh_template;
          if (!ProjectVertices(cameras[l], vertices, &screen, nullptr)) {
            throw std::runtime_error("frame " + std::to_string(frame.frame.index) +
                                     ": the surface went behind the camera");
          }
          d.roi = RegionOfInterest(screen, d.mask, cameras[l].width, cameras[l].height,
                                   4.0 + std::sqrt(options.rasterizer.cutoff * options.rasterizer.sigma));
          d.photometric_weight = use_photometric ? std::sqrt(options.photometric_weight / level_pixels) : 0.0;
          d.silhouette_weight = std::sqrt(options.silhouette_weight / level_pixels);
          d.robust_loss = options.robust_loss;
          d.robust_scale = options.robust_scale * d.photometric_weight;
          if (d.roi.area() > 0) problem.AddResidualBlock(new CompressedRenderCost(std::move(d)), nullptr, theta);
        }
        if (use_inextensibility && !edges.empty()) {
          problem.AddResidualBlock(
              new CompressedCost(new InextensibilityCost(&model, edges, rest_lengths,
                                                         std::sqrt(options.inextensibility_weight / edges.size()))),
              nullptr, theta);
        }
        if (use_temporal) {
          const double w = std::sqrt(options.temporal_weight / model.num_vertices());
          if (k > 0) {
            problem.AddResidualBlock(new CompressedCost(new TemporalCost(&model, size, w)), nullptr, theta,
                                     window[k - 1]->theta.data());
          } else if (has_previous_final) {
            problem.AddResidualBlock(new CompressedCost(new TemporalCost(&model, size, w, &previous_final)), nullptr,
                                     theta);
          }
        }
      }
      ceres::Solver::Options solver;
      solver.minimizer_type = ceres::TRUST_REGION;
      solver.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
      // Every term is compressed to (parameters + 1) rows: a small dense system.
      solver.linear_solver_type = ceres::DENSE_QR;
      solver.max_num_iterations = options.max_iterations_per_level;
      // The window's frames are evaluated side by side; a lone frame's pixels
      // are split over the threads by the rasterizer instead.
      solver.num_threads = window.size() > 1 ? ResolveNumThreads(options.num_threads) : 1;
      solver.logging_type = ceres::SILENT;
      solver.update_state_every_iteration = true;
      SftIterationSummary row;
      row.frame = window.back()->frame.index;
      row.window = window.front()->frame.index;
      std::function<double()> e3d;
      if (scene.ground_truth_kind == GroundTruthKind::kVertices) {
        FrameData* newest = window.back().get();
        e3d = [&model, newest] {
          Eigen::Matrix3Xd v;
          model.Evaluate(newest->theta.data(), &v);
          return ComputeE3D(v, newest->frame.ground_truth);
        };
      }
      WindowCallback callback(options, &summary.trace, row, start, e3d);
      solver.callbacks.push_back(&callback);
      ceres::Solver::Summary result;
      ceres::Solve(solver, &problem, &result);
      // Per frame of the window, so that windows of different sizes compare.
      cost = result.final_cost / window.size();
      iterations += callback.iterations();
      for (const auto& frame : window) {
        for (double v : frame->theta) {
          if (!std::isfinite(v)) throw std::runtime_error("the solve diverged (non-finite parameters)");
        }
      }
    }
    frame_time[t] = Seconds(frame_start);
    frame_cost[t] = cost;
    frame_iterations[t] = iterations;
    if (static_cast<int>(window.size()) >= options.window_size) {
      const int oldest = window.front()->frame.index - scene.first_frame;
      finalize(*window.front(), frame_time[oldest], frame_cost[oldest], frame_iterations[oldest]);
      window.pop_front();
    }
  }
  while (!window.empty()) {
    const int oldest = window.front()->frame.index - scene.first_frame;
    finalize(*window.front(), frame_time[oldest], frame_cost[oldest], frame_iterations[oldest]);
    window.pop_front();
  }
  summary.total_time_s = Seconds(start);
  summary.mean_time_per_frame_s = summary.frames.empty() ? 0.0 : summary.total_time_s / summary.frames.size();
  summary.mean_e3d = Mean(summary.frames, &SftFrameSummary::e3d);
  summary.mean_normal_error_deg = Mean(summary.frames, &SftFrameSummary::normal_error_deg);
  summary.mean_rmse_mm = Mean(summary.frames, &SftFrameSummary::rmse_mm);
  summary.mean_chamfer_1e4 = Mean(summary.frames, &SftFrameSummary::chamfer_1e4);
  if (std::isfinite(summary.template_e3d) && !summary.frames.empty()) {
    summary.template_e3d /= summary.frames.size();
    summary.template_rmse_mm /= summary.frames.size();
  }
  return summary;
}

void WriteSftOutputs(const std::string& directory, const SftScene& scene, const PolySftOptions& options,
                     const PolySftSummary& summary) {
  namespace fs = std::filesystem;
  fs::create_directories(fs::path(directory) / "meshes");
  TriangleMesh mesh;
  mesh.faces = scene.template_mesh.faces;
  for (const SftFrameSummary& frame : summary.frames) {
    char name[32];
    std::snprintf(name, sizeof(name), "%06d.ply", frame.index);
    mesh.vertices = frame.vertices;
    WritePly((fs::path(directory) / "meshes" / name).string(), mesh);
  }
  auto number = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
  {
    std::ofstream trace(fs::path(directory) / "trace.csv");
    trace << "frame,window,iteration,time_s,cost,e3d\n";
    for (const SftIterationSummary& r : summary.trace) {
      trace << r.frame << ',' << r.window << ',' << r.iteration << ',' << r.time_s << ',' << r.cost << ',';
      if (std::isfinite(r.e3d)) trace << r.e3d;
      trace << '\n';
    }
    if (!trace) throw std::runtime_error((fs::path(directory) / "trace.csv").string() + ": cannot be written");
  }
  nlohmann::json frames = nlohmann::json::array();
  for (const SftFrameSummary& f : summary.frames) {
    frames.push_back({{"frame", f.index},
                      {"time_s", f.time_s},
                      {"cost", f.cost},
                      {"iterations", f.iterations},
                      {"e3d", number(f.e3d)},
                      {"e_n_deg", number(f.normal_error_deg)},
                      {"rmse_mm", number(f.rmse_mm)},
                      {"chamfer_1e4", number(f.chamfer_1e4)}});
  }
  nlohmann::json terms = nlohmann::json::object();
  for (const auto& [name, weight] : summary.terms) terms[name] = weight;
  const nlohmann::json metrics = {
      {"scene", scene.directory},
      {"frames", frames},
      {"mean", {{"e3d", number(summary.mean_e3d)},
                {"e_n_deg", number(summary.mean_normal_error_deg)},
                {"rmse_mm", number(summary.mean_rmse_mm)},
                {"chamfer_1e4", number(summary.mean_chamfer_1e4)},
                {"time_per_frame_s", summary.mean_time_per_frame_s}}},
      {"baseline_template_still", {{"e3d", number(summary.template_e3d)}, {"rmse_mm", number(summary.template_rmse_mm)}}},
      {"total_time_s", summary.total_time_s},
      {"active_terms", terms},
      {"warnings", summary.warnings},
      {"settings",
       {{"jet_order", options.deformation.jet_order},
        {"deformation", summary.deformation},
        {"uv_displacement", options.deformation.uv_displacement == UvDisplacement::kCompactField ? "compact" : "per_vertex"},
        {"uv_order", options.deformation.uv_order},
        {"window_size", options.window_size},
        {"pyramid_levels", options.pyramid_levels},
        {"max_image_width", options.max_image_width},
        {"max_iterations_per_level", options.max_iterations_per_level},
        {"patience", options.patience},
        {"sigma", options.rasterizer.sigma},
        {"gamma", options.rasterizer.gamma},
        {"robust_loss", options.robust_loss == RobustLoss::kNone    ? "none"
                        : options.robust_loss == RobustLoss::kHuber ? "huber"
                                                                    : "cauchy"}}}};
  std::ofstream out(fs::path(directory) / "metrics.json");
  out << metrics.dump(2) << '\n';
  if (!out) throw std::runtime_error((fs::path(directory) / "metrics.json").string() + ": cannot be written");
}

}  // namespace polyfit
