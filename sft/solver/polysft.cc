#include "sft/solver/polysft.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>

#include <ceres/ceres.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "cost_functions/compressed_cost.h"
#include "cost_functions/gravity_inertia_residuals.h"
#include "polyfit/eval/mesh_metrics.h"
#include "polyfit/mesh/hinge_rest.h"
#include "polyfit/mesh/mesh_io.h"
#include "polyfit/mesh/per_face_normals.h"
#include "polyfit/mesh/unique_edges.h"
#include "polyfit/util/atomic_file.h"
#include "polyfit/util/json_number.h"
#include "polyfit/util/parallel_for.h"
#include "sft/render/background_plate.h"
#include "sft/render/mask_distance.h"
#include "sft/render/vertex_visibility.h"
#include "sft/scene/sft_metrics.h"
#include "sft/solver/brightness.h"
#include "sft/solver/flow_matches.h"
#include "sft/solver/fold_mirror.h"
#include "sft/solver/frame_costs.h"
#include "sft/solver/match_pose.h"
#include "sft/solver/polysft_settings.h"
#include "sft/solver/silhouette_band.h"

namespace polyfit {
namespace {

using Clock = std::chrono::steady_clock;

// A vertex is hidden by its own surface where a nearer part lies this far
// (times the template's size) in front of it: a fold's layers, not a
// curved sheet's neighbouring triangles (PolySftOptions::
// occluded_temporal_weight).
constexpr double kOccludedDepthTolerance = 0.01;

double Seconds(Clock::time_point since) { return std::chrono::duration<double>(Clock::now() - since).count(); }

// One frame's images at every pyramid level (coarsest first).
struct FrameData {
  SftFrame frame;
  // The render buffers of the frame's image terms, one at a time (each
  // level's and window's problem in turn).
  SoftRenderOutput render_scratch;
  // The silhouette's bounds per level (MaskBounds; equal without a band).
  std::vector<cv::Mat> images, masks, masks_upper;
  // The distance outside the mask's outline at the coarsest level
  // (OutsideDistance; with the silhouette's reach only).
  cv::Mat outside;
  bool mask_empty = false;
  // The frame's lighting, last matched (PolySftOptions::match_brightness),
  // and per level the frame mapped to the texture's lighting: matched in
  // the first window the frame enters, kept for the later ones (where its
  // estimate barely moves) at a third of the renders.
  Brightness brightness;
  std::vector<cv::Mat> compensated;
  // Per level, what lies behind the surface (BackgroundPlate: the mask's
  // region filled from around it), for levels composited over it
  // (Compositing::kOverBackground); empty elsewhere. Its brightness-
  // matched copy beside compensated (the match is per channel affine, and
  // so is the plate's fill).
  std::vector<cv::Mat> plates, compensated_plates;
  // Keypoint correspondences with the template (the finest level's
  // pixels; with PolySftOptions::feature_weight, or relocalize after a
  // frame that was not tracked), and the median
  // distance (full-size pixels) of the surface from them after the last
  // solve (NaN without them).
  std::vector<FeatureMatch> features;
  double feature_error = std::numeric_limits<double>::quiet_NaN();
  // Optical-flow correspondences from the frame before (the finest level's
  // pixels; with PolySftOptions::flow_start or flow_weight only).
  std::vector<FeatureMatch> flow;
  bool flow_started = false;  // its start is the flow's fit (flow_start)
  // The frame before was not tracked (after_lost), and whether the frame
  // was placed on its keypoints, as its start or in a re-solve
  // (relocalized; PolySftOptions::relocalize).
  bool after_lost = false;
  bool relocalized = false;
  // The parameters (JetDeformationModel layout), and where its first solve
  // started; whether that is not where the frame before ended (a motion
  // prediction, a flow or keypoint fit, the ground truth).
  std::vector<double> theta;
  std::vector<double> start;
  bool moved_start = false;
  // The atlas's patches when the frame was last solved, and the patch of
  // each vertex then.
  int patches = 1;
  std::vector<int> vertex_patches;
  // No level of its last window's solve reached max_iterations_per_level
  // (PolySftOptions::coarse_levels_newest_only).
  bool settled = false;
};

// Stops a level once `patience` iterations in a row improved the cost by
// less than the tolerance, and records the trace. A rejected step is no
// sign of convergence (the trust region shrinks and the next step is
// tried): it neither counts nor is compared against, and its row has the
// cost where the solve stays (Ceres reports the rejected candidate's).
class WindowCallback : public ceres::IterationCallback {
 public:
  WindowCallback(const PolySftOptions& options, std::vector<SftIterationSummary>* trace, SftIterationSummary row,
                 Clock::time_point start, std::function<double()> e3d)
      : options_(options), trace_(trace), row_(row), start_(start), e3d_(std::move(e3d)) {}

  // The solve stops after `cap` iterations (as Ceres' max_num_iterations
  // would: capped() says so) unless go_on(cost) says it may go on to
  // its max_num_iterations.
  void GoOnPast(int cap, std::function<bool(double cost)> go_on) {
    cap_ = cap;
    go_on_ = std::move(go_on);
  }

  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    SftIterationSummary row = row_;
    row.iteration = iterations_++;
    row.time_s = Seconds(start_);
    const bool rejected = s.iteration > 0 && !s.step_is_successful;
    row.cost = rejected ? last_cost_ : s.cost;
    if (e3d_) row.e3d = e3d_();
    trace_->push_back(row);
    if (!rejected) {
      if (s.iteration > 0) {
        const double improvement = (last_cost_ - s.cost) / std::max(last_cost_, 1e-300);
        stalled_ = improvement < options_.improvement_tolerance ? stalled_ + 1 : 0;
      }
      last_cost_ = s.cost;
      if (stalled_ >= options_.patience) return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
    }
    if (go_on_ && s.iteration == cap_ && !go_on_(last_cost_)) {
      capped_ = true;
      return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
    }
    return ceres::SOLVER_CONTINUE;
  }
  int iterations() const { return iterations_; }
  bool capped() const { return capped_; }

 private:
  const PolySftOptions& options_;
  std::vector<SftIterationSummary>* trace_;
  SftIterationSummary row_;
  Clock::time_point start_;
  std::function<double()> e3d_;
  double last_cost_ = 0.0;
  int stalled_ = 0;
  int iterations_ = 0;
  int cap_ = 0;
  std::function<bool(double)> go_on_;
  bool capped_ = false;
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

// Sparse normal equations for an atlas (its blocks couple only across
// seams), dense where no sparse library is built in.
ceres::LinearSolverType SparseSolver() {
  return ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE) ||
                 ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::EIGEN_SPARSE)
             ? ceres::SPARSE_NORMAL_CHOLESKY
             : ceres::DENSE_NORMAL_CHOLESKY;
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

int ChoosePyramidLevels(const PolySftOptions& options, int image_width) {
  if (options.pyramid_levels > 0) return options.pyramid_levels;
  const int finest = options.max_image_width > 0 ? std::min(options.max_image_width, image_width) : image_width;
  int levels = 3;
  while (levels < 6 && finest > 128 * (1 << (levels - 1))) ++levels;
  return levels;
}

std::string PolySftOptions::Validate() const {
  if (std::string p = deformation.Validate(); !p.empty()) return "deformation: " + p;
  if (std::string p = rasterizer.Validate(); !p.empty()) return "rasterizer: " + p;
  if (std::string p = atlas.Validate(); !p.empty()) return p;
  if (window_size < 1) return "window_size must be >= 1";
  if (pyramid_levels < 0 || pyramid_levels > 6) return "pyramid_levels must be in [1, 6], or 0 (chosen by width)";
  if (max_image_width < 0) return "max_image_width must be >= 0";
  if (max_iterations_per_level < 1) return "max_iterations_per_level must be >= 1";
  if (tracked_finest_iterations < 0) return "tracked_finest_iterations must be >= 0";
  if (patience < 1) return "patience must be >= 1";
  if (iterative_min_patches < 2) return "iterative_min_patches must be >= 2";
  if (!(iterative_eta > 0.0 && iterative_eta < 1.0)) return "iterative_eta must be in (0, 1)";
  const std::pair<const char*, double> weights[] = {{"photometric_weight", photometric_weight},
                                                     {"silhouette_weight", silhouette_weight},
                                                     {"silhouette_reach_weight", silhouette_reach_weight},
                                                     {"feature_weight", feature_weight},
                                                     {"flow_weight", flow_weight},
                                                     {"inextensibility_weight", inextensibility_weight},
                                                     {"bending_weight", bending_weight},
                                                     {"new_crease_bending_weight", new_crease_bending_weight},
                                                     {"temporal_weight", temporal_weight},
                                                     {"occluded_temporal_weight", occluded_temporal_weight}};
  for (const auto& [name, w] : weights) {
    if (!(w >= 0.0) || !std::isfinite(w)) return std::string(name) + " must be finite and >= 0";
  }
  if (!(inextensibility_robust_strain >= 0.0) || !std::isfinite(inextensibility_robust_strain)) {
    return "inextensibility_robust_strain must be finite and >= 0 (0: squared)";
  }
  if (!(occluded_velocity >= 0.0 && occluded_velocity <= 1.0)) return "occluded_velocity must be in [0, 1]";
  if (!(depth_softness >= 0.0) || !std::isfinite(depth_softness)) {
    return "depth_softness must be finite and >= 0 (m; 0: rasterizer.gamma as given)";
  }
  if (!(finest_sigma >= 0.0) || !std::isfinite(finest_sigma)) {
    return "finest_sigma must be finite and >= 0 (pixels squared; 0: rasterizer.sigma)";
  }
  if (temporal_order != 1 && temporal_order != 2) return "temporal_order must be 1 or 2";
  if (!(feature_huber_px > 0.0)) return "feature_huber_px must be > 0";
  if (!(feature_dead_zone_px >= 0.0)) return "feature_dead_zone_px must be >= 0";
  if (std::string p = features.Validate(); !p.empty()) return "features: " + p;
  if (!(robust_scale > 0.0)) return "robust_scale must be > 0";
  if (!(silhouette_band <= 100.0)) return "silhouette_band must be <= 100 px (negative: measured)";
  if (max_frames < 0) return "max_frames must be >= 0";
  if (!(new_crease_angle_deg > 0.0 && new_crease_angle_deg <= 180.0)) return "new_crease_angle_deg must be in (0, 180]";
  if (new_crease_span_frames < 1 || new_crease_span_frames > 30) return "new_crease_span_frames must be in [1, 30]";
  return {};
}

namespace {

// Where the image terms sit in a level's Ceres problem for one frame.
struct LevelData {
  PinholeCamera camera;
  double scale = 1.0;
  std::unique_ptr<SoftRasterizer> rasterizer;         // all threads: a lone frame
  std::unique_ptr<SoftRasterizer> serial_rasterizer;  // one thread: frames side by side
};

// SolvePolySft's phases over one sequence: set-up (terms, template data,
// pyramid, rasterizers), then per frame load, solve the window coarse to
// fine, and finalise the frame that leaves the window.
class PolySftController {
 public:
  PolySftController(const PolySftOptions& options, const SftScene& scene, const SftFrameCallback& on_frame)
      : options_(options),
        scene_(scene),
        on_frame_(on_frame),
        start_(Clock::now()),
        vertex_texcoords_(VertexTexcoords(scene.template_mesh.faces, scene.template_mesh.corner_texcoords,
                                          scene.template_mesh.num_vertices())),
        model_(options.deformation, scene.template_mesh.vertices, &vertex_texcoords_) {}

  PolySftSummary Run() {
    ChooseTerms();
    CheckTemplate();
    PrepareTemplateData();
    SplitInitialPatches();
    atlas_terms_ = GroupAtlasTerms(model_, edges_, rest_lengths_, Hinges());
    render_groups_ = MakePatchGroups(model_, scene_.template_mesh.faces);
    BuildPyramid();
    CreateRasterizers();
    const int num_frames =
        options_.max_frames > 0 ? std::min(options_.max_frames, scene_.frame_count) : scene_.frame_count;
    frame_time_.assign(num_frames, 0.0);
    frame_cost_.assign(num_frames, 0.0);
    frame_iterations_.assign(num_frames, 0);
    for (int t = 0; t < num_frames; ++t) {
      const auto frame_start = Clock::now();
      AddFrameToWindow(t);
      double cost = 0.0;
      int iterations = 0;
      if (!SolveWindow(&cost, &iterations)) break;
      frame_cost_[t] = cost;  // whether it is tracked, for RefineAtlas
      if (RefineAtlas(t) && !SolveWindow(&cost, &iterations)) break;
      // A hidden split leaves the surface where it was, and the hidden
      // child has no image to fit: the next frame's window solve frees it
      // (solving this window again cost table 3 a sixth of its time, for
      // no better errors: docs/benchmarks.md).
      SplitAlongOcclusion(t);
      RecoverLostFrame(t, &cost, &iterations);
      SecondOpinionOnNewCrease(t, &cost, &iterations);
      const bool misfit = FitsFarWorse(t, cost);
      const bool lost = misfit && !FoundByKeypoints(window_.back().get());
      if (misfit) KeypointsFromNowOn(t);
      frame_time_[t] = Seconds(frame_start);
      frame_cost_[t] = cost;
      if (!lost) tracked_costs_.push_back(cost);
      frame_iterations_[t] = iterations;
      if (static_cast<int>(window_.size()) >= options_.window_size) FinalizeOldestFrame();
    }
    if (summary_.termination_type != TerminationType::kFailure) {
      while (!window_.empty()) FinalizeOldestFrame();
    }
    Summarize();
    return std::move(summary_);
  }

 private:
  // Active terms and their weights: only what the scene supports.
  void ChooseTerms() {
    const PolySftOptions& o = options_;
    const int num_frames = o.max_frames > 0 ? std::min(o.max_frames, scene_.frame_count) : scene_.frame_count;
    use_masks_ = scene_.has_masks() && o.silhouette_weight > 0.0;
    summary_.silhouette_band_px = use_masks_ ? o.silhouette_band : 0.0;
    use_temporal_ = num_frames > 1 && o.temporal_weight > 0.0;
    use_photometric_ = o.photometric_weight > 0.0;
    use_inextensibility_ = o.inextensibility_weight > 0.0;
    if (use_photometric_) summary_.terms.emplace_back("photometric", o.photometric_weight);
    if (use_masks_) summary_.terms.emplace_back("silhouette", o.silhouette_weight);
    if (use_masks_ && o.silhouette_reach_weight > 0.0)
      summary_.terms.emplace_back("silhouette_reach", o.silhouette_reach_weight);
    use_features_ = use_photometric_ && o.feature_weight > 0.0;
    feature_weight_ = o.feature_weight;
    if (use_features_) summary_.terms.emplace_back("features", o.feature_weight);
    use_flow_ = use_photometric_ && num_frames > 1 && (o.flow_weight > 0.0 || o.flow_start);
    if (use_flow_ && o.flow_weight > 0.0) summary_.terms.emplace_back("flow", o.flow_weight);
    if (use_inextensibility_) summary_.terms.emplace_back("inextensibility", o.inextensibility_weight);
    if (o.bending_weight > 0.0) summary_.terms.emplace_back("bending", o.bending_weight);
    ChooseGravityPrior();
    if (num_frames > 1 && o.occluded_temporal_weight > 0.0) {
      summary_.terms.emplace_back("occluded_hold", o.occluded_temporal_weight);
    }
    if (use_temporal_) summary_.terms.emplace_back(gravity_shift_ ? "temporal_gravity" : "temporal", o.temporal_weight);
    // Data terms are normalised to about 1 per unit weight: the regularisers
    // far above them decide the shape alone.
    const double data = std::max(use_photometric_ ? o.photometric_weight : 0.0, use_masks_ ? o.silhouette_weight : 0.0);
    const double stiffest =
        std::max(use_inextensibility_ ? o.inextensibility_weight : 0.0, use_temporal_ ? o.temporal_weight : 0.0);
    if (data > 0.0 && stiffest >= 1e4 * data) {
      summary_.warnings.emplace_back("stiff weights (a regulariser at " + std::to_string(stiffest / data) +
                                     " times the data terms): the images barely move the surface and results may "
                                     "be unreliable");
    }
    if (!use_photometric_ && !use_masks_) {
      throw std::invalid_argument("PolySftOptions: no data term (photometric weight 0 and no masks)");
    }
  }

  // The template in atlas.initial_patches cells from the start, as many as
  // the atlas's own rule allows (each cell min_vertices on average).
  void SplitInitialPatches() {
    const PatchAtlasOptions& atlas = options_.atlas;
    const int k = std::min({atlas.initial_patches, atlas.max_patches, model_.num_vertices() / atlas.min_vertices});
    if (k <= 1 || !model_.can_split()) return;
    const std::vector<int> child = SplitPatchVertices(scene_.template_mesh, model_.vertex_patches(), 0, k);
    if (!child.empty()) model_.SplitPatch(0, child);
  }

  // The physics prior where asked for and the scene can have it: the shift
  // g dt^2 of the second-order temporal term's target.
  void ChooseGravityPrior() {
    if (!use_temporal_ || !options_.gravity_prior) return;
    if (!scene_.has_gravity || !(scene_.frame_rate > 0.0)) {
      summary_.warnings.emplace_back(
          "gravity_prior: the scene states no gravity and frame rate (scene.json's 'gravity' and 'frame_rate'): the "
          "prior is off");
      return;
    }
    const double g = scene_.gravity.norm();
    gravity_shift_ = g > 0.0 ? InertiaResidual::GravityShift(1.0 / scene_.frame_rate, 1.0, 1.0, g, -scene_.gravity / g)
                             : Eigen::Vector3d::Zero();
  }

  int TemporalOrder() const { return gravity_shift_ ? 2 : options_.temporal_order; }

  // The deformation chosen, and what may make the result unreliable.
  void CheckTemplate() {
    summary_.deformation = model_.texture_space() ? "texture_space" : "patch_jet";
    if (options_.ground_truth_start != GroundTruthStart::kNone &&
        scene_.ground_truth_kind != GroundTruthKind::kVertices) {
      summary_.warnings.emplace_back(
          "ground_truth_start: the scene has no per-vertex ground truth; frames start from the frame before");
    }
    if (model_.texture_space() && !options_.deformation.texture_space) {
      summary_.warnings.emplace_back(
          "the template is not a height field over one plane: it is deformed by a texture-space field instead of "
          "its patch's jet");
    }
    if (!options_.deformation.keep_detail &&
        model_.template_rms_error() > 1e-3 * BoundingBoxDiagonal(scene_.template_mesh.vertices)) {
      char buffer[160];
      std::snprintf(buffer, sizeof(buffer), "the template's jet deviates from it by %.2e m RMS (keep_detail holds it)",
                    model_.template_rms_error());
      summary_.warnings.emplace_back(buffer);
    }
    // Little texture: the photometric term cannot locate the surface.
    cv::Mat grey, dx, dy;
    cv::cvtColor(scene_.texture, grey, cv::COLOR_RGB2GRAY);
    cv::Sobel(grey, dx, CV_32F, 1, 0);
    cv::Sobel(grey, dy, CV_32F, 0, 1);
    if (cv::mean(dx.mul(dx) + dy.mul(dy))[0] < 1e-4) {
      summary_.warnings.emplace_back("the texture has little detail: shape is constrained mostly by the " +
                                     std::string(use_masks_ ? "silhouettes" : "regularisers") +
                                     " and results may be unreliable");
    }
  }

  // Faces, texture coordinates and depth range for the rasterizer; edges
  // and their rest lengths; the template's pixel area (normalises the image
  // terms); the template held still (the baseline).
  void PrepareTemplateData() {
    const TriangleMesh& mesh = scene_.template_mesh;
    mesh_template_.faces = mesh.faces;
    mesh_template_.corner_texcoords = mesh.corner_texcoords;
    mesh_template_.boundary_edges = MeshBoundaryEdgeFlags(mesh.faces);
    size_ = BoundingBoxDiagonal(mesh.vertices);
    mesh_template_.depth_near = std::max(1e-3, mesh.vertices.row(2).minCoeff() - size_);
    mesh_template_.depth_far = mesh.vertices.row(2).maxCoeff() + size_;
    const Eigen::Matrix2Xi edges = UniqueEdges(mesh);
    for (Eigen::Index e = 0; e < edges.cols(); ++e) {
      const double length = (mesh.vertices.col(edges(0, e)) - mesh.vertices.col(edges(1, e))).norm();
      if (length > 0.0) {
        edges_.emplace_back(edges(0, e), edges(1, e));
        rest_lengths_.push_back(length);
      }
    }
    for (double length : rest_lengths_) mean_edge_ += length / rest_lengths_.size();
    if (options_.atlas.hidden_split_share > 0.0) template_facing_ = FacesCamera(mesh.vertices);
    if (options_.bending_weight > 0.0 || NewCreaseOpinions()) hinges_ = MeasureHingeRest(mesh);
    ScreenMesh screen = mesh_template_;
    ProjectVertices(scene_.camera, mesh.vertices, &screen, nullptr);
    template_pixels_ = 0.0;
    for (int f = 0; f < screen.faces.cols(); ++f) {
      const Eigen::Vector2d a = screen.pixels.col(screen.faces(0, f)), b = screen.pixels.col(screen.faces(1, f)),
                            c = screen.pixels.col(screen.faces(2, f));
      template_pixels_ += 0.5 * std::abs((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
    }
    template_pixels_ = std::max(template_pixels_, 16.0);
    rasterizer_options_ = options_.rasterizer;
    if (options_.depth_softness > 0.0) {
      rasterizer_options_.gamma = SoftnessToGamma(options_.depth_softness, mesh.vertices.row(2).mean(),
                                                  mesh_template_.depth_near, mesh_template_.depth_far);
    }
    if (scene_.ground_truth_kind == GroundTruthKind::kVertices) summary_.template_e3d = summary_.template_rmse_mm = 0.0;
  }

  // Levels coarsest first, halving from the finest (which may itself be
  // scaled down to max_image_width).
  void BuildPyramid() {
    const double top_scale = options_.max_image_width > 0 && options_.max_image_width < scene_.camera.width
                                 ? static_cast<double>(options_.max_image_width) / scene_.camera.width
                                 : 1.0;
    const int levels = ChoosePyramidLevels(options_, scene_.camera.width);
    summary_.pyramid_levels = levels;
    levels_.resize(levels);
    for (int l = 0; l < levels; ++l) {
      levels_[l].scale = top_scale * std::ldexp(1.0, -(levels - 1 - l));
      levels_[l].camera = scene_.camera.Scaled(levels_[l].scale);
    }
  }

  // One rasterizer per level, each with the texture prefiltered to about one
  // texel per image pixel: sampled at a single point per pixel, a finer
  // texture aliases, and its colours match neither the (area-averaged)
  // frames nor their neighbours, which ruins the photometric gradients.
  void CreateRasterizers() {
    const TriangleMesh& mesh = scene_.template_mesh;
    ScreenMesh screen = mesh_template_;
    ProjectVertices(scene_.camera, mesh.vertices, &screen, nullptr);
    // Pixels per unit of texture coordinate, from the template's edges.
    double pixels_per_uv = 0.0;
    for (int f = 0; f < screen.faces.cols(); ++f) {
      for (int c = 0; c < 3; ++c) {
        const double duv =
            (mesh.corner_texcoords.col(3 * f + c) - mesh.corner_texcoords.col(3 * f + (c + 1) % 3)).norm();
        const double dpx =
            (screen.pixels.col(screen.faces(c, f)) - screen.pixels.col(screen.faces((c + 1) % 3, f))).norm();
        if (duv > 0.0) pixels_per_uv = std::max(pixels_per_uv, dpx / duv);
      }
    }
    const cv::Mat& full = scene_.texture;
    for (LevelData& level : levels_) {
      const double factor = std::min(1.0, level.scale * pixels_per_uv / std::max(full.cols, full.rows));
      cv::Mat texture = full;
      if (factor < 1.0) {
        cv::resize(full, texture,
                   cv::Size(std::max(2, static_cast<int>(std::lround(full.cols * factor))),
                            std::max(2, static_cast<int>(std::lround(full.rows * factor)))),
                   0, 0, cv::INTER_AREA);
      }
      SoftRasterizerOptions options = rasterizer_options_;
      if (&level == &levels_.back() && options_.finest_sigma > 0.0) options.sigma = options_.finest_sigma;
      if (&level == &levels_.back()) {
        options.mipmap = options_.finest_mipmap;
        options.compositing = options_.finest_compositing;
      }
      // Without masks nothing says what lies behind the surface.
      if (options.compositing == Compositing::kOverBackground && !scene_.has_masks()) {
        options.compositing = Compositing::kOver;
      }
      level.rasterizer = std::make_unique<SoftRasterizer>(options, texture);
      SoftRasterizerOptions serial = options;
      serial.num_threads = 1;
      level.serial_rasterizer = std::make_unique<SoftRasterizer>(serial, texture);
    }
  }

  // The band as far as the first frame's mask is off the template's
  // silhouette, rendered at the finest level (0 after the first frame).
  void MeasureSilhouetteBand(const FrameData& data, int t) {
    summary_.silhouette_band_px = 0.0;
    if (t != 0 || cv::countNonZero(data.frame.mask) == 0) return;
    const LevelData& level = levels_.back();
    ScreenMesh screen = mesh_template_;
    if (!ProjectVertices(level.camera, scene_.template_mesh.vertices, &screen, nullptr)) return;
    // Nearly hard: the soft silhouette's 1/2 level lies outside the edge.
    SoftRasterizerOptions hard = rasterizer_options_;
    hard.mipmap = false;  // the silhouette alone is read
    hard.sigma = 1e-3;
    SoftRenderOutput render;
    SoftRasterizer(hard, scene_.texture)
        .Render(screen, level.camera.width, level.camera.height, cv::Mat(), false, &render);
    cv::Mat mask = data.frame.mask;
    if (level.scale != 1.0) cv::resize(mask, mask, render.silhouette.size(), 0, 0, cv::INTER_AREA);
    const double offset = MaskBorderOffset(mask, render.silhouette) / level.scale;
    summary_.silhouette_band_px = SilhouetteBandForOffset(offset);
    if (std::lround(summary_.silhouette_band_px) > 0) {
      char buffer[220];
      std::snprintf(buffer, sizeof(buffer),
                    "frame %d: the mask is %s by %.1f px against the template's silhouette: silhouettes are left "
                    "free within %ld px of the masks' borders (silhouette_band)",
                    data.frame.index, offset > 0.0 ? "grown" : "shrunk", std::abs(offset),
                    std::lround(summary_.silhouette_band_px));
      summary_.warnings.emplace_back(buffer);
    }
  }

  // The warm start of a new frame: the newest frame's parameters, or with
  // PolySftOptions::predict_motion those moved on by their last change
  // (constant velocity of the deformation and the rigid motion) where the
  // frame prefers them: a motion that reverses between frames is
  // overshot by the prediction.
  std::vector<double> WarmStart(const FrameData& data) const {
    const std::vector<double>* last = Solved(0);
    if (last == nullptr) return std::vector<double>(model_.num_parameters(), 0.0);
    const std::vector<double>* before = Solved(1);
    if (!options_.predict_motion || before == nullptr || data.mask_empty || (!use_photometric_ && !use_masks_) ||
        !NewestSolvedTracked() || (window_.size() >= 2 && !Tracked(*window_[window_.size() - 2]))) {
      return *last;
    }
    std::vector<double> predicted = *last;
    for (size_t k = 0; k < predicted.size(); ++k) predicted[k] += (*last)[k] - (*before)[k];
    return ImageCost(0, data, predicted.data()) < ImageCost(0, data, last->data()) ? predicted : *last;
  }

  // The parameters of the k-th newest frame solved so far (0: the
  // newest): from the window, then the frames that left it (with a window
  // of one frame, the frames before); null past those.
  const std::vector<double>* Solved(size_t k) const {
    if (k < window_.size()) return &window_[window_.size() - 1 - k]->theta;
    k -= window_.size();
    return k < final_thetas_.size() ? &final_thetas_[k] : nullptr;
  }

  // Whether Solved(0) was tracked (true before the first frame).
  bool NewestSolvedTracked() const { return window_.empty() ? previous_final_tracked_ : Tracked(*window_.back()); }

  // Whether a solved frame fits far worse than the tracked frames (its
  // motion is no motion to carry on, unless its keypoints find it:
  // Tracked).
  bool Lost(const FrameData& data) const {
    const int t = data.frame.index - scene_.first_frame;
    return FitsFarWorse(t, frame_cost_[t]);
  }

  // Whether frame t at `cost` (per frame of its window) fits
  // kLostCostRatio times worse than the tracked frames; never the first,
  // which they are measured against.
  bool FitsFarWorse(int t, double cost) const { return t > 0 && CostRatio(cost) > kLostCostRatio; }

  // A frame's cost against what the frames tracked so far cost (their
  // median; the first frame's alone at first): a frame is lost when it
  // fits kLostCostRatio times worse. Not against the first frame's alone:
  // where the template is registered, the render matches the frame to
  // its noise, and a deforming surface's misfit (a hanging cloth tracked
  // within 3 mm costs 2-8 times its first frame) or a finer render's
  // lower floor would read as lost (docs/benchmarks.md).
  static constexpr double kLostCostRatio = 4.0;
  double CostRatio(double cost) const {
    double floor = frame_cost_[0];
    if (tracked_costs_.size() > 1) {
      std::vector<double> costs = tracked_costs_;
      std::nth_element(costs.begin(), costs.begin() + costs.size() / 2, costs.end());
      floor = costs[costs.size() / 2];
    }
    return cost / std::max(floor, 1e-12);
  }

  // A solved frame whose motion may be carried on (and whose misfit a
  // split may take): seen, in the texture's colours, and where it is. With
  // keypoint matches, where they put it (the surface within a few pixels
  // of them: a surface one jet cannot bend to the frame fits far worse
  // than the first in colour, yet is found); without, fitting about as
  // well as the first.
  bool Tracked(const FrameData& data) const {
    if (data.mask_empty || data.brightness.correlation < 0.2) return false;
    if (std::isfinite(data.feature_error)) return data.feature_error <= FoundFeatureError();
    return !Lost(data);
  }

  // The median keypoint distance (full-size pixels) under which a frame is
  // found: a few pixels, or 5% of the template's size in the image.
  double FoundFeatureError() const { return std::max(3.0, 0.05 * std::sqrt(template_pixels_)); }

  // FrameData::feature_error of every frame in the window.
  void MeasureFeatureErrors() {
    if (!use_features_) return;
    for (const auto& frame : window_) frame->feature_error = FeatureError(*frame);
  }

  // The median distance (full-size pixels) of the frame's surface from its
  // keypoint matches; NaN without them.
  double FeatureError(const FrameData& frame) const {
    if (frame.features.empty()) return std::numeric_limits<double>::quiet_NaN();
    const double to_full = 1.0 / levels_.back().scale;
    Eigen::Matrix3Xd vertices;
    model_.Evaluate(frame.theta.data(), &vertices);
    std::vector<double> errors;
    for (const FeatureMatch& m : frame.features) {
      const Eigen::Vector3d x = m.PointOn(vertices, scene_.template_mesh.faces);
      if (!(x.z() > 0.0)) continue;
      errors.push_back(to_full * (levels_.back().camera.Project(x) - m.pixel).norm());
    }
    if (errors.empty()) return std::numeric_limits<double>::quiet_NaN();
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
    return errors[errors.size() / 2];
  }

  // Loads frame t with its pyramid, warm-started from the newest frame.
  void AddFrameToWindow(int t) {
    auto data = std::make_unique<FrameData>();
    data->frame = LoadFrame(scene_, t);
    const int levels = static_cast<int>(levels_.size());
    data->images.resize(levels);
    data->masks.resize(levels);
    data->masks_upper.resize(levels);
    cv::Mat lower, upper;  // at full size: the band is in its pixels
    if (!data->frame.mask.empty()) {
      if (summary_.silhouette_band_px < 0.0) MeasureSilhouetteBand(*data, t);
      MaskBounds(data->frame.mask, summary_.silhouette_band_px, &lower, &upper);
      if (options_.relax_mask_border) RelaxBinaryBorder(&lower, &upper);
    }
    for (int l = 0; l < levels; ++l) {
      const cv::Size size(levels_[l].camera.width, levels_[l].camera.height);
      if (levels_[l].scale == 1.0) {
        data->images[l] = data->frame.image;
        data->masks[l] = lower;
        data->masks_upper[l] = upper;
      } else {
        cv::resize(data->frame.image, data->images[l], size, 0, 0, cv::INTER_AREA);
        if (!lower.empty()) {
          cv::resize(lower, data->masks[l], size, 0, 0, cv::INTER_AREA);
          cv::resize(upper, data->masks_upper[l], size, 0, 0, cv::INTER_AREA);
        }
      }
    }
    if (!upper.empty()) {
      data->plates.resize(levels);
      for (int l = 0; l < levels; ++l) {
        // One pixel more: a rim pixel the mask's rounding left out.
        if (levels_[l].rasterizer->options().compositing == Compositing::kOverBackground) {
          data->plates[l] = BackgroundPlate(data->images[l], data->masks_upper[l], 1);
        }
      }
    }
    if (options_.silhouette_reach_weight > 0.0 && !upper.empty() && levels > 1) {
      data->outside = OutsideDistance(data->masks_upper[0], ReachMargin(0));
    }
    if (!data->frame.mask.empty() && cv::countNonZero(data->frame.mask) == 0) {
      data->mask_empty = true;
      summary_.warnings.emplace_back("frame " + std::to_string(data->frame.index) +
                                     ": the mask is empty (object not visible?): its image terms are skipped");
    }
    data->after_lost = !NewestSolvedTracked();
    // The template's keypoints from the first frame's view of it, for
    // whichever later frame needs them.
    if (t == 0 && use_photometric_ && !data->mask_empty &&
        (options_.keypoints_when_lost || options_.relocalize)) {
      FindTemplateKeypoints(*data);
    }
    if (use_features_ || (options_.relocalize && use_photometric_ && data->after_lost)) {
      SeekKeypoints(data.get());
    }
    MatchFlow(data.get());
    data->theta = WarmStart(*data);
    window_.push_back(std::move(data));
    if (options_.flow_start) StartFromFlow();
    if (options_.relocalize) StartFromKeypoints();
    if (options_.ground_truth_start != GroundTruthStart::kNone) StartFromGroundTruth();
    window_.back()->start = window_.back()->theta;
    const std::vector<double>* before = Solved(1);
    window_.back()->moved_start = before != nullptr && window_.back()->start != *before;
  }

  // PolySftOptions::keypoints_when_lost: the keypoint term on from the
  // frame after the first that fits far worse than the tracked ones,
  // lost or not (its keypoints may find it: FoundByKeypoints).
  void KeypointsFromNowOn(int t) {
    static constexpr double kWeight = 100.0;
    if (!options_.keypoints_when_lost || use_features_ || !use_photometric_) return;
    use_features_ = true;
    feature_weight_ = kWeight;
    summary_.terms.emplace_back("features", kWeight);
    summary_.warnings.emplace_back("frame " + std::to_string(scene_.first_frame + t) +
                                   " fits far worse than the tracked frames: keypoint correspondences on from the "
                                   "next frame (keypoints_when_lost)");
  }

  // PolySftOptions::flow_start: the newest frame's parameters fitted to its
  // flow correspondences under the regularisers (the window's other frames
  // held), kept where they fit the frame's coarsest level better than the
  // warm start. The fit's weight only sets how far the regularisers bend
  // to the matches (the keypoints' scale); a few iterations bring the
  // start within the pyramid's reach, which is all a start needs (20 cost
  // four times the time for no better result: docs/benchmarks.md).
  void StartFromFlow() {
    static constexpr double kWeight = 100.0;
    static constexpr size_t kMinMatches = 10;
    static constexpr int kIterations = 5;
    FrameData& frame = *window_.back();
    if (frame.flow.size() < kMinMatches || frame.mask_empty) return;
    const std::vector<double> warm = frame.theta;
    FitNewestFrame(kIterations, [&](ceres::Problem* problem) {
      AddMatchTerm(static_cast<int>(levels_.size()) - 1, frame, frame.flow, kWeight, problem);
    });
    frame.flow_started = FitsCoarsestBetter(frame, warm);
    if (!frame.flow_started) frame.theta = warm;
  }

  // PolySftOptions::relocalize: a frame after one that was not tracked has
  // no flow and a start where the surface was lost; it starts from the
  // template placed on its keypoints (PlaceOnKeypoints) where that fits its
  // coarsest level better than the warm start, unless its keypoints agree
  // with the warm start (the frame before fit badly but was where they say:
  // a fold one jet cannot hold, not a loss).
  void StartFromKeypoints() {
    FrameData& frame = *window_.back();
    if (!frame.after_lost || frame.mask_empty || KeypointsAgree(frame)) return;
    const std::vector<double> warm = frame.theta;
    if (!PlaceOnKeypoints(&frame)) return;
    frame.relocalized = FitsCoarsestBetter(frame, warm);
    if (!frame.relocalized) frame.theta = warm;
  }

  // The frame's surface within FoundFeatureError of its keypoints.
  bool KeypointsAgree(const FrameData& frame) const { return FeatureError(frame) <= FoundFeatureError(); }

  // Whether a frame that fits far worse than the tracked ones is where its
  // keypoints say (then it is tracked, Tracked, and its cost joins theirs):
  // the misfit of a surface the model does not bend to the frame exactly
  // (a fold, an edge-on part) grows as the motion goes on, from the truth
  // too (the table's 0.6e-3 at rest to 2e-3 once its corner lifts and 2e-2
  // once it folds), and read as a loss it cut the next frame's flow and
  // its carried motion. Matched here when the keypoint term is not on.
  bool FoundByKeypoints(FrameData* frame) {
    if (!features_ || frame->mask_empty) return false;
    if (!use_features_ && frame->features.empty()) SeekKeypoints(frame);
    frame->feature_error = FeatureError(*frame);
    return frame->feature_error <= FoundFeatureError();  // false for NaN: no matches
  }

  // The frame's keypoint correspondences with the template's texture.
  void SeekKeypoints(FrameData* frame) {
    if (frame->mask_empty) return;
    if (!features_) FindTemplateKeypoints(*frame);
    frame->features = features_->Match(frame->images.back(), frame->masks.back());
  }

  // The template placed rigidly on the newest frame's keypoints
  // (PoseFromMatches), the frame fitted to that and then to the keypoints
  // that agree with it, under the regularisers (the window's other frames
  // held). False, the frame untouched, where its keypoints agree on no
  // motion.
  bool PlaceOnKeypoints(FrameData* frame) {
    static constexpr double kWeight = 100.0;
    const Eigen::Matrix3Xd& rest = scene_.template_mesh.vertices;
    MatchPose pose;
    if (!PoseFromMatches(levels_.back().camera, rest, scene_.template_mesh.faces, frame->features, MatchPoseOptions(),
                         &pose)) {
      return false;
    }
    const Eigen::Matrix3Xd placed = (pose.rotation * rest).colwise() + pose.translation;
    std::vector<FeatureMatch> agreeing;
    for (int i : pose.inliers) agreeing.push_back(frame->features[i]);
    FitNewestFrameTo(placed);
    FitNewestFrame(5, [&](ceres::Problem* problem) {
      AddMatchTerm(static_cast<int>(levels_.size()) - 1, *frame, agreeing, kWeight, problem);
    });
    return true;
  }

  // PolySftOptions::flow_weight, flow_start: the frame before's surface
  // (the window's newest frame: frames enter in order), where it saw it,
  // carried into this frame by optical flow (FlowMatches). Only a tracked
  // frame's surface is carried: the flow moves a registration on, right or
  // wrong, and a lost frame's carried on keeps the frames after from
  // finding the surface again.
  void MatchFlow(FrameData* data) const {
    if (!use_flow_ || window_.empty() || data->mask_empty) return;
    const FrameData& before = *window_.back();
    if (!Tracked(before)) return;  // tracked: its mask is not empty either
    Eigen::Matrix3Xd vertices;
    model_.Evaluate(before.theta.data(), &vertices);
    FlowMatchOptions flow;
    flow.depth_tolerance = 0.5 * mean_edge_;
    data->flow = FlowMatches(levels_.back().camera, vertices, scene_.template_mesh.faces, before.images.back(),
                             data->images.back(), before.masks_upper.back(), data->masks_upper.back(), flow);
  }

  // PolySftOptions::ground_truth_start: the newest frame's parameters
  // fitted to the ground truth (its own, or the frame before's) under the
  // regularisers (the window's other frames held), each vertex pulled to
  // its point by
  //   r = (w / L) (X_i - G_i),  w^2 = 10 / #V,  L the template's mean edge,
  // the temporal term's order-1 residual against the ground truth as data.
  void StartFromGroundTruth() {
    FrameData& frame = *window_.back();
    if (scene_.ground_truth_kind != GroundTruthKind::kVertices) return;
    Eigen::Matrix3Xd truth = frame.frame.ground_truth;
    if (options_.ground_truth_start == GroundTruthStart::kFrameBefore) {
      // Frames enter in order: the one before's truth is kept, not read again.
      std::swap(truth, previous_truth_);
      if (truth.cols() == 0) truth = previous_truth_;  // the first frame: its own
    }
    if (truth.cols() != model_.num_vertices()) return;
    // As near the truth as the model goes: what is left is the cost's.
    FitNewestFrameTo(truth, kTruthFitIterations);
  }

  // FitNewestFrameTo's iterations for a start (a mirrored flap, a flipped
  // crease, the template placed on keypoints): within the pyramid's reach
  // is all a start needs, and a target the jets cannot hold (a mirrored
  // flap's crease inside a patch) was still far off after 30, at 0.2 s a
  // fit (at 10 a flag's frame is 15-20% faster on two threads, the cloth
  // scenes' errors within their run-to-run spread; docs/benchmarks.md).
  // For the ground truth, as near as the model goes.
  static constexpr int kStartFitIterations = 10;
  static constexpr int kTruthFitIterations = 30;

  // The newest frame fitted to vertex positions (3 by #V) under the
  // regularisers (a target's weight far above theirs), in at most
  // `iterations` Levenberg-Marquardt iterations.
  void FitNewestFrameTo(const Eigen::Matrix3Xd& target, int iterations = kStartFitIterations) {
    FrameData& frame = *window_.back();
    FitNewestFrame(iterations, [&](ceres::Problem* problem) {
      const std::vector<double*> blocks = Blocks(frame.theta);
      const double w = std::sqrt(10.0 / model_.num_vertices());
      for (int p = 0; p < model_.num_patches(); ++p) {
        problem->AddResidualBlock(new CompressedCost(new TemporalCost(&model_, p, mean_edge_, w, &target)), nullptr,
                                  blocks[p]);
      }
    });
  }

  // The newest frame's parameters fitted to a data term (add_data) under
  // the regularisers, the window's other frames held: the fits that start
  // a frame (StartFromFlow, PlaceOnKeypoints, FitNewestFrameTo).
  void FitNewestFrame(int iterations, const std::function<void(ceres::Problem*)>& add_data) {
    ceres::Problem::Options problem_options;
    problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    add_data(&problem);
    AddRegularizers(window_.size() - 1, false, &problem);
    for (size_t k = 0; k + 1 < window_.size(); ++k) {
      for (double* block : Blocks(window_[k]->theta)) {
        if (problem.HasParameterBlock(block)) problem.SetParameterBlockConstant(block);
      }
    }
    ceres::Solver::Options solver = LevelSolverOptions();
    solver.max_num_iterations = iterations;
    ceres::Solver::Summary result;
    ceres::Solve(solver, &problem, &result);
  }

  // The template's keypoints (TextureFeatures), from the template rendered
  // at the finest level over the first frame (its background), where the
  // first frame sees it.
  void FindTemplateKeypoints(const FrameData& first) {
    const LevelData& level = levels_.back();
    const Eigen::Matrix3Xd& vertices = scene_.template_mesh.vertices;
    ScreenMesh screen = mesh_template_;
    // A template behind the camera has no view: no faces, no keypoints.
    Eigen::Matrix2Xd corners(2, 0);
    Eigen::VectorXd depths(0);
    if (ProjectVertices(level.camera, vertices, &screen, nullptr)) {
      corners.resize(2, 3 * screen.faces.cols());
      depths.resize(3 * screen.faces.cols());
      for (int f = 0; f < screen.faces.cols(); ++f) {
        for (int k = 0; k < 3; ++k) {
          corners.col(3 * f + k) = screen.pixels.col(screen.faces(k, f));
          depths[3 * f + k] = vertices(2, screen.faces(k, f));
        }
      }
    }
    SoftRenderOutput render;
    if (corners.cols() > 0) {
      level.rasterizer->Render(screen, level.camera.width, level.camera.height, first.images.back(), false, &render);
    } else {
      render.color = first.images.back();
    }
    features_ = std::make_unique<TextureFeatures>(options_.features, render.color, render.silhouette, corners, depths);
    if (features_->size() < std::max(options_.features.min_matches, 1)) {
      summary_.warnings.emplace_back("the template shows " + std::to_string(features_->size()) +
                                     " keypoints where the first frame sees it: keypoint correspondences "
                                     "(feature_weight) have nothing to match");
    }
  }

  // The split render terms of one problem, kept beside it, and the
  // callback (the problem's evaluation_callback) that renders each frame
  // once per evaluation for all its groups.
  struct SplitTerms {
    explicit SplitTerms(int num_threads) : callback(num_threads) {}
    std::vector<std::unique_ptr<SplitRenderTerm>> terms;
    RenderTermCallback callback;
  };

  // The photometric and silhouette term of window frame k at a level;
  // false when the surface went behind the camera. One residual block for
  // one patch; for an atlas, a SplitRenderTerm (render_groups_, into
  // `split`, returned in *render) whose row blocks the caller adds once the
  // frame's regularisers are attached (AddFrameTerms).
  bool AddImageTerm(int l, FrameData& frame, ceres::Problem* problem, SplitTerms* split,
                    SplitRenderTerm** render) {
    *render = nullptr;
    if (frame.mask_empty || (!use_photometric_ && !use_masks_)) return true;
    RenderCost::Data d;
    if (!ImageTerm(l, frame, solving_frames_ > 1, &d)) return false;
    if (d.roi.area() <= 0) return true;
    d.render_scratch = &frame.render_scratch;
    const std::vector<double*> blocks = Blocks(frame.theta);
    if (model_.num_patches() == 1) {
      problem->AddResidualBlock(new CompressedRenderCost(std::move(d)), nullptr, blocks);
    } else {
      split->terms.push_back(std::make_unique<SplitRenderTerm>(std::move(d), render_groups_, frame.theta.data()));
      split->callback.Add(split->terms.back().get());
      *render = split->terms.back().get();
    }
    AddSilhouetteReach(l, frame, problem, *render);
    // Correspondences guide the coarse levels; the finest is the images'
    // unless asked.
    const bool coarse = l + 1 < static_cast<int>(levels_.size());
    if (use_features_ && (coarse || options_.features_on_finest)) {
      AddMatchTerm(l, frame, frame.features, feature_weight_, problem, *render);
    }
    if (options_.flow_weight > 0.0 && (coarse || options_.flow_on_finest)) {
      AddMatchTerm(l, frame, frame.flow, options_.flow_weight, problem, *render);
    }
    return true;
  }

  // Window frame k's image term at level l and its regularisers: for an
  // atlas, the frame's own regularisers attached to its render term, whose
  // row blocks are added last. False when the surface went behind the
  // camera.
  bool AddFrameTerms(int l, size_t k, ceres::Problem* problem, SplitTerms* split) {
    FrameData& frame = *window_[k];
    SplitRenderTerm* render = nullptr;
    if (!AddImageTerm(l, frame, problem, split, &render)) return false;
    AddRegularizers(k, l + 1 < static_cast<int>(levels_.size()), problem, render);
    if (render == nullptr) return true;
    const std::vector<double*> blocks = Blocks(frame.theta);
    for (int i = 0; i < render->num_row_blocks(); ++i) {
      std::vector<double*> row_blocks;
      for (const int p : render->row_block_patches(i)) row_blocks.push_back(blocks[p]);
      problem->AddResidualBlock(render->NewRowBlockCost(i), nullptr, row_blocks);
    }
    return true;
  }

  // Correspondences of a frame at level l (FeatureCost; keypoints or
  // optical flow), with w = sqrt(weight / N) / (s_l D): D the template's
  // linear size in full-size pixels, s_l the level's scale, so that the
  // cost is weight / 2 times the mean squared distance over D^2 at any
  // level; the dead zone and Huber's threshold in full-size pixels. One
  // cost per set of patches the matches' faces span (in a fixed order),
  // so that an atlas's normal equations stay sparse by patch; attached to
  // the frame's `render` term where given.
  void AddMatchTerm(int l, FrameData& frame, const std::vector<FeatureMatch>& matches, double weight,
                    ceres::Problem* problem, SplitRenderTerm* render = nullptr) {
    if (matches.empty()) return;
    const LevelData& level = levels_[l];
    const double w = std::sqrt(weight / matches.size()) / std::sqrt(template_pixels_);
    const double to_level = level.scale / levels_.back().scale;  // the matches are in the finest level's pixels
    std::map<std::vector<int>, std::vector<FeatureCost::Point>> by_patches;
    for (const FeatureMatch& m : matches) {
      const Eigen::Vector3i corners = scene_.template_mesh.faces.col(m.face);
      std::vector<int> patches = {model_.patch_of_vertex(corners[0]), model_.patch_of_vertex(corners[1]),
                                  model_.patch_of_vertex(corners[2])};
      std::sort(patches.begin(), patches.end());
      patches.erase(std::unique(patches.begin(), patches.end()), patches.end());
      by_patches[patches].push_back({corners, m.barycentric, to_level * (m.pixel.array() + 0.5) - 0.5});
    }
    for (auto& group : by_patches) {
      auto* cost = new FeatureCost(&model_, std::move(group.second), level.camera, w / level.scale,
                                   options_.feature_dead_zone_px * level.scale, w * options_.feature_huber_px);
      AddFrameTerm(frame, cost, cost->patches(), problem, render);
    }
  }

  // How far the reach's distance map continues the mask past the image
  // at level l (half the image: a surface the image cuts off may go on).
  int ReachMargin(int l) const { return std::max(levels_[l].camera.width, levels_[l].camera.height) / 2; }

  // The silhouette's long reach on the coarsest level (SilhouetteReachCost),
  // attached to the frame's `render` term where given.
  void AddSilhouetteReach(int l, FrameData& frame, ceres::Problem* problem, SplitRenderTerm* render) {
    if (l != 0 || !use_masks_ || frame.outside.empty()) return;
    for (int p = 0; p < model_.num_patches(); ++p) {
      AddFrameTerm(frame,
                   new SilhouetteReachCost(&model_, p, levels_[l].camera, frame.outside, ReachMargin(l), 0.5,
                                           options_.silhouette_reach_weight),
                   {p}, problem, render);
    }
  }

  // The image terms' data as the solve sees them: the frame mapped to the
  // texture's lighting. serial: rendered on one thread (frames side by side).
  bool ImageTerm(int l, FrameData& frame, bool serial, RenderCost::Data* out) {
    const LevelData& level = levels_[l];
    RenderCost::Data d;
    ScreenMesh screen;
    if (!ImageTermData(l, frame, frame.theta.data(), serial ? level.serial_rasterizer.get() : level.rasterizer.get(),
                       &d, &screen)) {
      return false;
    }
    if (d.roi.area() > 0 && use_photometric_ && options_.match_brightness) {
      frame.compensated.resize(levels_.size());
      if (frame.compensated[l].empty()) {
        frame.brightness = MatchFrameBrightness(*d.rasterizer, screen, level.camera, d.image, d.mask, d.roi);
        frame.compensated[l] = CompensateBrightness(d.image, frame.brightness);
        if (!d.background.empty()) {
          frame.compensated_plates.resize(levels_.size());
          frame.compensated_plates[l] = CompensateBrightness(d.background, frame.brightness);
        }
      }
      d.image = frame.compensated[l];
      if (!d.background.empty()) d.background = frame.compensated_plates[l];
    }
    *out = std::move(d);
    return true;
  }

  // Pointers to each patch's block of theta.
  std::vector<double*> Blocks(std::vector<double>& theta) const {
    std::vector<double*> blocks(model_.num_patches());
    for (int p = 0; p < model_.num_patches(); ++p)
      blocks[p] = theta.data() + static_cast<size_t>(model_.block_size()) * p;
    return blocks;
  }

  // The image terms' data of a frame at a level, at parameters theta (the
  // frame's own lighting, before brightness matching); false when the
  // surface went behind the camera.
  bool ImageTermData(int l, const FrameData& frame, const double* theta, const SoftRasterizer* rasterizer,
                     RenderCost::Data* out, ScreenMesh* screen_out) const {
    const LevelData& level = levels_[l];
    RenderCost::Data d;
    d.model = &model_;
    d.rasterizer = rasterizer;
    d.mesh = mesh_template_;
    d.camera = level.camera;
    d.image = frame.images[l];
    if (static_cast<int>(frame.plates.size()) > l) d.background = frame.plates[l];
    if (use_masks_) {
      d.mask = frame.masks[l];
      d.mask_upper = frame.masks_upper[l];
    }
    Eigen::Matrix3Xd vertices;
    model_.Evaluate(theta, &vertices);
    ScreenMesh screen = mesh_template_;
    if (!ProjectVertices(level.camera, vertices, &screen, nullptr)) return false;
    const double level_pixels = template_pixels_ * level.scale * level.scale;
    d.roi = RegionOfInterest(screen, d.mask_upper, level.camera.width, level.camera.height,
                             4.0 + std::sqrt(options_.rasterizer.cutoff * options_.rasterizer.sigma));
    d.photometric_weight = use_photometric_ ? std::sqrt(options_.photometric_weight / level_pixels) : 0.0;
    d.silhouette_weight = std::sqrt(options_.silhouette_weight / level_pixels);
    d.robust_loss = options_.robust_loss;
    d.robust_scale = options_.robust_scale * d.photometric_weight;
    *out = std::move(d);
    *screen_out = std::move(screen);
    return true;
  }

  // The frame's parameters fit its coarsest level better than `other`
  // (the rule by which a start replaces another).
  bool FitsCoarsestBetter(const FrameData& frame, const std::vector<double>& other) const {
    // Both in the atlas as it is now (a split extends every kept start).
    const size_t size = static_cast<size_t>(model_.num_parameters());
    if (frame.theta.size() != size || other.size() != size) {
      throw std::logic_error("PolySfT: parameters from before a split compared with the atlas after it");
    }
    return ImageCost(0, frame, frame.theta.data()) < ImageCost(0, frame, other.data());
  }

  // The image terms' cost of a frame at parameters theta, at level l
  // (infinite when the surface is behind the camera).
  double ImageCost(int l, const FrameData& frame, const double* theta) const {
    RenderCost::Data d;
    ScreenMesh screen;
    if (!ImageTermData(l, frame, theta, levels_[l].rasterizer.get(), &d, &screen)) {
      return std::numeric_limits<double>::infinity();
    }
    if (d.roi.area() <= 0) return 0.0;
    double squared_norm = 0.0;
    RenderCost(std::move(d)).EvaluateNormalEquations(theta, &squared_norm, nullptr, nullptr);
    return squared_norm;
  }

  // The frame's lighting against the texture's, from a render of the
  // surface where it is now (coarse levels give it first; finer levels
  // refine it as the surface settles).
  static Brightness MatchFrameBrightness(const SoftRasterizer& rasterizer, const ScreenMesh& screen,
                                         const PinholeCamera& camera, const cv::Mat& image, const cv::Mat& mask,
                                         const cv::Rect& roi) {
    SoftRenderOutput render;
    rasterizer.Render(screen, camera.width, camera.height, cv::Mat(), false, &render, roi);
    return MatchBrightness(render.color, render.silhouette, image, mask, roi);
  }

  // A term over window frame `frame`'s `patches` alone: attached to its
  // render term where it has one (`render`), else a residual block
  // (compressed, unless `compress` is false).
  void AddFrameTerm(FrameData& frame, ceres::CostFunction* cost, const std::vector<int>& patches,
                    ceres::Problem* problem, SplitRenderTerm* render, bool compress = true) {
    if (render != nullptr) {
      render->Attach(cost, patches);
      return;
    }
    const std::vector<double*> all = Blocks(frame.theta);
    std::vector<double*> some;
    for (const int p : patches) some.push_back(all[p]);
    problem->AddResidualBlock(compress ? new CompressedCost(cost) : cost, nullptr, some);
  }

  // Inextensibility of window frame k, bending where asked, its patches'
  // seams, the hold of its hidden part, and its temporal link to the
  // frames before it (in the window, or finalised before it; as many as
  // temporal_order asks and exist): each over the blocks of the patches it
  // joins, those within the frame attached to its `render` term where
  // given.
  void AddRegularizers(size_t k, bool coarse, ceres::Problem* problem, SplitRenderTerm* render = nullptr) {
    // Where the frame's estimate is as its problem is built (the seams'
    // and the occluded hold's choices).
    Eigen::Matrix3Xd vertices;
    model_.Evaluate(window_[k]->theta.data(), &vertices);
    // Which vertices a nearer part hides: an occlusion render, made at most
    // once for the seams and the hold of hidden vertices.
    std::optional<std::vector<std::uint8_t>> hidden;
    AddShapeTerms(*window_[k], problem, render);
    AddSeams(*window_[k], coarse, vertices, &hidden, problem, render);
    AddOccludedHold(k, vertices, &hidden, problem);
    AddTemporal(k, problem);
  }

  // AddRegularizers: inextensibility and bending of one frame.
  void AddShapeTerms(FrameData& frame, ceres::Problem* problem, SplitRenderTerm* render) {
    if (use_inextensibility_ && !edges_.empty()) {
      const double w = std::sqrt(options_.inextensibility_weight / edges_.size());
      for (const AtlasTerms::EdgeGroup& g : atlas_terms_.edge_groups) {
        AddFrameTerm(frame,
                     new InextensibilityCost(&model_, g.patches, g.edges, g.rest_lengths, w,
                                             options_.inextensibility_robust_strain),
                     g.patches, problem, render);
      }
    }
    const double bending = options_.bending_weight + (bending_prior_on_ ? options_.new_crease_bending_weight : 0.0);
    if (bending <= 0.0) return;
    const double stiffness = std::sqrt(bending);
    for (const AtlasTerms::HingeGroup& g : atlas_terms_.hinge_groups) {
      std::vector<double> weights(g.weights.size());
      for (size_t h = 0; h < weights.size(); ++h) weights[h] = stiffness * std::sqrt(g.weights[h]);
      AddFrameTerm(frame, new BendingCost(&model_, g.patches, g.hinges, g.rest_angles, weights), g.patches, problem,
                   render);
    }
  }

  // AddRegularizers: the seams of one frame at `vertices` (3 by #V), loose
  // where its images see both patches, and their uv fields held alike.
  void AddSeams(FrameData& frame, bool coarse, const Eigen::Matrix3Xd& vertices,
                std::optional<std::vector<std::uint8_t>>* hidden, ceres::Problem* problem,
                SplitRenderTerm* render) {
    if (atlas_terms_.seams.empty()) return;
    const PatchAtlasOptions& atlas = options_.atlas;
    const double position_weight = coarse ? atlas.coarse_seam_position_weight : atlas.seam_position_weight;
    size_t count = 0;
    for (const AtlasTerms::Seam& seam : atlas_terms_.seams) count += seam.edges.size();
    const std::vector<std::uint8_t> seen = SeenPatches(frame, vertices);
    const std::vector<std::uint8_t> textured =
        atlas.seen_seam_uv_weight < std::max(atlas.seam_uv_weight, atlas.coarse_seam_uv_weight) ||
                atlas.seen_seam_uv_robust != atlas.seam_uv_robust
            ? TexturedPatches(seen, vertices, HiddenOnce(vertices, hidden))
            : std::vector<std::uint8_t>(seen.size(), 0);
    const double wn = std::sqrt(atlas.seam_normal_weight / count);
    for (const AtlasTerms::Seam& seam : atlas_terms_.seams) {
      const double wx =
          std::sqrt((seen[seam.a] && seen[seam.b] ? atlas.seen_seam_position_weight : position_weight) / count);
      if (wx > 0.0 || wn > 0.0) {
        AddFrameTerm(frame, CreateSeamCost(&model_, seam.a, seam.b, seam.edges, mean_edge_, wx, wn),
                     {seam.a, seam.b}, problem, render);
      }
      const double level_uv_weight = coarse ? atlas.coarse_seam_uv_weight : atlas.seam_uv_weight;
      const bool both_textured = textured[seam.a] && textured[seam.b];
      const double uv_weight =
          both_textured ? std::min(level_uv_weight, atlas.seen_seam_uv_weight) : level_uv_weight;
      if (uv_weight > 0.0) {
        AddFrameTerm(frame,
                     CreateSharedUvCost(&model_, std::sqrt(uv_weight / atlas_terms_.seams.size()),
                                        both_textured ? atlas.seen_seam_uv_robust : atlas.seam_uv_robust),
                     {seam.a, seam.b}, problem, render, false);
      }
    }
  }

  // Up to `order` frames before window frame k, most recent first: the
  // window's (their blocks), then the finalised (their vertices). Returns
  // how many there are.
  int EarlierFrames(size_t k, int order, std::vector<std::vector<double*>>* blocks,
                    std::vector<const Eigen::Matrix3Xd*>* fixed) const {
    for (int back = 1; back <= order; ++back) {
      const int j = static_cast<int>(k) - back;
      if (j >= 0) {
        blocks->push_back(Blocks(window_[j]->theta));
      } else if (-j - 1 < static_cast<int>(finals_.size())) {
        fixed->push_back(&finals_[-j - 1]);
      } else {
        break;
      }
    }
    return static_cast<int>(blocks->size() + fixed->size());
  }

  // AddRegularizers: window frame k's temporal link, per patch.
  void AddTemporal(size_t k, ceres::Problem* problem) {
    if (!use_temporal_) return;
    const std::vector<double*> blocks = Blocks(window_[k]->theta);
    const double w = std::sqrt(options_.temporal_weight / model_.num_vertices());
    std::vector<std::vector<double*>> earlier_blocks;
    std::vector<const Eigen::Matrix3Xd*> fixed;
    const int order = EarlierFrames(k, TemporalOrder(), &earlier_blocks, &fixed);
    if (order == 0) return;
    // Gravity's shift needs both frames before (a frame with one before
    // has no velocity to carry on).
    const Eigen::Vector3d shift = order == 2 && gravity_shift_ ? *gravity_shift_ : Eigen::Vector3d::Zero();
    for (int p = 0; p < model_.num_patches(); ++p) {
      std::vector<double*> frames = {blocks[p]};
      for (const auto& earlier : earlier_blocks) frames.push_back(earlier[p]);
      problem->AddResidualBlock(new CompressedCost(new TemporalCost(&model_, p, size_, w, order, fixed, shift)),
                                nullptr, frames);
    }
  }

  // The patches of a frame (#patches flags) that its images see whole:
  // with masks (the silhouette holds their borders), and all but 5% of
  // their vertices inside the image where its estimate (3 by #V) is.
  std::vector<std::uint8_t> SeenPatches(const FrameData& frame, const Eigen::Matrix3Xd& vertices) const {
    std::vector<std::uint8_t> seen(model_.num_patches(), 0);
    if (!use_masks_ || frame.mask_empty) return seen;
    const PinholeCamera& camera = levels_.back().camera;
    std::vector<int> inside(model_.num_patches(), 0), all(model_.num_patches(), 0);
    for (int v = 0; v < model_.num_vertices(); ++v) {
      const int p = model_.patch_of_vertex(v);
      ++all[p];
      if (!(vertices(2, v) > 0.0)) continue;
      const Eigen::Vector2d pixel = camera.Project(vertices.col(v));
      inside[p] += pixel.x() >= 0.0 && pixel.y() >= 0.0 && pixel.x() < camera.width && pixel.y() < camera.height;
    }
    for (int p = 0; p < model_.num_patches(); ++p) seen[p] = inside[p] >= 0.95 * all[p];
    return seen;
  }

  // Of the `seen` patches, those whose texture the frame shows: at most a
  // tenth of their vertices hidden by a nearer part, and their faces
  // turned to the camera, at most 60 degrees from it on average (a flap
  // edge-on or turned over shows no texture to tell how it slides).
  // hidden: HiddenVertices(vertices).
  std::vector<std::uint8_t> TexturedPatches(std::vector<std::uint8_t> seen, const Eigen::Matrix3Xd& vertices,
                                            const std::vector<std::uint8_t>& hidden) const {
    if (hidden.empty()) return std::vector<std::uint8_t>(seen.size(), 0);
    const std::vector<int> count = model_.PatchSizes();
    std::vector<int> hidden_count(seen.size(), 0), faces(seen.size(), 0);
    std::vector<double> facing(seen.size(), 0.0);
    for (int v = 0; v < model_.num_vertices(); ++v) hidden_count[model_.patch_of_vertex(v)] += hidden[v];
    TriangleMesh mesh;
    mesh.vertices = vertices;
    mesh.faces = scene_.template_mesh.faces;
    const Eigen::Matrix3Xd normals = PerFaceNormals(mesh);
    for (Eigen::Index f = 0; f < mesh.faces.cols(); ++f) {
      const int p = model_.patch_of_vertex(mesh.faces(0, f));
      const Eigen::Vector3d at = vertices.col(mesh.faces(0, f));
      facing[p] += std::max(0.0, -normals.col(f).dot(at) / std::max(at.norm(), 1e-12));
      ++faces[p];
    }
    for (size_t p = 0; p < seen.size(); ++p) {
      seen[p] = seen[p] && 10 * hidden_count[p] <= count[p] && faces[p] > 0 && facing[p] >= 0.5 * faces[p];
    }
    return seen;
  }

  // HiddenVertices(vertices), rendered on the first call and kept in `cache`.
  const std::vector<std::uint8_t>& HiddenOnce(const Eigen::Matrix3Xd& vertices,
                                              std::optional<std::vector<std::uint8_t>>* cache) const {
    if (!cache->has_value()) *cache = HiddenVertices(vertices);
    return **cache;
  }

  // Per vertex (#V) of a surface at `vertices` (3 by #V), whether a nearer
  // part of it hides the vertex in the finest level's view
  // (OccludedVertices); empty when the surface is behind the camera.
  // occluders: OccludedVertices'.
  std::vector<std::uint8_t> HiddenVertices(const Eigen::Matrix3Xd& vertices,
                                           std::vector<int>* occluders = nullptr) const {
    const LevelData& finest = levels_.back();
    ScreenMesh screen = mesh_template_;
    if (!ProjectVertices(finest.camera, vertices, &screen, nullptr)) return {};
    return OccludedVertices(screen, finest.camera.width, finest.camera.height, kOccludedDepthTolerance * size_,
                            occluders);
  }

  // Per vertex (#V) and per face (#F) of the template's faces at
  // `vertices` (3 by #V, camera frame): whether its normal points toward
  // the camera.
  struct Facing {
    std::vector<std::uint8_t> vertices, faces;
  };
  Facing FacesCamera(const Eigen::Matrix3Xd& vertices) const {
    TriangleMesh mesh;
    mesh.vertices = vertices;
    mesh.faces = scene_.template_mesh.faces;
    const Eigen::Matrix3Xd normals = VertexNormals(mesh);
    Facing facing;
    facing.vertices.resize(vertices.cols());
    for (Eigen::Index v = 0; v < vertices.cols(); ++v) facing.vertices[v] = normals.col(v).dot(vertices.col(v)) < 0.0;
    const Eigen::Matrix3Xd face_normals = PerFaceNormals(mesh);
    facing.faces.resize(mesh.faces.cols());
    for (Eigen::Index f = 0; f < mesh.faces.cols(); ++f) {
      facing.faces[f] = face_normals.col(f).dot(vertices.col(mesh.faces(0, f))) < 0.0;
    }
    return facing;
  }

  // PolySftOptions::occluded_temporal_weight: window frame k's vertices
  // that another part of its surface hides (where its estimate is now)
  // held to where the frame before put them, carried on at
  // occluded_velocity times their velocity there.
  void AddOccludedHold(size_t k, const Eigen::Matrix3Xd& vertices, std::optional<std::vector<std::uint8_t>>* hidden,
                       ceres::Problem* problem) {
    if (options_.occluded_temporal_weight <= 0.0) return;
    // With a velocity to carry, the two frames before; order 1 where there
    // is only one (the second frame).
    std::vector<std::vector<double*>> earlier_blocks;
    std::vector<const Eigen::Matrix3Xd*> fixed;
    const int order = EarlierFrames(k, options_.occluded_velocity > 0.0 ? 2 : 1, &earlier_blocks, &fixed);
    if (order == 0) return;  // the first frame
    const std::vector<std::uint8_t>& occluded = HiddenOnce(vertices, hidden);
    if (occluded.empty()) return;
    std::vector<std::vector<int>> per_patch(model_.num_patches());
    for (int v = 0; v < model_.num_vertices(); ++v) {
      if (occluded[v]) per_patch[model_.patch_of_vertex(v)].push_back(v);
    }
    const double w = std::sqrt(options_.occluded_temporal_weight / model_.num_vertices());
    const std::vector<double*> blocks = Blocks(window_[k]->theta);
    for (int p = 0; p < model_.num_patches(); ++p) {
      if (per_patch[p].empty()) continue;
      std::vector<double*> frames = {blocks[p]};
      for (const auto& earlier : earlier_blocks) frames.push_back(earlier[p]);
      problem->AddResidualBlock(new CompressedCost(new TemporalCost(&model_, p, size_, w, order, fixed,
                                                                    Eigen::Vector3d::Zero(), per_patch[p],
                                                                    options_.occluded_velocity)),
                                nullptr, frames);
    }
  }

  ceres::Solver::Options LevelSolverOptions() const {
    ceres::Solver::Options solver;
    solver.minimizer_type = ceres::TRUST_REGION;
    solver.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    // Every term is compressed to (parameters + 1) rows: one patch gives a
    // small dense system; an atlas, one sparse by patch, solved by
    // conjugate gradients from iterative_min_patches patches on.
    if (model_.num_patches() == 1) {
      solver.linear_solver_type = ceres::DENSE_QR;
    } else if (model_.num_patches() < options_.iterative_min_patches) {
      solver.linear_solver_type = SparseSolver();
    } else {
      solver.linear_solver_type = ceres::CGNR;
      solver.preconditioner_type = ceres::JACOBI;
      solver.eta = options_.iterative_eta;
    }
    solver.max_num_iterations = options_.max_iterations_per_level;
    // The window's frames are rendered side by side (RenderTermCallback);
    // a lone frame's pixels are split over the threads by the rasterizer
    // instead. Either way Ceres evaluates the residual blocks (the render
    // terms' row blocks, seams, temporal terms) on every thread: on a lone
    // frame too, 5-7% less time a frame (docs/benchmarks.md).
    solver.num_threads = ResolveNumThreads(options_.num_threads);
    solver.logging_type = ceres::SILENT;
    solver.update_state_every_iteration = true;
    return solver;
  }

  // PolySftOptions::check_coarse_levels before level l, for the window's
  // frames from `first` on (`entry`: each as the solve began).
  void CheckCoarseLevels(int l, size_t first, const std::vector<std::vector<double>>& entry) {
    bool moved = false;
    for (size_t k = first; k < window_.size(); ++k) moved |= window_[k]->theta != entry[k - first];
    if (!moved) return;
    ++summary_.coarse_moves_checked;
    const double now = LevelCost(l, first);
    std::vector<std::vector<double>> moved_to;
    for (size_t k = first; k < window_.size(); ++k) {
      moved_to.push_back(window_[k]->theta);
      window_[k]->theta = entry[k - first];
    }
    if (LevelCost(l, first) < now) {
      ++summary_.coarse_moves_undone;
      return;
    }
    for (size_t k = first; k < window_.size(); ++k) window_[k]->theta = moved_to[k - first];
  }

  // What level l's solve of the window's frames from `first` on would
  // start at: their image terms and regularisers (infinite when a surface
  // is behind the camera).
  double LevelCost(int l, size_t first) {
    double cost = 0.0;
    ceres::Problem problem;
    for (size_t k = first; k < window_.size(); ++k) {
      if (!window_[k]->mask_empty && (use_photometric_ || use_masks_)) {
        cost += 0.5 * ImageCost(l, *window_[k], window_[k]->theta.data());
      }
      AddRegularizers(k, l + 1 < static_cast<int>(levels_.size()), &problem);
    }
    double regularizers = 0.0;
    ceres::Problem::EvaluateOptions evaluate;
    evaluate.num_threads = ResolveNumThreads(options_.num_threads);
    if (problem.NumResidualBlocks() > 0 && !problem.Evaluate(evaluate, &regularizers, nullptr, nullptr, nullptr)) {
      return std::numeric_limits<double>::infinity();
    }
    return cost + regularizers;
  }

  // The first of the window's frames that the coarse levels' solves
  // change. They only bring the newest frame into the basin: an older
  // frame whose last solve settled at every level and that is tracked is
  // held there and refined with it on the finest; one that is not (a large
  // motion still converging, a frame found again or lost) passes through
  // the whole pyramid again.
  size_t FirstCoarseFreeFrame() const {
    if (!options_.coarse_levels_newest_only) return 0;
    size_t first = window_.size() - 1;
    while (first > 0 && !(window_[first - 1]->settled && Tracked(*window_[first - 1]))) --first;
    return first;
  }

  // Every level, coarse to fine. False (with the summary's failure set)
  // when the solve diverged or the surface went behind the camera.
  bool SolveWindow(double* cost, int* iterations) {
    const size_t coarse_first_free = FirstCoarseFreeFrame();
    // Cleared by any level solve of a frame that reaches its iteration cap.
    for (size_t k = coarse_first_free; k < window_.size(); ++k) window_[k]->settled = true;
    std::vector<std::vector<double>> entry;  // the frames the coarse levels solve, as they begin
    if (options_.check_coarse_levels) {
      for (size_t k = coarse_first_free; k < window_.size(); ++k) entry.push_back(window_[k]->theta);
    }
    for (int l = 0; l < static_cast<int>(levels_.size()); ++l) {
      if (l > 0 && options_.check_coarse_levels) CheckCoarseLevels(l, coarse_first_free, entry);
      // A lone frame's pixels are split over the threads by the rasterizer;
      // a window's frames are rendered side by side.
      const size_t first_free = l + 1 < static_cast<int>(levels_.size()) ? coarse_first_free : 0;
      solving_frames_ = static_cast<int>(window_.size() - first_free);
      SplitTerms split(solving_frames_ > 1 ? ResolveNumThreads(options_.num_threads) : 1);
      ceres::Problem::Options problem_options;
      problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
      problem_options.evaluation_callback = &split.callback;
      ceres::Problem problem(problem_options);
      for (size_t k = 0; k < window_.size(); ++k) {
        FrameData& frame = *window_[k];
        for (double* block : Blocks(frame.theta)) {
          problem.AddParameterBlock(block, model_.block_size());
          if (k < first_free) problem.SetParameterBlockConstant(block);
        }
        if (k < first_free) continue;
        if (!AddFrameTerms(l, k, &problem, &split)) {
          return Fail("frame " + std::to_string(frame.frame.index) + ": the surface went behind the camera");
        }
      }
      ceres::Solver::Options solver = LevelSolverOptions();
      SftIterationSummary row;
      row.frame = window_.back()->frame.index;
      row.window = window_.front()->frame.index;
      row.patches = model_.num_patches();
      row.recovery = recovery_;
      std::function<double()> e3d;
      if (scene_.ground_truth_kind == GroundTruthKind::kVertices) {
        FrameData* newest = window_.back().get();
        e3d = [this, newest] {
          Eigen::Matrix3Xd v;
          model_.Evaluate(newest->theta.data(), &v);
          return ComputeE3D(v, newest->frame.ground_truth);
        };
      }
      WindowCallback callback(options_, &summary_.trace, row, start_, e3d);
      if (l + 1 == static_cast<int>(levels_.size())) GoOnWhileTracked(&solver, &callback);
      solver.callbacks.push_back(&callback);
      ceres::Solver::Summary result;
      ceres::Solve(solver, &problem, &result);
      if (callback.capped()) result.termination_type = ceres::NO_CONVERGENCE;
      if (result.termination_type == ceres::FAILURE) {
        // Its start could not be evaluated: nothing moved, and its cost is
        // not the frame's.
        return Fail("frame " + std::to_string(window_.back()->frame.index) + ": the solve failed (" + result.message +
                    ")");
      }
      if (result.termination_type == ceres::NO_CONVERGENCE) {
        ++unconverged_solves_;
        for (size_t k = first_free; k < window_.size(); ++k) window_[k]->settled = false;
      }
      ++solves_;
      // Per frame of the window, so that windows of different sizes compare.
      *cost = result.final_cost / window_.size();
      *iterations += callback.iterations();
      for (const auto& frame : window_) {
        frame->patches = model_.num_patches();
        frame->vertex_patches = model_.vertex_patches();
        for (double v : frame->theta) {
          if (!std::isfinite(v)) {
            return Fail("frame " + std::to_string(window_.back()->frame.index) +
                        ": the solve diverged (non-finite parameters)");
          }
        }
      }
    }
    MeasureFeatureErrors();
    return true;
  }

  // PolySftOptions::tracked_finest_iterations: the finest level's solve
  // goes on past max_iterations_per_level while the window's cost per
  // frame is a tracked frame's (FitsFarWorse: the first frame always).
  void GoOnWhileTracked(ceres::Solver::Options* solver, WindowCallback* callback) const {
    if (options_.tracked_finest_iterations <= options_.max_iterations_per_level) return;
    solver->max_num_iterations = options_.tracked_finest_iterations;
    const double frames = static_cast<double>(window_.size());
    const int t = window_.back()->frame.index - scene_.first_frame;
    callback->GoOnPast(options_.max_iterations_per_level,
                       [this, frames, t](double cost) { return !FitsFarWorse(t, cost / frames); });
  }

  // Splits patch p (SplitPatch's child_of_vertex) and carries the window's
  // parameters, the frame before's and the atlas's terms over to it.
  PatchSplit SplitPatchInPlace(int p, const std::vector<int>& child) {
    const PatchSplit split = model_.SplitPatch(p, child);
    for (auto& frame : window_) frame->theta = model_.InheritParameters(split, frame->theta);
    for (auto& theta : final_thetas_) theta = model_.InheritParameters(split, theta);
    atlas_terms_ = GroupAtlasTerms(model_, edges_, rest_lengths_, Hinges());
    render_groups_ = MakePatchGroups(model_, scene_.template_mesh.faces);
    return split;
  }

  // A split kept: each frame's start too (RecoverLostFrame compares
  // against it), and every patch may be tested again (numbered anew).
  void KeepSplit(const PatchSplit& split) {
    for (auto& frame : window_) frame->start = model_.InheritParameters(split, frame->start);
    failed_ratio_.assign(model_.num_patches(), 0.0);
  }

  // PatchAtlasOptions::hidden_split_share, after frame t's window is
  // solved: true when a patch split.
  bool SplitAlongOcclusion(int t) {
    const double min_share = options_.atlas.hidden_split_share;
    if (!(min_share > 0.0) || t == 0 || !model_.can_split()) return false;
    if (hidden_patches_ + 1 > options_.atlas.max_hidden_patches) return false;
    FrameData& newest = *window_.back();
    Eigen::Matrix3Xd vertices;
    model_.Evaluate(newest.theta.data(), &vertices);
    std::vector<int> occluders;
    std::vector<std::uint8_t> occluded = HiddenVertices(vertices, &occluders);
    if (occluded.empty()) return false;
    // A layer under another: hidden, facing the camera as in the template,
    // and hidden by a part turned over (the cloth under a flap folded onto
    // it). A hidden vertex turned away (a drape's far side) or hidden by a
    // part that faces as it does (a wave's crest, a sheet seen edge-on) is
    // on one sheet with what hides it, which the jets they share carry on.
    const Facing facing = FacesCamera(vertices);
    for (int v = 0; v < model_.num_vertices(); ++v) {
      const int f = occluders[v];
      occluded[v] &=
          facing.vertices[v] == template_facing_.vertices[v] && f >= 0 && facing.faces[f] != template_facing_.faces[f];
    }
    const std::vector<int> sizes = model_.PatchSizes();
    int best = -1;
    double best_balance = 0.0;
    std::vector<int> hidden(model_.num_patches(), 0);  // per patch, its vertices hidden
    for (int v = 0; v < model_.num_vertices(); ++v) hidden[model_.patch_of_vertex(v)] += occluded[v] ? 1 : 0;
    for (int p = 0; p < model_.num_patches(); ++p) {
      const int h = hidden[p], seen = sizes[p] - hidden[p];
      if (h < options_.atlas.min_hidden_vertices || seen < 3) continue;
      const double share = static_cast<double>(std::min(h, seen)) / sizes[p];
      if (share >= min_share && share > best_balance) best_balance = share, best = p;
    }
    if (best < 0) return false;
    std::vector<int> child(model_.num_vertices(), -1);
    for (int v = 0; v < model_.num_vertices(); ++v) {
      if (model_.patch_of_vertex(v) == best) child[v] = occluded[v] ? 1 : 0;
    }
    const PatchSplit split = SplitPatchInPlace(best, child);
    KeepSplit(split);
    ++hidden_patches_;
    // No score test: its ratio, significance and step are 0.
    summary_.splits.push_back({newest.frame.index, best, split.num_children, 0.0, 0.0, 0.0});
    return true;
  }

  // After frame t's window is solved: on the first frame, the image
  // residual per vertex (the floor); later, the patch that fits worst
  // against its floor is split if the split passes the score test (below);
  // true when it was, and the window must be solved again.
  bool RefineAtlas(int t) {
    if (!model_.can_split() || options_.atlas.max_patches <= 1 || (!use_photometric_ && !use_masks_)) return false;
    FrameData& newest = *window_.back();
    if (newest.mask_empty || (t > 0 && floor_squared_.size() == 0)) return false;
    // A frame that is not tracked (lost, or its colours not the texture's)
    // or did not settle fits badly for want of tracking, not of patches: a
    // split there only frees the sheet to fit what it cannot find.
    // A frame its keypoints find that still fits far worse than the
    // tracked ones (a cloth in continuous motion, falling or flapping,
    // that never settles) may split unsettled: its misfit is the model's,
    // and the score test below still asks that the split pay. One that
    // fits about as well as the tracked ones waits until it settles.
    const bool found_misfit = Lost(newest) && FoundByKeypoints(&newest);
    if (t > 0 && !(Tracked(newest) && (newest.settled || found_misfit))) return false;
    // The residual's splits' room: the hidden splits' children count apart.
    PatchAtlasOptions room = options_.atlas;
    room.max_patches += hidden_patches_;
    // A full atlas: nothing to measure.
    if (t > 0 && model_.num_patches() + room.FewestChildren() - 1 > room.max_patches) return false;
    RenderCost::Data d;
    if (!ImageTerm(static_cast<int>(levels_.size()) - 1, newest, false, &d) || d.roi.area() <= 0) return false;
    const int channels = d.mask.empty() ? 3 : 4;
    Eigen::VectorXd squared, pixels;
    if (!RenderCost(std::move(d)).VertexResiduals(newest.theta.data(), &squared, &pixels)) return false;
    if (t == 0) {
      floor_squared_ = squared;
      floor_pixels_ = pixels;
      // Per residual, in the cost's units (1/2 r^2).
      noise_cost_ = 0.5 * squared.sum() / std::max(pixels.sum(), 1.0) / channels;
      return false;
    }
    std::vector<double> ratios;
    const std::vector<int> chosen = PatchesToSplit(room, model_, squared, pixels, floor_squared_, floor_pixels_, &ratios);
    // A patch that failed the test is tried again only once it fits worse
    // than it did then: on a smooth scene the same patch would otherwise
    // be tested, and fail, every frame.
    failed_ratio_.resize(model_.num_patches(), 0.0);
    const auto untried =
        std::find_if(chosen.begin(), chosen.end(), [&](int q) { return ratios[q] > failed_ratio_[q]; });
    if (untried == chosen.end()) return false;
    const int p = *untried;
    const std::vector<int> child =
        SplitPatchVertices(scene_.template_mesh, model_.vertex_patches(), p,
                           options_.atlas.ChildrenFor(model_.PatchSizes()[p]));
    if (child.empty()) return false;
    // The score test: the decrease one Gauss-Newton step on the newest
    // frame would give with the split, beyond what it gives without, against
    // what its extra parameters would gain from noise alone (about one
    // residual's variance each).
    const double before = PredictedDecrease();
    const JetDeformationModel unsplit = model_;
    const AtlasTerms unsplit_terms = atlas_terms_;
    const PatchGroups unsplit_groups = render_groups_;
    std::vector<std::vector<double>> thetas;
    for (auto& frame : window_) thetas.push_back(frame->theta);
    const std::vector<std::vector<double>> finals = final_thetas_;
    const PatchSplit split = SplitPatchInPlace(p, child);
    Eigen::VectorXd step;
    const double gain = PredictedDecrease(&step) - before;
    const double noise = (split.num_children - 1) * model_.block_size() * noise_cost_;
    const double step_pixels = step.size() == model_.num_parameters() ? LargestStepPixels(newest, step, child) : 0.0;
    if (gain > options_.atlas.split_significance * noise && step_pixels >= options_.atlas.split_min_step_pixels) {
      summary_.splits.push_back({newest.frame.index, p, split.num_children, ratios[p], gain / noise, step_pixels});
      KeepSplit(split);
      return true;
    }
    model_ = unsplit;
    atlas_terms_ = unsplit_terms;
    render_groups_ = unsplit_groups;
    for (size_t k = 0; k < window_.size(); ++k) window_[k]->theta = thetas[k];
    final_thetas_ = finals;
    failed_ratio_[p] = ratios[p];
    return false;
  }

  // How far the score test's step moves the split patch's vertices in the
  // finest level's image (the largest, in pixels): a split whose step moves
  // nothing visibly refines what one jet already holds.
  double LargestStepPixels(const FrameData& frame, const Eigen::VectorXd& step, const std::vector<int>& child) const {
    Eigen::Matrix3Xd before, after;
    model_.Evaluate(frame.theta.data(), &before);
    std::vector<double> moved = frame.theta;
    for (Eigen::Index i = 0; i < step.size(); ++i) moved[i] += step[i];
    model_.Evaluate(moved.data(), &after);
    const PinholeCamera& camera = levels_.back().camera;
    double largest = 0.0;
    for (Eigen::Index i = 0; i < before.cols(); ++i) {
      if (child[i] < 0 || !(before(2, i) > 0.0) || !(after(2, i) > 0.0)) continue;
      largest = std::max(largest, (camera.Project(after.col(i)) - camera.Project(before.col(i))).norm());
    }
    return largest;
  }

  // The decrease of the newest frame's cost at the finest level that one
  // Gauss-Newton step (lightly damped) would give, the other frames held.
  double PredictedDecrease(Eigen::VectorXd* step_out = nullptr) {
    SplitTerms split(1);  // one frame, its render on the rasterizer's threads
    solving_frames_ = 1;
    ceres::Problem::Options problem_options;
    problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
    problem_options.evaluation_callback = &split.callback;
    ceres::Problem problem(problem_options);
    const size_t k = window_.size() - 1;
    FrameData& frame = *window_[k];
    const std::vector<double*> blocks = Blocks(frame.theta);
    for (double* block : blocks) problem.AddParameterBlock(block, model_.block_size());
    if (!AddFrameTerms(static_cast<int>(levels_.size()) - 1, k, &problem, &split)) return 0.0;
    ceres::Problem::EvaluateOptions evaluate;
    evaluate.parameter_blocks = blocks;
    evaluate.num_threads = ResolveNumThreads(options_.num_threads);
    double cost = 0.0;
    std::vector<double> gradient;
    ceres::CRSMatrix crs;
    if (!problem.Evaluate(evaluate, &cost, nullptr, &gradient, &crs)) return 0.0;
    const int n = crs.num_cols;
    // J^T J from the rows' non-zeros only: a dense update per row would cost
    // n^2 a row, most of a refinement's time on a large atlas.
    Eigen::MatrixXd jtj = Eigen::MatrixXd::Zero(n, n);
    for (int r = 0; r < crs.num_rows; ++r) {
      for (int e = crs.rows[r]; e < crs.rows[r + 1]; ++e) {
        const double v = crs.values[e];
        for (int f = crs.rows[r]; f < crs.rows[r + 1]; ++f) jtj(crs.cols[f], crs.cols[e]) += v * crs.values[f];
      }
    }
    const Eigen::Map<const Eigen::VectorXd> g(gradient.data(), n);
    Eigen::MatrixXd damped = jtj;
    damped.diagonal() *= 1.0 + 1e-4;
    const Eigen::VectorXd step = -damped.ldlt().solve(g);
    if (step_out != nullptr) *step_out = step;
    return std::max(0.0, -(g.dot(step) + 0.5 * step.dot(jtj * step)));
  }

  // A newest frame that fits far worse than the first, its window solved
  // again from other starts of the frame, the better kept:
  // recover_lost_frames moves it onto its mask, relocalize places the
  // template on its keypoints (unless its start already was that).
  void RecoverLostFrame(int t, double* cost, int* iterations) {
    FrameData& newest = *window_.back();
    if (t == 0 || newest.mask_empty) return;
    auto lost = [&] {
      char why[80];
      std::snprintf(why, sizeof(why), "lost (cost %.0f times the tracked frames')", CostRatio(*cost));
      return std::string(why);
    };
    if (options_.recover_lost_frames && use_masks_ && !newest.frame.mask.empty() && FitsFarWorse(t, *cost)) {
      SolveAgainFrom(kRecoveryMask, lost(), "moved onto its mask", [&](int*) { return MoveOntoMask(&newest); }, cost,
                     iterations);
    }
    if (options_.relocalize && use_photometric_ && !newest.relocalized && FitsFarWorse(t, *cost)) {
      // Not where its keypoints find the surface already (its misfit is
      // the model's: a fold one jet cannot hold), nor where the template
      // placed on them fits the coarsest level worse than the frame's own
      // start did (a surface too deformed for one rigid motion).
      auto place = [&](int*) {
        if (newest.features.empty()) SeekKeypoints(&newest);
        if (KeypointsAgree(newest)) return false;
        return PlaceOnKeypoints(&newest) && FitsCoarsestBetter(newest, newest.start);
      };
      newest.relocalized =
          SolveAgainFrom(kRecoveryKeypoints, lost(), "placed on its keypoints", place, cost, iterations);
    }
  }

  // Whether a frame with a new crease is solved again (any of
  // SecondOpinionOnNewCrease's starts is on).
  bool NewCreaseOpinions() const {
    return options_.new_crease_bending_weight > 0.0 || options_.mirror_new_creases ||
           options_.new_crease_from_frame_before;
  }

  // trace.csv's `recovery`: the re-solve's start (RecoverLostFrame,
  // SecondOpinionOnNewCrease).
  static constexpr int kRecoveryMask = 1;
  static constexpr int kRecoveryKeypoints = 2;
  static constexpr int kRecoveryBending = 3;
  static constexpr int kRecoveryMirror = 4;
  static constexpr int kRecoveryFrameBefore = 5;
  static constexpr int kRecoveryFlip = 6;

  // The window solved again from `restart`'s change to the newest frame
  // (which may solve it itself, counting its iterations in `more`), where
  // the change was made; kept (true) where it ends at a lower cost, and
  // said in a warning that begins with `why`.
  bool SolveAgainFrom(int recovery, const std::string& why, const char* how,
                      const std::function<bool(int* more)>& restart, double* cost, int* iterations) {
    std::vector<std::vector<double>> before;
    std::vector<bool> settled;
    for (const auto& frame : window_) {
      before.push_back(frame->theta);
      settled.push_back(frame->settled);
    }
    // A failed attempt leaves no trace but its rows (SolveWindow fails the
    // run only through Fail).
    const TerminationType termination = summary_.termination_type;
    const std::string message = summary_.message;
    recovery_ = recovery;
    double again = 0.0;
    int more = 0;
    const bool solved = restart(&more) && SolveWindow(&again, &more);
    recovery_ = 0;
    if (solved && again < *cost) {
      char buffer[100];
      std::snprintf(buffer, sizeof(buffer), "; %s and solved again: cost %.3g -> %.3g", how, *cost, again);
      summary_.warnings.emplace_back("frame " + std::to_string(window_.back()->frame.index) + ": " + why + buffer);
      *cost = again;
      *iterations += more;
      return true;
    }
    summary_.termination_type = termination;
    summary_.message = message;
    for (size_t k = 0; k < window_.size(); ++k) {
      window_[k]->theta = before[k];
      window_[k]->settled = settled[k];
    }
    return false;
  }

  // PolySftOptions::new_crease_bending_weight: a frame whose solve made a
  // new crease solved again from its start under a bending prior, then
  // without it from there; mirror_new_creases, with its flap mirrored;
  // new_crease_from_frame_before, from where the frame before ended. The
  // lowest cost kept.
  void SecondOpinionOnNewCrease(int t, double* cost, int* iterations) {
    FrameData& newest = *window_.back();
    if (t == 0 || newest.mask_empty || !NewCreaseOpinions() || hinges_.hinges.empty()) return;
    // Measured since the frame before; failing that, over the span.
    int span = 1;
    std::vector<double> changes = HingeChanges(span);
    auto largest = [&] { return changes.empty() ? 0.0 : *std::max_element(changes.begin(), changes.end()); };
    double crease = largest();
    if (!(crease > options_.new_crease_angle_deg)) {
      span = std::min(options_.new_crease_span_frames, FramesBack());
      if (span <= 1) return;
      changes = HingeChanges(span);
      crease = largest();
      if (!(crease > options_.new_crease_angle_deg)) return;
    }
    char why[80];
    if (span == 1) {
      std::snprintf(why, sizeof(why), "a new crease (%.0f deg)", crease);
    } else {
      std::snprintf(why, sizeof(why), "a new crease (%.0f deg over %d frames)", crease, span);
    }
    const bool bend = options_.new_crease_bending_weight > 0.0;
    bool bent_kept = false;
    if (bend) {
      auto bent = [&](int* more) {
        newest.theta = newest.start;
        bending_prior_on_ = true;
        double bent_cost = 0.0;
        const bool solved = SolveWindow(&bent_cost, more);
        bending_prior_on_ = false;
        return solved;
      };
      bent_kept =
          SolveAgainFrom(kRecoveryBending, why, "from its start under a bending prior", bent, cost, iterations);
    }
    // Measured again where the bending prior's opinion was kept.
    if (options_.mirror_new_creases) MirrorNewCrease(why, bent_kept ? HingeChanges(span) : changes, cost, iterations);
    // A crease grown over several frames has the frame before in it.
    if (options_.new_crease_from_frame_before && newest.moved_start && span == 1) {
      // Copied: the window's solve moves the frame before too.
      const std::vector<double> before = *Solved(1);
      auto from_before = [&](int*) {
        newest.theta = before;
        return true;
      };
      SolveAgainFrom(kRecoveryFrameBefore, why, "from where the frame before ended", from_before, cost, iterations);
    }
  }

  // PolySftOptions::mirror_new_creases: the newest frame's flap beyond its
  // new crease (the hinges that turned by more than half
  // new_crease_angle_deg over the trigger's span) mirrored about the sheet
  // beside it (MirrorFoldFlap), or, where the crease cuts no flap off, its
  // band turned inside out along the rays (flip_new_crease_bands,
  // FlipCreaseAlongRays); the frame fitted to that and solved again, the
  // lower final cost kept.
  // changes: HingeChanges(span) at the newest frame as it stands.
  void MirrorNewCrease(const std::string& why, const std::vector<double>& changes, double* cost, int* iterations) {
    if (changes.empty()) return;
    std::vector<std::uint8_t> crease(changes.size());
    for (size_t h = 0; h < changes.size(); ++h) crease[h] = changes[h] > 0.5 * options_.new_crease_angle_deg;
    Eigen::Matrix3Xd now, mirrored;
    model_.Evaluate(window_.back()->theta.data(), &now);
    auto fitted = [&](int*) {
      FitNewestFrameTo(mirrored);
      return true;
    };
    if (MirrorFoldFlap(scene_.template_mesh, hinges_.hinges, crease, now, &mirrored) > 0) {
      SolveAgainFrom(kRecoveryMirror, why, "its flap mirrored about the crease", fitted, cost, iterations);
    } else if (options_.flip_new_crease_bands &&
               FlipCreaseAlongRays(scene_.template_mesh, hinges_.hinges, crease, now, &mirrored) > 0) {
      SolveAgainFrom(kRecoveryFlip, why, "its crease turned inside out along the rays", fitted, cost, iterations);
    }
  }

  // How many frames before the newest are kept (in the window or
  // finalised), for HingeChanges.
  int FramesBack() const { return static_cast<int>(window_.size() + finals_.size()) - 1; }

  // Per hinge of hinges_, how far its dihedral angle turned (degrees) from
  // `back` frames before the newest (1 <= back <= FramesBack()) to the
  // newest; empty without a frame before.
  std::vector<double> HingeChanges(int back) const {
    Eigen::Matrix3Xd now, before;
    const int in_window = static_cast<int>(window_.size()) - 1;
    if (back <= in_window) {
      model_.Evaluate(window_[in_window - back]->theta.data(), &before);
    } else if (back - in_window - 1 < static_cast<int>(finals_.size())) {
      before = finals_[back - in_window - 1];
    } else {
      return {};
    }
    model_.Evaluate(window_.back()->theta.data(), &now);
    return HingeTurnsDeg(hinges_.hinges, now, before);
  }

  // Translates the frame's surface parallel to the image, at its mean
  // depth, so that its vertices' projected centroid is the mask's.
  bool MoveOntoMask(FrameData* frame) const {
    const cv::Moments m = cv::moments(frame->frame.mask > 0.5, true);
    if (m.m00 <= 0.0) return false;
    Eigen::Matrix3Xd vertices;
    model_.Evaluate(frame->theta.data(), &vertices);
    Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
    for (int i = 0; i < vertices.cols(); ++i) centroid += scene_.camera.Project(vertices.col(i));
    centroid /= static_cast<double>(vertices.cols());
    const double depth = vertices.row(2).mean();
    const Eigen::Vector3d shift((m.m10 / m.m00 - centroid.x()) * depth / scene_.camera.fx,
                                (m.m01 / m.m00 - centroid.y()) * depth / scene_.camera.fy, 0.0);
    if (!shift.allFinite() || !(depth > 0.0)) return false;
    // X = s R_O (... + T_p) + T_O for the patch jet; X = ... + T_c in
    // texture space.
    const Eigen::Vector3d step =
        model_.texture_space()
            ? shift
            : Eigen::Vector3d(model_.patch().frame.rotation.transpose() * shift / model_.patch().frame.scale);
    for (int p = 0; p < model_.num_patches(); ++p) {
      double* translation =
          frame->theta.data() + static_cast<size_t>(p) * model_.block_size() + model_.translation_offset();
      for (int k = 0; k < 3; ++k) translation[k] += step[k];
    }
    return true;
  }

  const HingeRest* Hinges() const { return hinges_.hinges.empty() ? nullptr : &hinges_; }

  bool Fail(const std::string& message) {
    summary_.termination_type = TerminationType::kFailure;
    summary_.message = message + "; frames before the window are kept";
    return false;
  }

  void FinalizeOldestFrame() {
    FrameData& data = *window_.front();
    const int t = data.frame.index - scene_.first_frame;
    FinalizeFrame(data, frame_time_[t], frame_cost_[t], frame_iterations_[t]);
    window_.pop_front();
  }

  // The frame's result, its error against ground truth, and a warning when
  // it fits far worse than the tracked frames and no keypoints find it
  // (tracking probably lost).
  void FinalizeFrame(FrameData& data, double time_s, double cost, int iterations) {
    if (Lost(data) && !(data.feature_error <= FoundFeatureError())) {
      char buffer[200];
      std::snprintf(buffer, sizeof(buffer),
                    "frame %d: cost %.3g is %.0f times the tracked frames': tracking may be lost (motion too large "
                    "between frames?)",
                    data.frame.index, cost, CostRatio(cost));
      summary_.warnings.emplace_back(buffer);
    }
    // Matched at the finest level from the frame's nearly final estimate.
    if (data.brightness.correlation < 0.2) {
      char buffer[200];
      std::snprintf(buffer, sizeof(buffer),
                    "frame %d: its colours barely correlate with the texture's where the surface is (%.2f): "
                    "tracking may be lost",
                    data.frame.index, data.brightness.correlation);
      summary_.warnings.emplace_back(buffer);
    }
    SftFrameSummary result;
    result.index = data.frame.index;
    model_.Evaluate(data.theta.data(), &result.vertices);
    result.time_s = time_s;
    result.cost = cost;
    result.iterations = iterations;
    result.patches = data.patches;
    result.vertex_patches = data.vertex_patches;
    result.flow_matches = static_cast<int>(data.flow.size());
    result.flow_start = data.flow_started;
    result.keypoint_matches = static_cast<int>(data.features.size());
    result.relocalized = data.relocalized;
    if (scene_.ground_truth_kind == GroundTruthKind::kVertices) {
      const Eigen::Matrix3Xd& gt = data.frame.ground_truth;
      result.e3d = ComputeE3D(result.vertices, gt);
      result.normal_error_deg = ComputeNormalErrorDeg(scene_.template_mesh.faces, result.vertices, gt);
      result.rmse_mm = ComputeRmseMm(result.vertices, gt);
      summary_.template_e3d += ComputeE3D(scene_.template_mesh.vertices, gt);
      summary_.template_rmse_mm += ComputeRmseMm(scene_.template_mesh.vertices, gt);
    } else if (scene_.ground_truth_kind == GroundTruthKind::kPoints) {
      TriangleMesh surface;
      surface.vertices = result.vertices;
      surface.faces = scene_.template_mesh.faces;
      result.chamfer_1e4 = ComputePointChamfer1e4(surface, data.frame.ground_truth);
    }
    // The frames before the window that temporal_order and
    // new_crease_span_frames read, newest first.
    finals_.insert(finals_.begin(), result.vertices);
    const int kept = std::max(2, options_.new_crease_span_frames - options_.window_size + 1);
    finals_.resize(std::min<size_t>(finals_.size(), kept));
    final_thetas_.insert(final_thetas_.begin(), data.theta);
    final_thetas_.resize(finals_.size());
    previous_final_tracked_ = Tracked(data);
    summary_.frames.push_back(result);
    if (on_frame_) on_frame_(summary_.frames.back());
  }

  void Summarize() {
    PolySftSummary& s = summary_;
    s.total_time_s = Seconds(start_);
    s.mean_time_per_frame_s = s.frames.empty() ? 0.0 : s.total_time_s / s.frames.size();
    s.mean_e3d = Mean(s.frames, &SftFrameSummary::e3d);
    s.mean_normal_error_deg = Mean(s.frames, &SftFrameSummary::normal_error_deg);
    s.mean_rmse_mm = Mean(s.frames, &SftFrameSummary::rmse_mm);
    s.mean_chamfer_1e4 = Mean(s.frames, &SftFrameSummary::chamfer_1e4);
    s.patch_vertices = model_.PatchSizes();
    if (std::isfinite(s.template_e3d) && !s.frames.empty()) {
      s.template_e3d /= s.frames.size();
      s.template_rmse_mm /= s.frames.size();
    }
    if (s.termination_type != TerminationType::kFailure && unconverged_solves_ > 0) {
      s.termination_type = TerminationType::kNoConvergence;
      s.message = std::to_string(unconverged_solves_) + " of " + std::to_string(solves_) +
                  " level solves reached max_iterations_per_level";
    }
  }

  const PolySftOptions& options_;
  const SftScene& scene_;
  const SftFrameCallback& on_frame_;
  const Clock::time_point start_;
  const Eigen::Matrix2Xd vertex_texcoords_;
  JetDeformationModel model_;
  AtlasTerms atlas_terms_;
  PatchGroups render_groups_;  // the render term's residual blocks (an atlas's)
  int solving_frames_ = 1;     // the window's frames a level's solve changes
  double mean_edge_ = 0.0;     // the template's, in metres
  // The image residual per vertex on the first frame (the floor a patch's
  // fit is compared with).
  Eigen::VectorXd floor_squared_, floor_pixels_;
  double noise_cost_ = 0.0;
  // Per patch, its residual ratio when it last failed the split's test (0:
  // not tested since the last split).
  std::vector<double> failed_ratio_;
  PolySftSummary summary_;
  bool use_masks_ = false, use_temporal_ = false, use_photometric_ = false, use_inextensibility_ = false;
  std::optional<Eigen::Vector3d> gravity_shift_;  // g dt^2, with the physics prior
  bool use_features_ = false;
  double feature_weight_ = 0.0;  // the keypoints' weight, once on
  bool use_flow_ = false;
  // The template's keypoints on the surface (with use_features_), and the
  // finest level's texture they are rendered with.
  std::unique_ptr<TextureFeatures> features_;
  // FacesCamera of the template (SplitAlongOcclusion).
  Facing template_facing_;
  int hidden_patches_ = 0;  // patches the hidden splits added
  ScreenMesh mesh_template_;
  double size_ = 0.0;                         // the template's bounding-box diagonal
  SoftRasterizerOptions rasterizer_options_;  // options_.rasterizer, gamma from depth_softness
  std::vector<Eigen::Vector2i> edges_;
  std::vector<double> rest_lengths_;
  // With PolySftOptions::bending_weight or new_crease_bending_weight only;
  // the latter's prior is on during its second opinion.
  HingeRest hinges_;
  bool bending_prior_on_ = false;
  double template_pixels_ = 0.0;
  std::vector<LevelData> levels_;
  std::deque<std::unique_ptr<FrameData>> window_;
  // The frames before the window (two, or as many as new_crease_span_frames
  // needs), newest first, once there are.
  std::vector<Eigen::Matrix3Xd> finals_;
  std::vector<std::vector<double>> final_thetas_;  // their parameters
  bool previous_final_tracked_ = true;
  int recovery_ = 0;  // solving a lost frame again (RecoverLostFrame): its kRecovery start
  Eigen::Matrix3Xd previous_truth_;  // the last frame's ground truth (ground_truth_start kFrameBefore)
  std::vector<double> frame_time_, frame_cost_;
  std::vector<double> tracked_costs_;  // the final costs of the frames not lost, in order
  std::vector<int> frame_iterations_;
  int solves_ = 0, unconverged_solves_ = 0;
};

}  // namespace

PolySftSummary SolvePolySft(const PolySftOptions& options, const SftScene& scene, const SftFrameCallback& on_frame) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw std::invalid_argument("PolySftOptions: " + problem);
  }
  return PolySftController(options, scene, on_frame).Run();
}

std::string PolySftSummary::BriefReport() const {
  char line[512];
  int n = std::snprintf(line, sizeof(line), "%s: %zu frames in %.2f s (%.3f s per frame)",
                        TerminationTypeToString(termination_type), frames.size(), total_time_s, mean_time_per_frame_s);
  if (std::isfinite(mean_e3d)) {
    n += std::snprintf(line + n, sizeof(line) - n,
                       "; mean e3D %.4f, e_n %.2f deg, RMSE %.2f mm (template held still: e3D %.4f, RMSE %.1f mm)",
                       mean_e3d, mean_normal_error_deg, mean_rmse_mm, template_e3d, template_rmse_mm);
  }
  if (std::isfinite(mean_chamfer_1e4) && n < static_cast<int>(sizeof(line))) {
    n += std::snprintf(line + n, sizeof(line) - n, "; mean Chamfer x1e4 %.4f", mean_chamfer_1e4);
  }
  std::string report = line;
  if (!message.empty()) report += " (" + message + ")";
  return report;
}

void WriteSftOutputs(const std::string& directory, const SftScene& scene, const PolySftOptions& options,
                     const PolySftSummary& summary) {
  namespace fs = std::filesystem;
  std::error_code error;
  fs::create_directories(fs::path(directory) / "meshes", error);
  if (error) throw Error(ErrorKind::kOutput, directory + ": cannot create the folder: " + error.message());
  TriangleMesh mesh;
  mesh.faces = scene.template_mesh.faces;
  for (const SftFrameSummary& frame : summary.frames) {
    char name[32];
    std::snprintf(name, sizeof(name), "%06d.ply", frame.index);
    mesh.vertices = frame.vertices;
    WritePly((fs::path(directory) / "meshes" / name).string(), mesh);
  }
  WriteFileAtomically((fs::path(directory) / "trace.csv").string(), [&](std::ostream& trace) {
    // The scene format's columns first; then the atlas's patches and
    // whether the row re-solves a lost frame.
    trace << "frame,window,iteration,time_s,cost,e3d,patches,recovery\n";
    for (const SftIterationSummary& r : summary.trace) {
      trace << r.frame << ',' << r.window << ',' << r.iteration << ',' << r.time_s << ',' << r.cost << ',';
      if (std::isfinite(r.e3d)) trace << r.e3d;
      trace << ',' << r.patches << ',' << r.recovery << '\n';
    }
  });
  nlohmann::json frames = nlohmann::json::array();
  for (const SftFrameSummary& f : summary.frames) {
    frames.push_back({{"frame", f.index},
                      {"time_s", f.time_s},
                      {"cost", f.cost},
                      {"iterations", f.iterations},
                      {"patches", f.patches},
                      {"flow_matches", f.flow_matches},
                      {"flow_start", f.flow_start},
                      {"keypoint_matches", f.keypoint_matches},
                      {"relocalized", f.relocalized},
                      {"e3d", JsonNumber(f.e3d)},
                      {"e_n_deg", JsonNumber(f.normal_error_deg)},
                      {"rmse_mm", JsonNumber(f.rmse_mm)},
                      {"chamfer_1e4", JsonNumber(f.chamfer_1e4)}});
  }
  nlohmann::json splits = nlohmann::json::array();
  for (const SftPatchSplit& s : summary.splits) {
    splits.push_back({{"frame", s.frame},
                      {"patch", s.patch},
                      {"children", s.children},
                      {"ratio", JsonNumber(s.ratio)},
                      {"significance", JsonNumber(s.significance)},
                      {"step_px", JsonNumber(s.step_pixels)}});
  }
  nlohmann::json terms = nlohmann::json::object();
  for (const auto& [name, weight] : summary.terms) terms[name] = weight;
  const nlohmann::json metrics = {
      {"scene", scene.directory},
      {"termination", TerminationTypeToString(summary.termination_type)},
      {"message", summary.message},
      {"frames", frames},
      {"mean",
       {{"e3d", JsonNumber(summary.mean_e3d)},
        {"e_n_deg", JsonNumber(summary.mean_normal_error_deg)},
        {"rmse_mm", JsonNumber(summary.mean_rmse_mm)},
        {"chamfer_1e4", JsonNumber(summary.mean_chamfer_1e4)},
        {"time_per_frame_s", summary.mean_time_per_frame_s}}},
      {"baseline_template_still",
       {{"e3d", JsonNumber(summary.template_e3d)}, {"rmse_mm", JsonNumber(summary.template_rmse_mm)}}},
      {"total_time_s", summary.total_time_s},
      {"deformation", summary.deformation},
      {"atlas",
       {{"patches", summary.patch_vertices.size()}, {"patch_vertices", summary.patch_vertices}, {"splits", splits}}},
      {"active_terms", terms},
      {"silhouette_band_px", summary.silhouette_band_px},
      {"pyramid_levels", summary.pyramid_levels},
      {"coarse_moves", {{"checked", summary.coarse_moves_checked}, {"undone", summary.coarse_moves_undone}}},
      {"warnings", summary.warnings},
      {"settings", PolySftSettingsToJson(options)}};
  WriteFileAtomically((fs::path(directory) / "metrics.json").string(),
                      [&](std::ostream& out) { out << metrics.dump(2) << '\n'; });
}

}  // namespace polyfit
