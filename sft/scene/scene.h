// A shape-from-template scene directory, as ../shared/docs/sft-scene-format.md
// defines it: camera, textured template, frames, optional masks and ground
// truth. LoadScene checks everything before any solving; LoadFrame reads
// one frame's images and ground truth.
#ifndef POLYFIT_SFT_SCENE_SCENE_H_
#define POLYFIT_SFT_SCENE_SCENE_H_

#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "polyfit/mesh/triangle_mesh.h"
#include "polyfit/util/status.h"
#include "sft/camera/pinhole_camera.h"

namespace polyfit {

// Every problem with a scene: what() names the key or the file.
class SceneError : public Error {
 public:
  explicit SceneError(const std::string& message, ErrorKind kind = ErrorKind::kInput) : Error(kind, message) {}
};

enum class GroundTruthKind { kNone, kVertices, kPoints };

struct SftScene {
  std::string directory;
  PinholeCamera camera;
  // In the camera frame at the first frame, the OBJ's vertex order, with
  // per-corner texture coordinates (OBJ convention: v up).
  TriangleMesh template_mesh;
  // RGB, CV_32FC3 in [0, 1].
  cv::Mat texture;
  int first_frame = 0;
  int frame_count = 0;
  std::vector<std::string> frame_paths;
  std::vector<std::string> mask_paths;  // empty: no masks
  std::vector<std::string> ground_truth_paths;
  GroundTruthKind ground_truth_kind = GroundTruthKind::kNone;
  // Optional keys of ours beyond the format (docs/sft.md): frames per
  // second (0: not given) and gravity in the camera frame (m/s^2).
  double frame_rate = 0.0;
  bool has_gravity = false;
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();

  bool has_masks() const { return !mask_paths.empty(); }
  bool has_ground_truth() const { return ground_truth_kind != GroundTruthKind::kNone; }
};

struct SftFrame {
  int index = 0;  // first_frame + t
  // RGB, CV_32FC3 in [0, 1], undistorted.
  cv::Mat image;
  // CV_32F, 1 inside (> 127 on disk), 0 outside; empty without masks.
  cv::Mat mask;
  // 3 by N in the camera frame; empty without ground truth.
  Eigen::Matrix3Xd ground_truth;
};

struct SceneLoadOptions {
  // Decode every frame and mask to check its size (and readability) now;
  // off, only their existence is checked.
  bool check_images = true;
};

// Reads scene.json and the template and texture, and checks every frame,
// mask and ground-truth file. Throws SceneError.
SftScene LoadScene(const std::string& directory, const SceneLoadOptions& options = {});

// Frame t (0-based, from first_frame). Throws SceneError.
SftFrame LoadFrame(const SftScene& scene, int t);

// Reads an image as RGB CV_32FC3 in [0, 1] (grey is expanded). Throws
// SceneError naming the file.
cv::Mat ReadImageRgb(const std::string& path);

}  // namespace polyfit

#endif  // POLYFIT_SFT_SCENE_SCENE_H_
