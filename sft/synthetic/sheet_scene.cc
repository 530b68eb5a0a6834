#include "sft/synthetic/sheet_scene.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <optional>
#include <random>
#include <stdexcept>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "polyfit/mesh/mesh_io.h"
#include "polyfit/util/atomic_file.h"
#include "sft/synthetic/cloth_motion.h"

namespace polyfit {
namespace {

namespace fs = std::filesystem;

// Texture: smooth colour gradients, then random discs, bars and rings of
// random colours (detail at every scale, so that every part of the sheet
// can be located).
cv::Mat MakeTexture(int size, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  cv::Mat texture(size, size, CV_32FC3);
  const double a = 2 + 3 * unit(rng), b = 2 + 3 * unit(rng), c = 3 + 3 * unit(rng);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const double u = static_cast<double>(x) / size, v = static_cast<double>(y) / size;
      texture.at<cv::Vec3f>(y, x) =
          cv::Vec3f(0.5 + 0.25 * std::sin(2 * M_PI * a * u), 0.5 + 0.25 * std::sin(2 * M_PI * b * v + 1.0),
                    0.5 + 0.25 * std::sin(2 * M_PI * c * (u + v)));
    }
  }
  for (int k = 0; k < 220; ++k) {
    const cv::Point centre(static_cast<int>(unit(rng) * size), static_cast<int>(unit(rng) * size));
    const cv::Scalar colour(unit(rng), unit(rng), unit(rng));
    const int radius = static_cast<int>(size * (0.01 + 0.05 * unit(rng)));
    switch (k % 3) {
      case 0: cv::circle(texture, centre, radius, colour, cv::FILLED, cv::LINE_AA); break;
      case 1:
        cv::rectangle(texture, centre, centre + cv::Point(radius * 2, radius / 2 + 1), colour, cv::FILLED, cv::LINE_AA);
        break;
      default: cv::circle(texture, centre, radius, colour, std::max(1, radius / 4), cv::LINE_AA); break;
    }
  }
  return texture;
}

// A low-contrast backdrop, so that the background is not a constant.
cv::Mat MakeBackground(int width, int height, std::mt19937_64& rng) {
  cv::Mat noise(height / 8 + 1, width / 8 + 1, CV_32FC3);
  std::uniform_real_distribution<float> unit(0.25f, 0.45f);
  for (int y = 0; y < noise.rows; ++y) {
    for (int x = 0; x < noise.cols; ++x) noise.at<cv::Vec3f>(y, x) = cv::Vec3f(unit(rng), unit(rng), unit(rng));
  }
  cv::Mat background;
  cv::resize(noise, background, cv::Size(width, height), 0, 0, cv::INTER_CUBIC);
  return background;
}

// PNG written atomically.
void WritePng(const std::string& path, const cv::Mat& image) {
  std::vector<uchar> png;
  if (!cv::imencode(".png", image, png)) throw Error(ErrorKind::kOutput, path + ": cannot be encoded as PNG");
  WriteFileAtomically(path, [&](std::ostream& out) {
    out.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
  });
}

void WriteRgbPng(const std::string& path, const cv::Mat& rgb) {
  cv::Mat bgr, bytes;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  bgr.convertTo(bytes, CV_8UC3, 255.0);
  WritePng(path, bytes);
}

std::string Frame(const char* pattern, int index) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), pattern, index);
  return buffer;
}

}  // namespace

SheetMotion ParseSheetMotion(const std::string& name) {
  if (name == "bend") return SheetMotion::kBend;
  if (name == "wave") return SheetMotion::kWave;
  if (name == "rigid") return SheetMotion::kRigid;
  if (name == "mixed") return SheetMotion::kMixed;
  if (name == "roll") return SheetMotion::kRoll;
  if (name == "crease") return SheetMotion::kCrease;
  if (name == "wave_packet") return SheetMotion::kWavePacket;
  if (name == "hanging") return SheetMotion::kHanging;
  if (name == "flag") return SheetMotion::kFlag;
  if (name == "fall") return SheetMotion::kFall;
  if (name == "table") return SheetMotion::kTable;
  throw std::invalid_argument("unknown motion '" + name +
                              "' (bend, wave, rigid, mixed, roll, crease, wave_packet, hanging, flag, fall or table)");
}

bool IsSimulatedMotion(SheetMotion motion) {
  return motion == SheetMotion::kHanging || motion == SheetMotion::kFlag || motion == SheetMotion::kFall ||
         motion == SheetMotion::kTable;
}

std::string SheetSceneOptions::Validate() const {
  if (frame_count < 1) return "frame_count must be >= 1";
  if (width < 16 || height < 16) return "the image must be at least 16 x 16";
  if (grid_x < 2 || grid_y < 2) return "the grid needs at least 2 x 2 cells";
  if (!(distance > 0.05)) return "distance must be > 0.05 m";
  if (!(wavelength > 0.0)) return "wavelength must be > 0";
  if (supersampling < 1 || supersampling > 8) return "supersampling must be in [1, 8]";
  if (!(focal_ratio >= 0.5 && focal_ratio <= 2.0)) return "focal_ratio must be in [0.5, 2]";
  if (!(std::abs(principal_offset_x) <= width / 4.0 && std::abs(principal_offset_y) <= height / 4.0)) {
    return "the principal point offset must be within a quarter of the image";
  }
  if (std::string p = imperfections.Validate(); !p.empty()) return "imperfections: " + p;
  if (!(frame_rate > 0.0 && frame_rate <= 1000.0)) return "frame_rate must be in (0, 1000]";
  if (!(wind_scale >= 0.0 && wind_scale <= 10.0)) return "wind_scale must be in [0, 10]";
  if (std::string p = cloth.Validate(); !p.empty()) return "cloth: " + p;
  return {};
}

void SheetSceneOptions::MakeRealLike() {
  imperfections = FootageImperfections::RealLike();
  focal_ratio = 1.03;
  principal_offset_x = 0.025 * width;
  principal_offset_y = -0.02 * height;
  noise_sigma = std::max(noise_sigma, 0.01);
}

SheetSceneOptions SheetSceneOptions::Small(int width, int grid_x, int frame_count) {
  SheetSceneOptions o;
  o.width = width;
  o.height = width * 3 / 4;
  o.focal_length = 0.9 * width;
  o.grid_x = grid_x;
  o.grid_y = std::max(2, grid_x * 2 / 3);
  o.texture_size = std::max(64, width * 8 / 5);
  o.frame_count = frame_count;
  return o;
}

namespace {

// A height profile z(w) across the sheet's height, followed by arc length
// so that the sheet is not stretched (a developable surface, like paper):
// maps arc length s (from w = 0) to (w, z). Tabulated, then inverted by
// interpolation.
class ArcLengthProfile {
 public:
  ArcLengthProfile(const std::function<double(double)>& height, double reach) : height_(height) {
    const int steps = 4000;  // w in [-reach, reach]
    const double dw = 2 * reach / steps;
    double arc = 0.0, previous = height(-reach);
    for (int k = 0; k <= steps; ++k) {
      const double w = -reach + k * dw, z = height(w);
      if (k > 0) arc += std::hypot(dw, z - previous);
      previous = z;
      w_.push_back(w);
      s_.push_back(arc);
    }
    const double s0 = s_[steps / 2];
    for (double& s : s_) s -= s0;
  }
  void At(double s, double* w, double* z) const {
    const size_t k = std::min<size_t>(std::lower_bound(s_.begin(), s_.end(), s) - s_.begin(), s_.size() - 1);
    const size_t k0 = k == 0 ? 0 : k - 1;
    const double t = s_[k] > s_[k0] ? (s - s_[k0]) / (s_[k] - s_[k0]) : 0.0;
    *w = w_[k0] + t * (w_[k] - w_[k0]);
    *z = height_(*w);
  }

 private:
  std::function<double(double)> height_;
  std::vector<double> w_, s_;
};

// The profile across the sheet's height at tau, or none (flat).
std::optional<ArcLengthProfile> HeightProfile(const SheetSceneOptions& o, double tau) {
  if (o.motion == SheetMotion::kWave) {
    // Travelling, its amplitude rising and falling; zero at w = 0.
    const double amplitude = o.wave_amplitude * std::sin(M_PI * tau), lambda = o.wavelength, phase = 0.5 * tau;
    return ArcLengthProfile(
        [=](double w) { return amplitude * (std::sin(2 * M_PI * (w / lambda + phase)) - std::sin(2 * M_PI * phase)); },
        o.sheet_height);
  }
  if (o.motion == SheetMotion::kWavePacket) {
    // About two periods across the height under a Gaussian envelope that
    // drifts along it, the crests travelling a period: no single low-order
    // polynomial holds it. Slopes up to about 0.6.
    const double h = o.sheet_height, lambda = 0.5 * h, amplitude = 0.05 * h * std::sin(M_PI * tau);
    const double centre = 0.25 * h * (tau - 0.5), sigma = 0.3 * h, phase = tau;
    return ArcLengthProfile(
        [=](double w) {
          const double envelope = std::exp(-0.5 * (w - centre) * (w - centre) / (sigma * sigma));
          return amplitude * envelope * std::sin(2 * M_PI * (w / lambda + phase));
        },
        h);
  }
  return std::nullopt;
}

// The sheet's point at (x, y) (before the rigid motion) for the motions
// that bend it about its vertical axis: a cylinder of the given curvature,
// or a crease along x = 0 whose halves each turn by `fold` toward the
// camera. Both isometric.
Eigen::Vector3d BendAcross(double x, double curvature, double fold) {
  if (fold != 0.0) return Eigen::Vector3d(x * std::cos(fold), 0.0, -std::abs(x) * std::sin(fold));
  if (curvature == 0.0) return Eigen::Vector3d(x, 0.0, 0.0);
  return Eigen::Vector3d(std::sin(curvature * x) / curvature, 0.0, (1.0 - std::cos(curvature * x)) / curvature);
}

}  // namespace

Eigen::Vector2d SheetGridPoint(const SheetSceneOptions& o, int vertex) {
  const int i = vertex % (o.grid_x + 1), j = vertex / (o.grid_x + 1);
  return Eigen::Vector2d((static_cast<double>(i) / o.grid_x - 0.5) * o.sheet_width,
                         (static_cast<double>(j) / o.grid_y - 0.5) * o.sheet_height);
}

Eigen::Matrix3Xd SheetVerticesAt(const SheetSceneOptions& o, double tau) {
  if (IsSimulatedMotion(o.motion)) {
    throw std::invalid_argument("SheetVerticesAt: a simulated motion has no closed form (use SheetSequence)");
  }
  const int nx = o.grid_x, ny = o.grid_y;
  Eigen::Matrix3Xd vertices(3, (nx + 1) * (ny + 1));
  const bool bend = o.motion == SheetMotion::kBend || o.motion == SheetMotion::kMixed;
  const bool rigid =
      o.motion == SheetMotion::kRigid || o.motion == SheetMotion::kMixed || o.motion == SheetMotion::kWavePacket;
  // Curvature up to 1 / 0.13 m: the sheet's ends fold about 65 degrees.
  // Rolled: the sheet wraps 270 degrees at first, 180 at the end.
  const double curvature = bend                             ? std::sin(M_PI * tau) / 0.13
                           : o.motion == SheetMotion::kRoll ? (1.5 * M_PI - 0.5 * M_PI * tau) / o.sheet_width
                                                            : 0.0;
  // The crease closes from flat to a 60 degree dihedral (each half 60).
  const double fold = o.motion == SheetMotion::kCrease ? (M_PI / 3.0) * tau : 0.0;
  const Eigen::Matrix3d rotation =
      rigid ? (Eigen::AngleAxisd(o.yaw_amplitude * std::sin(M_PI * tau), Eigen::Vector3d::UnitY()) *
               Eigen::AngleAxisd(0.2 * std::sin(2 * M_PI * tau), Eigen::Vector3d::UnitX()))
                  .toRotationMatrix()
            : Eigen::Matrix3d::Identity();
  const Eigen::Vector3d translation = rigid ? Eigen::Vector3d(o.sideways_amplitude * std::sin(2 * M_PI * tau),
                                                              0.015 * std::sin(M_PI * tau), 0.05 * std::sin(M_PI * tau))
                                            : Eigen::Vector3d::Zero();
  const std::optional<ArcLengthProfile> profile = HeightProfile(o, tau);
  for (int j = 0; j <= ny; ++j) {
    for (int i = 0; i <= nx; ++i) {
      const Eigen::Vector2d flat = SheetGridPoint(o, j * (nx + 1) + i);
      const double x = flat.x(), y = flat.y();
      Eigen::Vector3d p = BendAcross(x, curvature, fold);
      p.y() = y;
      if (profile) {
        double w, z;
        profile->At(y, &w, &z);
        p.y() = w;
        p.z() += z;
      }
      vertices.col(j * (nx + 1) + i) = rotation * p + translation + Eigen::Vector3d(0, 0, o.distance);
    }
  }
  return vertices;
}

void RenderHard(const TriangleMesh& mesh, const cv::Mat& texture, double fx, double fy, double cx, double cy, int ss,
                const cv::Mat& background, cv::Mat* color, cv::Mat* coverage, const std::vector<float>* face_shade) {
  const int width = background.cols, height = background.rows;
  const int sw = width * ss, sh = height * ss;
  // Per sample: depth and colour of the nearest surface.
  cv::Mat depth(sh, sw, CV_32F, cv::Scalar(std::numeric_limits<float>::infinity()));
  cv::Mat sample_color(sh, sw, CV_32FC3, cv::Scalar(0, 0, 0));
  const int tw = texture.cols, th = texture.rows;
  for (int f = 0; f < mesh.num_faces(); ++f) {
    Eigen::Vector3d P[3];
    double sx[3], sy[3];
    for (int c = 0; c < 3; ++c) {
      P[c] = mesh.vertices.col(mesh.faces(c, f));
      // Sample (i, j) has its centre at pixel ((i + 0.5) / ss - 0.5, ...).
      sx[c] = ((fx * P[c].x() / P[c].z() + cx) + 0.5) * ss - 0.5;
      sy[c] = ((fy * P[c].y() / P[c].z() + cy) + 0.5) * ss - 0.5;
    }
    const double area = (sx[1] - sx[0]) * (sy[2] - sy[0]) - (sy[1] - sy[0]) * (sx[2] - sx[0]);
    if (area == 0.0) continue;
    const int x0 = std::max(0, static_cast<int>(std::ceil(std::min({sx[0], sx[1], sx[2]}))));
    const int x1 = std::min(sw - 1, static_cast<int>(std::floor(std::max({sx[0], sx[1], sx[2]}))));
    const int y0 = std::max(0, static_cast<int>(std::ceil(std::min({sy[0], sy[1], sy[2]}))));
    const int y1 = std::min(sh - 1, static_cast<int>(std::floor(std::max({sy[0], sy[1], sy[2]}))));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        double b[3];
        b[0] = ((sx[1] - x) * (sy[2] - y) - (sy[1] - y) * (sx[2] - x)) / area;
        b[1] = ((sx[2] - x) * (sy[0] - y) - (sy[2] - y) * (sx[0] - x)) / area;
        b[2] = 1.0 - b[0] - b[1];
        if (b[0] < 0 || b[1] < 0 || b[2] < 0) continue;
        // Perspective-correct: interpolate attributes / z and 1 / z.
        double inv_z = 0.0, u = 0.0, v = 0.0;
        for (int c = 0; c < 3; ++c) {
          const double w = b[c] / P[c].z();
          inv_z += w;
          u += w * mesh.corner_texcoords(0, 3 * f + c);
          v += w * mesh.corner_texcoords(1, 3 * f + c);
        }
        const double z = 1.0 / inv_z;
        if (z >= depth.at<float>(y, x)) continue;
        depth.at<float>(y, x) = static_cast<float>(z);
        u *= z;
        v *= z;
        const double tx = std::clamp(u * tw - 0.5, 0.0, tw - 1.0), ty = std::clamp((1.0 - v) * th - 0.5, 0.0, th - 1.0);
        const int ix = std::min(static_cast<int>(tx), tw - 2), iy = std::min(static_cast<int>(ty), th - 2);
        const double ax = tx - ix, ay = ty - iy;
        const cv::Vec3f c00 = texture.at<cv::Vec3f>(iy, ix), c01 = texture.at<cv::Vec3f>(iy, ix + 1);
        const cv::Vec3f c10 = texture.at<cv::Vec3f>(iy + 1, ix), c11 = texture.at<cv::Vec3f>(iy + 1, ix + 1);
        const float shade = face_shade != nullptr ? (*face_shade)[f] : 1.0f;
        sample_color.at<cv::Vec3f>(y, x) =
            shade * ((1 - ay) * ((1 - ax) * c00 + ax * c01) + ay * ((1 - ax) * c10 + ax * c11));
      }
    }
  }
  color->create(height, width, CV_32FC3);
  coverage->create(height, width, CV_32F);
  const float inv = 1.0f / (ss * ss);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      cv::Vec3f sum(0, 0, 0);
      int hits = 0;
      for (int j = 0; j < ss; ++j) {
        for (int i = 0; i < ss; ++i) {
          if (std::isfinite(depth.at<float>(y * ss + j, x * ss + i))) {
            sum += sample_color.at<cv::Vec3f>(y * ss + j, x * ss + i);
            ++hits;
          } else {
            sum += background.at<cv::Vec3f>(y, x);
          }
        }
      }
      color->at<cv::Vec3f>(y, x) = sum * inv;
      coverage->at<float>(y, x) = hits * inv;
    }
  }
}

TriangleMesh MakeSheetMesh(const SheetSceneOptions& o, const Eigen::Matrix3Xd& vertices) {
  TriangleMesh sheet;
  sheet.vertices = vertices;
  const int nx = o.grid_x, ny = o.grid_y;
  sheet.faces.resize(3, 2 * nx * ny);
  sheet.corner_texcoords.resize(2, 6 * nx * ny);
  const auto uv = [&](int vertex) {
    return Eigen::Vector2d(static_cast<double>(vertex % (nx + 1)) / nx,
                           1.0 - static_cast<double>(vertex / (nx + 1)) / ny);
  };
  int f = 0;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const int a = j * (nx + 1) + i, b = a + 1, c = a + nx + 2, d = a + nx + 1;
      for (const Eigen::Vector3i& face : {Eigen::Vector3i(a, c, b), Eigen::Vector3i(a, d, c)}) {
        sheet.faces.col(f) = face;
        for (int k = 0; k < 3; ++k) sheet.corner_texcoords.col(3 * f + k) = uv(face[k]);
        ++f;
      }
    }
  }
  return sheet;
}

std::vector<Eigen::Matrix3Xd> SheetSequence(const SheetSceneOptions& o, ClothMotionReport* report) {
  if (IsSimulatedMotion(o.motion)) return SimulateClothMotion(o, report);
  if (report != nullptr) *report = ClothMotionReport();
  std::vector<Eigen::Matrix3Xd> frames;
  for (int t = 0; t < o.frame_count; ++t) {
    frames.push_back(SheetVerticesAt(o, o.frame_count > 1 ? static_cast<double>(t) / (o.frame_count - 1) : 0.0));
  }
  return frames;
}

namespace {

// An OBJ with one texture coordinate per vertex (each vertex's is the same
// at every corner on the grid).
void WriteTemplateObj(const std::string& path, const TriangleMesh& sheet) {
  std::vector<Eigen::Vector2d> vertex_uv(sheet.num_vertices());
  for (int k = 0; k < sheet.num_faces(); ++k) {
    for (int c = 0; c < 3; ++c) vertex_uv[sheet.faces(c, k)] = sheet.corner_texcoords.col(3 * k + c);
  }
  WriteFileAtomically(path, [&](std::ostream& obj) {
    obj.precision(10);
    obj << "# PolyFit synthetic sheet: " << sheet.num_vertices() << " vertices\n";
    for (int v = 0; v < sheet.num_vertices(); ++v) {
      obj << "v " << sheet.vertices(0, v) << ' ' << sheet.vertices(1, v) << ' ' << sheet.vertices(2, v) << '\n';
    }
    for (int v = 0; v < sheet.num_vertices(); ++v) obj << "vt " << vertex_uv[v].x() << ' ' << vertex_uv[v].y() << '\n';
    for (int k = 0; k < sheet.num_faces(); ++k) {
      obj << 'f';
      for (int c = 0; c < 3; ++c) obj << ' ' << sheet.faces(c, k) + 1 << '/' << sheet.faces(c, k) + 1;
      obj << '\n';
    }
  });
}

const char* SheetMotionName(SheetMotion motion) {
  switch (motion) {
    case SheetMotion::kBend: return "bend";
    case SheetMotion::kWave: return "wave";
    case SheetMotion::kRigid: return "rigid";
    case SheetMotion::kRoll: return "roll";
    case SheetMotion::kMixed: return "mixed";
    case SheetMotion::kCrease: return "crease";
    case SheetMotion::kWavePacket: return "wave_packet";
    case SheetMotion::kHanging: return "hanging";
    case SheetMotion::kFlag: return "flag";
    case SheetMotion::kFall: return "fall";
    case SheetMotion::kTable: return "table";
  }
  return "mixed";
}

void WriteSceneJson(const SheetSceneOptions& o, const ClothMotionReport& simulation, const fs::path& dir, double cx,
                    double cy) {
  const FootageImperfections& f = o.imperfections;
  nlohmann::json scene = {{"camera",
                           {{"fx", o.focal_length},
                            {"fy", o.focal_length * o.focal_ratio},
                            {"cx", cx},
                            {"cy", cy},
                            {"width", o.width},
                            {"height", o.height}}},
                          {"template", "template.obj"},
                          {"texture", "texture.png"},
                          {"frames", "frames/%06d.png"},
                          {"ground_truth", "gt/%06d.ply"},
                          {"ground_truth_kind", "vertices"},
                          {"frame_count", o.frame_count},
                          {"first_frame", 0},
                          {"units", "m"},
                          {"generator",
                           {{"motion", SheetMotionName(o.motion)},
                            {"seed", o.seed},
                            {"wavelength", o.wavelength},
                            {"wave_amplitude", o.wave_amplitude},
                            {"yaw_amplitude", o.yaw_amplitude},
                            {"sideways_amplitude", o.sideways_amplitude},
                            {"noise_sigma", o.noise_sigma},
                            {"mask_offset", f.mask_offset},
                            {"mask_ragged", f.mask_ragged},
                            {"mask_holes", f.mask_holes},
                            {"gain_drift", f.gain_drift},
                            {"bias_drift", f.bias_drift},
                            {"shading", f.shading},
                            {"blur", f.blur},
                            {"moving_background", f.moving_background}}}};
  if (o.write_masks) scene["masks"] = "masks/%06d.png";
  if (IsSimulatedMotion(o.motion)) {
    // What a physics prior may read (docs/sft.md: optional keys).
    scene["frame_rate"] = o.frame_rate;
    scene["gravity"] = {simulation.gravity.x(), simulation.gravity.y(), simulation.gravity.z()};
    const auto mm = [](double metres) {
      return std::isfinite(metres) ? nlohmann::json(1e3 * metres) : nlohmann::json();
    };
    scene["generator"]["simulation"] = {{"frame_rate", o.frame_rate},
                                        {"wind_scale", o.wind_scale},
                                        {"substeps", o.cloth.substeps},
                                        {"bending_stiffness", o.cloth.bending_stiffness},
                                        {"max_edge_strain", simulation.max_edge_strain},
                                        {"thickness_mm", mm(simulation.thickness)},
                                        {"min_self_distance_mm", mm(simulation.min_self_distance)},
                                        {"min_obstacle_distance_mm", mm(simulation.min_obstacle_distance)}};
  }
  WriteFileAtomically((dir / "scene.json").string(), [&](std::ostream& out) { out << scene.dump(2) << '\n'; });
}

}  // namespace

void GenerateSheetScene(const SheetSceneOptions& o, const std::string& directory) {
  if (const std::string problem = o.Validate(); !problem.empty()) {
    throw std::invalid_argument("SheetSceneOptions: " + problem);
  }
  const fs::path dir(directory);
  std::error_code error;
  fs::create_directories(dir / "frames", error);
  if (!error) fs::create_directories(dir / "gt", error);
  if (!error && o.write_masks) fs::create_directories(dir / "masks", error);
  if (error) throw Error(ErrorKind::kOutput, directory + ": cannot create the folder: " + error.message());
  std::mt19937_64 rng(o.seed);
  const cv::Mat texture = MakeTexture(o.texture_size, rng);
  const cv::Mat background = MakeBackground(o.width, o.height, rng);
  WriteRgbPng((dir / "texture.png").string(), texture);
  ClothMotionReport simulation;
  const std::vector<Eigen::Matrix3Xd> sequence = SheetSequence(o, &simulation);
  TriangleMesh sheet = MakeSheetMesh(o, sequence.front());
  WriteTemplateObj((dir / "template.obj").string(), sheet);

  const double cx = (o.width - 1) / 2.0 + o.principal_offset_x, cy = (o.height - 1) / 2.0 + o.principal_offset_y;
  const FootageImperfections& imperfect = o.imperfections;
  cv::Mat backdrop;  // as detailed as the sheet, but out of focus and of lower contrast
  if (imperfect.moving_background) {
    cv::GaussianBlur(MakeTexture(std::max(o.width, o.height) + 64, rng), backdrop, cv::Size(0, 0), 1.5);
    backdrop.convertTo(backdrop, -1, 0.6, 0.15);  // every channel (a MatExpr's scalar reaches the first only)
  }
  const bool degrade_mask = imperfect.mask_offset != 0.0 || imperfect.mask_ragged > 0.0 || imperfect.mask_holes > 0;
  std::normal_distribution<float> noise(0.0f, static_cast<float>(o.noise_sigma));
  for (int t = 0; t < o.frame_count; ++t) {
    const double tau = o.frame_count > 1 ? static_cast<double>(t) / (o.frame_count - 1) : 0.0;
    sheet.vertices = sequence[t];
    const std::vector<float> shade = FaceShading(sheet, imperfect.shading);
    cv::Mat color, coverage;
    RenderHard(sheet, texture, o.focal_length, o.focal_length * o.focal_ratio, cx, cy, o.supersampling,
               imperfect.moving_background ? MovingBackground(backdrop, o.width, o.height, t) : background, &color,
               &coverage, &shade);
    DegradeFrame(imperfect, tau, &color);
    if (o.noise_sigma > 0.0) {
      for (auto it = color.begin<cv::Vec3f>(); it != color.end<cv::Vec3f>(); ++it) {
        for (int ch = 0; ch < 3; ++ch) (*it)[ch] = std::clamp((*it)[ch] + noise(rng), 0.0f, 1.0f);
      }
    }
    WriteRgbPng((dir / Frame("frames/%06d.png", t)).string(), color);
    if (o.write_masks) {
      cv::Mat mask;
      (degrade_mask ? DegradeMask(imperfect, coverage, o.seed * 1000003 + t) : coverage).convertTo(mask, CV_8U, 255.0);
      WritePng((dir / Frame("masks/%06d.png", t)).string(), mask);
    }
    WritePly((dir / Frame("gt/%06d.ply", t)).string(), sheet);
  }
  WriteSceneJson(o, simulation, dir, cx, cy);
}

}  // namespace polyfit
