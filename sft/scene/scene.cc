#include "sft/scene/scene.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "polyfit/mesh/ordered_io.h"

namespace polyfit {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

[[noreturn]] void Fail(const std::string& message) { throw SceneError(message); }

// A file pattern of the frame index: text with one integer conversion
// (%d, %5d, %06d; %% for a percent sign). Formatted here, never handed to
// printf: a pattern such as "%s" from scene.json would read memory that is
// not there (found by tests/fuzz/scene_fuzzer).
std::string FormatPattern(const std::string& pattern, int index, const std::string& key, const std::string& where) {
  std::string out;
  int conversions = 0;
  for (size_t i = 0; i < pattern.size(); ++i) {
    if (pattern[i] != '%') {
      out += pattern[i];
      continue;
    }
    if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
      out += '%';
      ++i;
      continue;
    }
    size_t j = i + 1;
    const bool zero = j < pattern.size() && pattern[j] == '0';
    if (zero) ++j;
    int width = 0;
    while (j < pattern.size() && std::isdigit(static_cast<unsigned char>(pattern[j])) && width < 100) {
      width = 10 * width + (pattern[j++] - '0');
    }
    if (j >= pattern.size() || (pattern[j] != 'd' && pattern[j] != 'i') || width > 20 || ++conversions > 1) {
      Fail(where + ": '" + key + "' must be a pattern with one integer conversion such as frames/%06d.png, not '" +
           pattern + "'");
    }
    std::string digits = std::to_string(index < 0 ? -static_cast<long long>(index) : index);
    if (index < 0) digits.insert(0, 1, '-');
    if (static_cast<int>(digits.size()) < width) {
      const size_t pad = width - digits.size();
      if (zero) {
        digits.insert(index < 0 ? 1 : 0, pad, '0');
      } else {
        digits.insert(0, pad, ' ');
      }
    }
    out += digits;
    i = j;
  }
  if (conversions != 1) {
    Fail(where + ": '" + key + "' must be a pattern with one integer conversion such as frames/%06d.png, not '" +
         pattern + "'");
  }
  return out;
}

template <typename T>
T Required(const json& object, const char* key, const std::string& where) {
  if (!object.contains(key)) Fail(where + ": missing required key '" + key + "'");
  try {
    return object.at(key).get<T>();
  } catch (const json::exception&) {
    Fail(where + ": key '" + key + "' has the wrong type");
  }
}

// An int key: a whole number in int's range (nlohmann's get<int> of 1e300
// or of a fraction would convert it unchecked).
int IntValue(const json& value, const char* key, const std::string& where) {
  const bool whole = value.is_number_integer() || (value.is_number_float() && std::isfinite(value.get<double>()) &&
                                                   value.get<double>() == std::floor(value.get<double>()));
  const double x = value.is_number() ? value.get<double>() : 0.0;
  if (!whole || x < std::numeric_limits<int>::min() || x > std::numeric_limits<int>::max()) {
    Fail(where + ": key '" + key + "' must be a whole number in int's range");
  }
  return static_cast<int>(x);
}

template <>
int Required<int>(const json& object, const char* key, const std::string& where) {
  if (!object.contains(key)) Fail(where + ": missing required key '" + key + "'");
  return IntValue(object.at(key), key, where);
}

int Optional(const json& object, const char* key, int fallback, const std::string& where) {
  return object.contains(key) ? IntValue(object.at(key), key, where) : fallback;
}

cv::Mat ReadMask(const std::string& path) {
  cv::Mat raw = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (raw.empty()) Fail(path + ": cannot be read as an image");
  cv::Mat mask;
  cv::threshold(raw, mask, 127, 1.0, cv::THRESH_BINARY);
  mask.convertTo(mask, CV_32F);
  return mask;
}

}  // namespace

cv::Mat ReadImageRgb(const std::string& path) {
  cv::Mat raw = cv::imread(path, cv::IMREAD_COLOR);  // BGR
  if (raw.empty()) Fail(path + ": cannot be read as an image (missing or not PNG/JPEG?)");
  cv::Mat rgb;
  cv::cvtColor(raw, rgb, cv::COLOR_BGR2RGB);
  rgb.convertTo(rgb, CV_32FC3, 1.0 / 255.0);
  return rgb;
}

namespace {

json ReadSceneJson(const std::string& json_path, const std::string& directory) {
  std::ifstream in(json_path);
  if (!in) Fail(json_path + ": missing (is " + directory + " a scene directory?)");
  try {
    return json::parse(in);
  } catch (const json::exception& e) {
    Fail(json_path + ": not valid JSON: " + e.what());
  }
}

PinholeCamera ReadCamera(const json& root, const std::string& where) {
  if (!root.contains("camera")) Fail(where + ": missing required key 'camera'");
  const json& cam = root["camera"];
  PinholeCamera camera;
  camera.fx = Required<double>(cam, "fx", where + " camera");
  camera.fy = Required<double>(cam, "fy", where + " camera");
  camera.cx = Required<double>(cam, "cx", where + " camera");
  camera.cy = Required<double>(cam, "cy", where + " camera");
  camera.width = Required<int>(cam, "width", where + " camera");
  camera.height = Required<int>(cam, "height", where + " camera");
  if (!(camera.fx > 0 && camera.fy > 0) || camera.width <= 0 || camera.height <= 0) {
    Fail(where + ": camera: fx, fy, width and height must be positive");
  }
  if (cam.contains("distortion")) {
    camera.distortion = Required<std::vector<double>>(cam, "distortion", where + " camera");
    if (camera.distortion.size() != 5) Fail(where + ": camera 'distortion' needs 5 values (k1, k2, p1, p2, k3)");
  }
  return camera;
}

// The template (textured, in front of the camera) and its texture.
void ReadTemplate(const json& root, const fs::path& dir, const std::string& where, SftScene* scene) {
  const std::string template_path = (dir / Required<std::string>(root, "template", where)).string();
  try {
    scene->template_mesh = ReadObjTemplate(template_path);
  } catch (const std::runtime_error& e) {
    Fail(e.what());
  }
  if (!scene->template_mesh.has_texcoords()) Fail(template_path + ": every face needs texture coordinates (vt)");
  for (int v = 0; v < scene->template_mesh.num_vertices(); ++v) {
    if (!(scene->template_mesh.vertices(2, v) > 0.0)) {
      Fail(template_path + ": vertex " + std::to_string(v) + " is not in front of the camera (z <= 0)");
    }
  }
  scene->texture = ReadImageRgb((dir / Required<std::string>(root, "texture", where)).string());
}

// Every frame's image, mask and ground-truth paths, each checked to exist.
void ListFrameFiles(const json& root, const fs::path& dir, const std::string& where, SftScene* scene) {
  scene->frame_count = Required<int>(root, "frame_count", where);
  scene->first_frame = Optional(root, "first_frame", 0, where);
  if (scene->frame_count <= 0) Fail(where + ": 'frame_count' must be positive");
  // Indices stay far from int's end.
  if (scene->first_frame < 0 || scene->first_frame > 100000000 || scene->frame_count > 100000000) {
    Fail(where + ": 'first_frame' must be in [0, 1e8] and 'frame_count' at most 1e8");
  }
  const std::string frames = Required<std::string>(root, "frames", where);
  const std::string masks = root.value("masks", std::string());
  const std::string ground_truth = root.value("ground_truth", std::string());
  const std::string kind = root.value("ground_truth_kind", std::string("vertices"));
  if (!ground_truth.empty()) {
    if (kind == "vertices") {
      scene->ground_truth_kind = GroundTruthKind::kVertices;
    } else if (kind == "points") {
      scene->ground_truth_kind = GroundTruthKind::kPoints;
    } else {
      Fail(where + ": 'ground_truth_kind' must be \"vertices\" or \"points\", not \"" + kind + "\"");
    }
  }
  const auto path_of = [&](const std::string& pattern, int index, const char* key) {
    const std::string path = (dir / FormatPattern(pattern, index, key, where)).string();
    if (!fs::exists(path)) Fail(path + ": missing (frame " + std::to_string(index) + ", key '" + key + "')");
    return path;
  };
  for (int t = 0; t < scene->frame_count; ++t) {
    const int index = scene->first_frame + t;
    scene->frame_paths.push_back(path_of(frames, index, "frames"));
    if (!masks.empty()) scene->mask_paths.push_back(path_of(masks, index, "masks"));
    if (!ground_truth.empty()) scene->ground_truth_paths.push_back(path_of(ground_truth, index, "ground_truth"));
  }
}

// Every frame and mask readable and of the camera's size.
void CheckImages(const SftScene& scene) {
  const PinholeCamera& camera = scene.camera;
  const auto check = [&camera](const std::string& path) {
    const cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
    if (image.empty()) Fail(path + ": cannot be read as an image");
    if (image.cols != camera.width || image.rows != camera.height) {
      Fail(path + ": " + std::to_string(image.cols) + "x" + std::to_string(image.rows) + ", but the camera is " +
           std::to_string(camera.width) + "x" + std::to_string(camera.height));
    }
  };
  for (int t = 0; t < scene.frame_count; ++t) {
    check(scene.frame_paths[t]);
    if (scene.has_masks()) check(scene.mask_paths[t]);
  }
}

// The first ground-truth file against the template (each frame's is checked
// on load).
void CheckGroundTruth(const SftScene& scene) {
  if (scene.ground_truth_kind != GroundTruthKind::kVertices) return;
  const Eigen::Matrix3Xd gt = [&] {
    try {
      return ReadPlyVertices(scene.ground_truth_paths[0]);
    } catch (const std::runtime_error& e) {
      Fail(e.what());
    }
  }();
  if (gt.cols() != scene.template_mesh.num_vertices()) {
    Fail(scene.ground_truth_paths[0] + ": " + std::to_string(gt.cols()) + " vertices, the template has " +
         std::to_string(scene.template_mesh.num_vertices()));
  }
}

// The optional physics a scene may state (PolySftOptions::gravity_prior
// reads them): "frame_rate" (frames per second, > 0) and "gravity" (m/s^2,
// three numbers in the camera frame). Absent: 0 and none.
void ReadPhysics(const json& root, const std::string& where, SftScene* scene) {
  if (root.contains("frame_rate")) {
    const json& rate = root.at("frame_rate");
    if (!rate.is_number() || !(rate.get<double>() > 0.0) || !std::isfinite(rate.get<double>())) {
      Fail(where + ": key 'frame_rate' must be a positive number (frames per second)");
    }
    scene->frame_rate = rate.get<double>();
  }
  if (root.contains("gravity")) {
    const json& g = root.at("gravity");
    bool valid = g.is_array() && g.size() == 3;
    for (size_t k = 0; valid && k < 3; ++k) valid = g[k].is_number() && std::isfinite(g[k].get<double>());
    if (!valid) Fail(where + ": key 'gravity' must be three finite numbers (m/s^2, camera frame)");
    scene->gravity = Eigen::Vector3d(g[0].get<double>(), g[1].get<double>(), g[2].get<double>());
    scene->has_gravity = true;
  }
}

}  // namespace

SftScene LoadScene(const std::string& directory, const SceneLoadOptions& options) {
  SftScene scene;
  scene.directory = directory;
  const fs::path dir(directory);
  const std::string json_path = (dir / "scene.json").string();
  const json root = ReadSceneJson(json_path, directory);
  scene.camera = ReadCamera(root, json_path);
  ReadTemplate(root, dir, json_path, &scene);
  ListFrameFiles(root, dir, json_path, &scene);
  ReadPhysics(root, json_path, &scene);
  if (options.check_images) CheckImages(scene);
  CheckGroundTruth(scene);
  return scene;
}

SftFrame LoadFrame(const SftScene& scene, int t) {
  if (t < 0 || t >= scene.frame_count) Fail("frame " + std::to_string(t) + " is out of range");
  SftFrame frame;
  frame.index = scene.first_frame + t;
  frame.image = ReadImageRgb(scene.frame_paths[t]);
  if (frame.image.cols != scene.camera.width || frame.image.rows != scene.camera.height) {
    Fail(scene.frame_paths[t] + ": wrong size");
  }
  if (scene.has_masks()) frame.mask = ReadMask(scene.mask_paths[t]);
  if (!scene.camera.distortion.empty()) {
    const cv::Matx33d k(scene.camera.fx, 0, scene.camera.cx, 0, scene.camera.fy, scene.camera.cy, 0, 0, 1);
    cv::Mat undistorted;
    cv::undistort(frame.image, undistorted, k, scene.camera.distortion);
    frame.image = undistorted;
    if (!frame.mask.empty()) {
      cv::Mat mask;
      cv::undistort(frame.mask, mask, k, scene.camera.distortion);
      frame.mask = mask;
    }
  }
  if (scene.has_ground_truth()) {
    try {
      frame.ground_truth = ReadPlyVertices(scene.ground_truth_paths[t]);
    } catch (const std::runtime_error& e) {
      Fail(e.what());
    }
    if (scene.ground_truth_kind == GroundTruthKind::kVertices &&
        frame.ground_truth.cols() != scene.template_mesh.num_vertices()) {
      Fail(scene.ground_truth_paths[t] + ": " + std::to_string(frame.ground_truth.cols()) +
           " vertices, the template has " + std::to_string(scene.template_mesh.num_vertices()));
    }
  }
  return frame;
}

}  // namespace polyfit
