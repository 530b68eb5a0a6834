// Time of OneFit's inference per frame on one core: body features, the
// network (the garment's half of the decoder precomputed), the garment's
// skinning and its vertices from the patches, against the garment's
// resolution (a tube around the torso, about 500 to 8,000 vertices, patched
// by area into about as many patches as the 2k suit has) and the network's
// width, with and without a warp head, the local pose and the body
// proximity at five or nine probes a patch (which poses the body each
// frame), and with the feedback decoder (default width) after it, once
// or twice; the network in single precision (OneFitDraper's default) and,
// for the shipped inputs (feedback once), also in double; and of that the
// garment's positions alone (PositionsAt); and with the relaxation that
// `onefit drape` runs after it (NetworkRelaxation, its defaults). Random weights:
// the time does not depend on them. The
// MakeHuman body when the shared data is there (its rig's features), else the procedural body.
//
//   onefit_inference_benchmark [BODY_DIR [PATCH_AREA]]
//   (PATCH_AREA, m^2: 0.006 gives the tube about the suit's 95 patches at
//   0.04 m^2, 0.003 about its 170 at 0.01 m^2)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "drape/network/onefit_draper.h"
#include "drape/simulate/drape_inputs.h"
#include "drape/simulate/drape_solver.h"
#include "drape/simulate/network_relaxation.h"
#include "polyfit/mesh/primitives.h"

namespace {

using polyfit::JointTransforms;

// Every joint turned a little about the vertical, differently per frame.
std::vector<JointTransforms> Poses(int joints, int frames) {
  std::vector<JointTransforms> poses;
  for (int t = 0; t < frames; ++t) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::AngleAxisd(0.05 * std::sin(0.3 * t), Eigen::Vector3d::UnitY()).toRotationMatrix();
    poses.emplace_back(joints, pose);
  }
  return poses;
}

struct Inputs {
  int warp_order;
  bool local_pose;
  int proximity_probes;  // 0: no body proximity
  bool feedback = false;
  int feedback_passes = 1;
};

polyfit::OneFitModel RandomModel(const polyfit::SkinnedBody& body, int width, const Inputs& inputs) {
  polyfit::OneFitNetworkOptions options;
  options.decoder_hidden = {width, width, width};
  options.body_hidden = {width, width};
  options.warp_order = inputs.warp_order;
  options.local_pose = inputs.local_pose;
  options.body_proximity = inputs.proximity_probes > 0;
  if (options.body_proximity) options.proximity_probes = inputs.proximity_probes;
  options.feedback = inputs.feedback;
  options.feedback_passes = inputs.feedback_passes;
  const int joints = body.skeleton.num_joints(), order = 4;
  polyfit::OneFitModel model;
  model.jet_order = order;
  model.num_joints = joints;
  model.network = polyfit::OneFitNetwork(polyfit::PatchFeatureSize(order, joints), polyfit::BodyFeatureSize(joints),
                                         polyfit::NumJetCoefficients(order), options);
  model.patch_normalizer.mean = Eigen::VectorXd::Zero(polyfit::PatchFeatureSize(order, joints));
  model.patch_normalizer.inv_std = Eigen::VectorXd::Ones(polyfit::PatchFeatureSize(order, joints));
  model.body_normalizer.mean = Eigen::VectorXd::Zero(polyfit::BodyFeatureSize(joints));
  model.body_normalizer.inv_std = Eigen::VectorXd::Ones(polyfit::BodyFeatureSize(joints));
  model.weights.resize(model.network.num_parameters());
  model.network.Initialize(1, 1e-3, model.weights.data());
  return model;
}

}  // namespace

int main(int argc, char** argv) {
  using Clock = std::chrono::steady_clock;
  const std::string dir = argc > 1 ? argv[1] : "../shared/data/drape/body";
  const double patch_area = argc > 2 ? std::atof(argv[2]) : 0.006;
  if (!(patch_area > 0.0)) {
    std::fprintf(stderr, "onefit_inference_benchmark: PATCH_AREA must be > 0\n");
    return 2;
  }
  const bool makehuman = std::filesystem::exists(dir + "/makehuman/base.obj");
  const polyfit::SkinnedBody body = polyfit::LoadDrapeBody(makehuman ? dir : "", polyfit::BodyShape{});
  std::printf("%s body, %d joints; one thread; median of 200 frames\n", makehuman ? "MakeHuman" : "procedural",
              body.skeleton.num_joints());
  // The torso: around the body's vertical axis at mid height.
  const Eigen::Vector3d lo = body.mesh.vertices.rowwise().minCoeff(), hi = body.mesh.vertices.rowwise().maxCoeff();
  const double height = hi.y() - lo.y();
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const std::vector<JointTransforms> poses = Poses(body.skeleton.num_joints(), 202);
  std::printf(
      "| garment vertices | patches | width | warp | local pose | body proximity | parameters | precision | ms per "
      "frame | of which positions | relaxed: ms per frame |\n|---:|---:|---:|---|---|---|---:|---|---:|---:|---:|\n");
  for (const auto& [segments, rings] : {std::pair{40, 12}, {80, 25}, {160, 50}}) {
    polyfit::TriangleMesh tube =
        polyfit::MakeTube(0.2, centre.y() - 0.1 * height, centre.y() + 0.15 * height, segments, rings);
    tube.vertices.row(0).array() += centre.x();
    tube.vertices.row(2).array() += centre.z();
    const polyfit::SkinWeights weights =
        polyfit::SingleJointWeights(tube.num_vertices(), std::min(1, body.skeleton.num_joints() - 1));
    for (const Inputs& inputs : {Inputs{-1, false, 0},
                                 {2, false, 0},
                                 {2, true, 0},
                                 {2, true, 5},
                                 {2, true, 9},
                                 {2, true, 5, true},
                                 {2, true, 5, true, 2}}) {
      polyfit::DrapeSolverOptions options;
      options.num_threads = 1;
      options.slide.warp_order = inputs.warp_order;
      options.patching.patch_area = patch_area;
      polyfit::DrapeSolver solver(body, tube, weights, options);
      const polyfit::NetworkRelaxation relaxation(body, solver.rest_garment());
      for (const int width : {48, 128, 256}) {
        const polyfit::OneFitModel model = RandomModel(body, width, inputs);
        const bool shipped = inputs.feedback && inputs.feedback_passes == 1;
        for (const auto precision : {polyfit::InferencePrecision::kFloat, polyfit::InferencePrecision::kDouble}) {
          if (precision == polyfit::InferencePrecision::kDouble && !shipped) continue;
          const polyfit::OneFitDraper draper(model, solver, weights, body.skeleton, &body, precision);
          std::vector<double> ms, positions_ms, relaxed_ms;
          double checksum = 0.0;
          for (int t = 2; t < static_cast<int>(poses.size()); ++t) {
            const auto start = Clock::now();
            const std::vector<double> params = draper.Predict(poses[t - 2], poses[t - 1], poses[t], 30.0, {});
            const auto predicted = Clock::now();
            Eigen::Matrix3Xd x = solver.PositionsAt(params, poses[t]);
            const auto end = Clock::now();
            relaxation.Apply(poses[t], &x, draper.posed_body());
            relaxed_ms.push_back(1e3 * std::chrono::duration<double>(Clock::now() - start).count());
            ms.push_back(1e3 * std::chrono::duration<double>(end - start).count());
            positions_ms.push_back(1e3 * std::chrono::duration<double>(end - predicted).count());
            checksum += x(0, 0);
          }
          for (std::vector<double>* v : {&ms, &positions_ms, &relaxed_ms}) {
            std::nth_element(v->begin(), v->begin() + v->size() / 2, v->end());
          }
          std::printf(
              "| %d | %d | %d | %s | %s | %s | %d | %s | %.3f | %.3f | %.3f |\n", tube.num_vertices(),
              solver.num_patches(), width, inputs.warp_order < 0 ? "none" : "order 2", inputs.local_pose ? "yes" : "no",
              inputs.proximity_probes == 0
                  ? "no"
                  : (std::to_string(inputs.proximity_probes) + " probes" +
                     (inputs.feedback ? ", feedback x" + std::to_string(inputs.feedback_passes) : ""))
                        .c_str(),
              model.network.num_parameters(), precision == polyfit::InferencePrecision::kFloat ? "float" : "double",
              ms[ms.size() / 2], positions_ms[positions_ms.size() / 2], relaxed_ms[relaxed_ms.size() / 2]);
          if (!std::isfinite(checksum)) return 1;
        }
      }
    }
  }
  return 0;
}
