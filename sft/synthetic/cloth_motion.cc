#include "sft/synthetic/cloth_motion.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <stdexcept>

namespace polyfit {
namespace {

// 0 before 0, 1 after 1, smooth in between.
double SmoothStep(double s) {
  s = std::clamp(s, 0.0, 1.0);
  return s * s * (3.0 - 2.0 * s);
}

// A gust: three seeded sines of 0.3-1.2 Hz, within [-1, 1].
class Gust {
 public:
  explicit Gust(std::mt19937_64& rng) {
    std::uniform_real_distribution<double> frequency(0.3, 1.2), phase(0.0, 2.0 * M_PI);
    for (int k = 0; k < 3; ++k) {
      frequency_[k] = frequency(rng);
      phase_[k] = phase(rng);
    }
  }
  double operator()(double t) const {
    double g = 0.0;
    for (int k = 0; k < 3; ++k) g += kWeight[k] * std::sin(2.0 * M_PI * frequency_[k] * t + phase_[k]);
    return g;
  }

 private:
  static constexpr double kWeight[3] = {0.6, 0.3, 0.1};
  double frequency_[3], phase_[3];
};

// What a motion scripts: where the flat sheet starts (its grid's x along
// `across`, y along `down`, about `origin`), the camera's pitch (gravity),
// pins and their targets at time t (s; negative while settling), the wind,
// an obstacle, and how long the cloth settles before frame 0.
struct ClothScript {
  Eigen::Vector3d origin, across = Eigen::Vector3d::UnitX(), down = Eigen::Vector3d::UnitY();
  // The flat sheet's out-of-plane offset (along across x down) at (x, y).
  std::function<double(double, double)> offset;
  double pitch = 0.0;  // radians, the camera looking down
  std::vector<int> pins;
  std::function<Eigen::Vector3d(int pin, double t)> pin_target;
  std::function<Eigen::Vector3d(double t)> wind;
  ClothObstacle obstacle;
  double settle_seconds = 0.0;
  double settle_damping = 4.0;
};

// World up in the camera frame for a camera pitched down by p:
// (0, -cos p, -sin p); the horizontal away from it: (0, -sin p, cos p).
Eigen::Vector3d Up(double pitch) { return Eigen::Vector3d(0.0, -std::cos(pitch), -std::sin(pitch)); }
Eigen::Vector3d Away(double pitch) { return Eigen::Vector3d(0.0, -std::sin(pitch), std::cos(pitch)); }

int GridVertex(const SheetSceneOptions& o, int i, int j) { return j * (o.grid_x + 1) + i; }

// Hanging from its top corners, which are drawn together to 3/4 of the
// width while it settles (a sag between them; the sheet starts bowed 1 cm
// away from the camera so that it sags that way), then gusts along the
// view axis of up to 1.5 m/s.
ClothScript Hanging(const SheetSceneOptions& o, std::mt19937_64& rng) {
  ClothScript s;
  s.origin = Eigen::Vector3d(0.0, 0.0, o.distance);
  const double w = o.sheet_width;
  s.offset = [w](double x, double) { return 0.01 * (1.0 - 4.0 * x * x / (w * w)); };
  s.pins = {GridVertex(o, 0, 0), GridVertex(o, o.grid_x, 0)};
  const Eigen::Vector3d top = s.origin - 0.5 * o.sheet_height * s.down;
  const double settle = 2.0;
  s.pin_target = [=](int pin, double t) {
    const double half = 0.5 * w * (1.0 - 0.25 * SmoothStep((t + settle) / (0.5 * settle)));
    return Eigen::Vector3d(top + (pin == 0 ? -half : half) * Eigen::Vector3d::UnitX());
  };
  const Gust gust(rng);
  const double peak = 1.5 * o.wind_scale;
  s.wind = [=](double t) { return Eigen::Vector3d(0.0, 0.0, t < 0.0 ? 0.0 : peak * gust(t)); };
  s.settle_seconds = settle;
  return s;
}

// Pinned along its left side (the pole), the wind blowing away from the
// pole at 5 m/s with gusts of +-30% and gusting across the sheet at up to
// 1.5 m/s.
ClothScript Flag(const SheetSceneOptions& o, std::mt19937_64& rng) {
  ClothScript s;
  s.origin = Eigen::Vector3d(0.0, 0.0, o.distance);
  for (int j = 0; j <= o.grid_y; ++j) s.pins.push_back(GridVertex(o, 0, j));
  const Gust along(rng), across(rng);
  const double scale = o.wind_scale;
  s.wind = [=](double t) {
    return Eigen::Vector3d(5.0 * scale * (1.0 + 0.3 * along(t)), 0.0, 1.5 * scale * across(t));
  };
  return s;
}

// Level, 9 cm above the top of a sphere of radius 8 cm (1 cm to the side of
// the sheet's centre), released at frame 0; the camera looks down 50
// degrees.
ClothScript Fall(const SheetSceneOptions& o) {
  ClothScript s;
  s.pitch = 50.0 * M_PI / 180.0;
  const Eigen::Vector3d up = Up(s.pitch), centre(0.0, 0.0, o.distance);
  s.origin = centre + 0.06 * up;
  s.down = Away(s.pitch);
  s.obstacle.kind = ClothObstacle::Kind::kSphere;
  s.obstacle.radius = 0.08;
  s.obstacle.point = centre - 0.11 * up + 0.01 * Eigen::Vector3d::UnitX();
  s.obstacle.friction = 0.5;
  return s;
}

// Lying on a table; its near right corner lifted 17 cm over 0.5 s, carried
// 22 cm toward the far left over 0.8 s and lowered to 4 cm over the next
// 0.4 s, folding the cloth over itself as one folds a towel; the camera
// looks down 45 degrees.
ClothScript Table(const SheetSceneOptions& o, double thickness) {
  ClothScript s;
  s.pitch = 45.0 * M_PI / 180.0;
  const Eigen::Vector3d up = Up(s.pitch), away = Away(s.pitch), centre(0.0, 0.0, o.distance);
  s.origin = centre + 0.5 * thickness * up - 0.04 * Eigen::Vector3d::UnitX();  // room on the right for the lift
  s.down = away;
  s.obstacle.kind = ClothObstacle::Kind::kPlane;
  s.obstacle.point = centre;
  s.obstacle.normal = up;
  s.obstacle.friction = 0.6;
  s.pins = {GridVertex(o, o.grid_x, 0)};
  const Eigen::Vector3d corner =
      s.origin + 0.5 * o.sheet_width * Eigen::Vector3d::UnitX() - 0.5 * o.sheet_height * away;
  const Eigen::Vector3d carry = 0.22 * (-Eigen::Vector3d::UnitX() + 0.7 * away).normalized();
  s.pin_target = [=](int, double t) {
    const double height = 0.17 * SmoothStep(t / 0.5) - 0.13 * SmoothStep((t - 1.1) / 0.4);
    return Eigen::Vector3d(corner + height * up + SmoothStep((t - 0.5) / 0.8) * carry);
  };
  return s;
}

ClothScript MakeScript(const SheetSceneOptions& o, double thickness, std::mt19937_64& rng) {
  switch (o.motion) {
    case SheetMotion::kHanging: return Hanging(o, rng);
    case SheetMotion::kFlag: return Flag(o, rng);
    case SheetMotion::kFall: return Fall(o);
    case SheetMotion::kTable: return Table(o, thickness);
    default: break;
  }
  throw std::invalid_argument("SimulateClothMotion: the motion is not simulated");
}

// The flat grid laid out as the script says.
Eigen::Matrix3Xd LayOut(const SheetSceneOptions& o, const ClothScript& s) {
  const int n = (o.grid_x + 1) * (o.grid_y + 1);
  const Eigen::Vector3d normal = s.across.cross(s.down);
  Eigen::Matrix3Xd x(3, n);
  for (int v = 0; v < n; ++v) {
    const Eigen::Vector2d p = SheetGridPoint(o, v);
    x.col(v) = s.origin + p.x() * s.across + p.y() * s.down + (s.offset ? s.offset(p.x(), p.y()) : 0.0) * normal;
  }
  return x;
}

void Step(const ClothScript& script, double t, double dt, ClothSimulation* cloth) {
  for (size_t k = 0; k < script.pins.size(); ++k) {
    if (script.pin_target) cloth->SetPinTarget(script.pins[k], script.pin_target(static_cast<int>(k), t + dt));
  }
  if (script.wind) cloth->SetWind(script.wind(t));
  cloth->Advance(dt);
}

}  // namespace

std::vector<Eigen::Matrix3Xd> SimulateClothMotion(const SheetSceneOptions& o, ClothMotionReport* report) {
  if (!IsSimulatedMotion(o.motion)) throw std::invalid_argument("SimulateClothMotion: the motion is not simulated");
  if (!(o.frame_rate > 0.0)) throw std::invalid_argument("SimulateClothMotion: frame_rate must be > 0");
  std::mt19937_64 rng(o.seed * 7919 + 17);
  // The table's script lays the sheet half a thickness above it.
  ClothScript flat;
  flat.origin.setZero();
  const double thickness = ClothThickness(MakeSheetMesh(o, LayOut(o, flat)), o.cloth);
  const ClothScript script = MakeScript(o, thickness, rng);
  ClothSimulationOptions physics = o.cloth;
  physics.gravity = 9.81 * -Up(script.pitch);
  ClothSimulation cloth(MakeSheetMesh(o, LayOut(o, script)), physics);
  for (int pin : script.pins) cloth.Pin(pin);
  cloth.SetObstacle(script.obstacle);
  const double dt = 1.0 / o.frame_rate;
  const int settle_frames = static_cast<int>(std::ceil(script.settle_seconds / dt));
  cloth.SetDamping(script.settle_damping);
  for (int k = 0; k < settle_frames; ++k) Step(script, (k - settle_frames) * dt, dt, &cloth);
  cloth.SetDamping(o.cloth.damping);

  ClothMotionReport checks;
  checks.thickness = cloth.thickness();
  checks.gravity = physics.gravity;
  checks.min_self_distance = checks.min_obstacle_distance = std::numeric_limits<double>::infinity();
  std::vector<Eigen::Matrix3Xd> frames;
  for (int t = 0; t < o.frame_count; ++t) {
    if (t > 0) Step(script, (t - 1) * dt, dt, &cloth);
    frames.push_back(cloth.positions());
    checks.max_edge_strain = std::max(checks.max_edge_strain, cloth.MaxEdgeStrain());
    checks.min_self_distance = std::min(checks.min_self_distance, cloth.MinSelfDistance());
    checks.min_obstacle_distance = std::min(checks.min_obstacle_distance, cloth.MinObstacleDistance());
    if (!frames.back().allFinite()) throw std::runtime_error("SimulateClothMotion: the cloth diverged");
  }
  if (report != nullptr) *report = checks;
  return frames;
}

}  // namespace polyfit
