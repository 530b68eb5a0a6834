#include "drape/body/body_shape.h"

#include <zlib.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace polyfit {
namespace {

// The tent weights of {min, average, max} at p in [0, 1].
std::array<double, 3> Tent(double p) {
  if (p <= 0.5) return {1.0 - 2.0 * p, 2.0 * p, 0.0};
  return {0.0, 2.0 - 2.0 * p, 2.0 * p - 1.0};
}

}  // namespace

void AddBodyShapeTarget(const std::string& path, double w, Eigen::Matrix3Xd* base) {
  if (w == 0.0) return;
  if (!std::filesystem::exists(path)) throw BodyError(path + ": no such shape target");
  gzFile file = gzopen(path.c_str(), "rb");
  if (file == nullptr) throw BodyError(path + ": cannot be opened");
  std::string text;
  char buffer[1 << 16];
  int got = 0;
  // The shipped targets inflate to under 1 MB; a compression bomb must
  // not take the memory.
  constexpr size_t kMaxText = size_t{64} << 20;
  while ((got = gzread(file, buffer, sizeof(buffer))) > 0 && text.size() <= kMaxText) {
    text.append(buffer, static_cast<size_t>(got));
  }
  const bool failed = got < 0;
  gzclose(file);
  if (failed) throw BodyError(path + ": not a readable gzip file");
  if (text.size() > kMaxText) throw BodyError(path + ": inflates to over 64 MB, not a shape target");
  std::istringstream lines(text);
  std::string line;
  int number = 0;
  while (std::getline(lines, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    long index = -1;
    double dx = 0.0, dy = 0.0, dz = 0.0;
    if (!(fields >> index >> dx >> dy >> dz) || !std::isfinite(dx) || !std::isfinite(dy) || !std::isfinite(dz)) {
      throw BodyError(path + ": line " + std::to_string(number) + ": expected 'vertex dx dy dz'");
    }
    if (index < 0 || index >= base->cols()) {
      throw BodyError(path + ": line " + std::to_string(number) + ": vertex " + std::to_string(index) +
                      " out of range");
    }
    base->col(index) += 0.1 * w * Eigen::Vector3d(dx, dy, dz);
  }
}

bool BodyShape::IsNeutral() const {
  return gender == 0.5 && muscle == 0.5 && weight == 0.5 && height == 0.5 && proportions == 0.5;
}

std::string BodyShape::Validate() const {
  const std::pair<const char*, double> values[] = {
      {"gender", gender}, {"muscle", muscle}, {"weight", weight}, {"height", height}, {"proportions", proportions}};
  for (const auto& [name, value] : values) {
    if (!(value >= 0.0 && value <= 1.0)) return std::string(name) + " must be in [0, 1]";
  }
  return {};
}

BodyShape BodyShape::Parse(const std::string& text) {
  BodyShape shape;
  std::istringstream items(text);
  std::string item;
  while (std::getline(items, item, ',')) {
    if (item.empty()) continue;
    const size_t eq = item.find('=');
    if (eq == std::string::npos) throw std::invalid_argument("shape: '" + item + "' is not key=value");
    const std::string key = item.substr(0, eq);
    double value = 0.0;
    try {
      size_t used = 0;
      value = std::stod(item.substr(eq + 1), &used);
      if (used != item.size() - eq - 1) throw std::invalid_argument("trailing");
    } catch (const std::exception&) {
      throw std::invalid_argument("shape: '" + key + "' needs a number, got '" + item.substr(eq + 1) + "'");
    }
    if (key == "gender")
      shape.gender = value;
    else if (key == "muscle")
      shape.muscle = value;
    else if (key == "weight")
      shape.weight = value;
    else if (key == "height")
      shape.height = value;
    else if (key == "proportions")
      shape.proportions = value;
    else
      throw std::invalid_argument("shape: unknown key '" + key + "' (gender, muscle, weight, height, proportions)");
  }
  const std::string problem = shape.Validate();
  if (!problem.empty()) throw std::invalid_argument("shape: " + problem);
  return shape;
}

std::string BodyShape::ToString() const {
  std::ostringstream out;
  out << "gender=" << gender << ",muscle=" << muscle << ",weight=" << weight << ",height=" << height
      << ",proportions=" << proportions;
  return out.str();
}

void ApplyBodyShape(const std::string& body_dir, const BodyShape& shape, SkinnedBody* body) {
  const std::string problem = shape.Validate();
  if (!problem.empty()) throw BodyError("BodyShape: " + problem);
  if (shape.IsNeutral()) return;
  const std::filesystem::path dir = std::filesystem::path(body_dir) / "targets_macro_young";
  Eigen::Matrix3Xd& base = body->base_vertices;
  const std::array<double, 3> muscle = Tent(shape.muscle), weight = Tent(shape.weight);
  const char* levels[] = {"min", "average", "max"};
  for (int g = 0; g < 2; ++g) {
    const double w_gender = g == 0 ? 1.0 - shape.gender : shape.gender;
    const std::string gender = g == 0 ? "female" : "male";
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) {
        const double w = w_gender * muscle[a] * weight[b];
        if (a == 1 && b == 1) continue;  // empty: the base mesh
        AddBodyShapeTarget(
            (dir / ("universal-" + gender + "-young-" + levels[a] + "muscle-" + levels[b] + "weight.target.gz"))
                .string(),
            w, &base);
      }
    }
    // Gender at average muscle and weight lives in the ethnic targets; only
    // the caucasian ones are shipped. Relative to the neutral mix (half of
    // each), so that the neutral shape stays the base mesh.
    AddBodyShapeTarget((dir / ("caucasian-" + gender + "-young.target.gz")).string(), w_gender - 0.5, &base);
    const std::string stem = gender + "-young-averagemuscle-averageweight-";
    if (shape.height != 0.5) {
      AddBodyShapeTarget(
          (dir / "height" / (stem + (shape.height > 0.5 ? "maxheight" : "minheight") + ".target.gz")).string(),
          w_gender * std::abs(2.0 * shape.height - 1.0), &base);
    }
    if (shape.proportions != 0.5) {
      AddBodyShapeTarget(
          (dir / "proportions" /
           (stem + (shape.proportions > 0.5 ? "idealproportions" : "uncommonproportions") + ".target.gz"))
              .string(),
          w_gender * std::abs(2.0 * shape.proportions - 1.0), &base);
    }
  }
  const int n = body->mesh.num_vertices();
  if (base.cols() < n) throw BodyError(body_dir + ": the body has more vertices than its base mesh");
  body->mesh.vertices = base.leftCols(n);
  Skeleton& skeleton = body->skeleton;
  for (int j = 0; j < skeleton.num_joints() && j < static_cast<int>(skeleton.head_vertices.size()); ++j) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int v : skeleton.head_vertices[j]) sum += base.col(v);
    skeleton.rest_heads.col(j) = sum / static_cast<double>(skeleton.head_vertices[j].size());
  }
}

}  // namespace polyfit
