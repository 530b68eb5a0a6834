#include "polyfit/synthetic/patch_families.h"

#include <cmath>
#include <stdexcept>

#include <Eigen/Geometry>

#include "polyfit/jet/jet_surface.h"

namespace polyfit {

const char* SurfaceFamilyName(SurfaceFamily family) {
  switch (family) {
    case SurfaceFamily::kJet4: return "jet4";
    case SurfaceFamily::kTrigonometric: return "trig";
    case SurfaceFamily::kGaussian: return "gaussian";
    case SurfaceFamily::kBessel: return "bessel";
    case SurfaceFamily::kSum: return "sum";
  }
  return "?";
}

SurfaceFamily ParseSurfaceFamily(const std::string& name) {
  for (SurfaceFamily f : {SurfaceFamily::kJet4, SurfaceFamily::kTrigonometric, SurfaceFamily::kGaussian,
                          SurfaceFamily::kBessel, SurfaceFamily::kSum}) {
    if (name == SurfaceFamilyName(f)) return f;
  }
  throw std::invalid_argument("unknown surface family '" + name + "' (expected jet4, trig, gaussian, bessel or sum)");
}

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr double kBesselK = 5.0;

double Uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}
}  // namespace

SyntheticSurface SyntheticSurface::Random(SurfaceFamily family, std::mt19937_64& rng) {
  SyntheticSurface s;
  const bool all = family == SurfaceFamily::kSum;
  auto radial = [&rng](double lo, double hi) {
    Radial r;
    r.amplitude = Uniform(rng, -0.5, 0.5);
    r.parameter = Uniform(rng, lo, hi);
    r.centre = Eigen::Vector2d(Uniform(rng, -1, 1), Uniform(rng, -1, 1));
    return r;
  };
  if (all || family == SurfaceFamily::kJet4) {
    s.has_jet_ = true;
    for (double& a : s.jet_) a = Uniform(rng, -0.5, 0.5);
  }
  if (all || family == SurfaceFamily::kTrigonometric) s.trig_ = radial(kPi, 2 * kPi);
  if (all || family == SurfaceFamily::kGaussian) s.gauss_ = radial(0.5, 1.0);
  if (all || family == SurfaceFamily::kBessel) s.bessel_ = radial(kBesselK, kBesselK);
  return s;
}

double SyntheticSurface::Height(double u, double v) const {
  double z = has_jet_ ? EvaluateJetHeight(4, jet_.data(), u, v) : 0.0;
  auto r = [u, v](const Radial& t) { return std::hypot(u - t.centre.x(), v - t.centre.y()); };
  // Absent terms have amplitude 0 (and parameter 0): skip, not 0 * NaN.
  if (trig_.amplitude != 0) z += trig_.amplitude * std::cos(trig_.parameter * r(trig_));
  if (gauss_.amplitude != 0) {
    const double rg = r(gauss_);
    z += gauss_.amplitude * std::exp(-rg * rg / (2 * gauss_.parameter * gauss_.parameter));
  }
  if (bessel_.amplitude != 0) {
    z += bessel_.amplitude * std::cyl_bessel_j(0.0, bessel_.parameter * r(bessel_));
  }
  return z;
}

Eigen::Vector2d SyntheticSurface::Gradient(double u, double v) const {
  Eigen::Vector2d g = Eigen::Vector2d::Zero();
  if (has_jet_) {
    const auto d = EvaluateJetDerivatives(4, jet_.data(), u, v);
    g = Eigen::Vector2d(d.z_u, d.z_v);
  }
  // d f(r) = f'(r) (p - c) / r, with f'(r) r^-1 bounded at r = 0 for each term.
  const Eigen::Vector2d p(u, v);
  if (trig_.amplitude != 0) {
    const Eigen::Vector2d d = p - trig_.centre;
    const double r = d.norm();
    const double th = trig_.parameter;
    const double fr = r > 1e-12 ? -trig_.amplitude * th * std::sin(th * r) / r : -trig_.amplitude * th * th;
    g += fr * d;
  }
  if (gauss_.amplitude != 0) {
    const Eigen::Vector2d d = p - gauss_.centre;
    const double s2 = gauss_.parameter * gauss_.parameter;
    g += -gauss_.amplitude * std::exp(-d.squaredNorm() / (2 * s2)) / s2 * d;
  }
  if (bessel_.amplitude != 0) {
    const Eigen::Vector2d d = p - bessel_.centre;
    const double r = d.norm();
    const double k = bessel_.parameter;
    // J0'(x) = -J1(x); J1(x) / x -> 1/2 at 0.
    const double fr =
        r > 1e-12 ? -bessel_.amplitude * k * std::cyl_bessel_j(1.0, k * r) / r : -bessel_.amplitude * k * k * 0.5;
    g += fr * d;
  }
  return g;
}

SyntheticPatch GenerateSyntheticPatch(const SyntheticPatchOptions& options, std::mt19937_64& rng) {
  SyntheticPatch patch;
  patch.surface = SyntheticSurface::Random(options.family, rng);
  if (options.rigid_motion) {
    std::normal_distribution<double> normal(0.0, 1.0);
    Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
    patch.rotation = q.normalized().toRotationMatrix();
    const double t = options.translation_range;
    patch.translation = Eigen::Vector3d(Uniform(rng, -t, t), Uniform(rng, -t, t), Uniform(rng, -t, t));
  }
  const int m = options.num_points;
  patch.points_in_world.resize(3, m);
  patch.surface_points_in_world.resize(3, m);
  patch.surface_normals_in_world.resize(3, m);
  std::normal_distribution<double> noise(0.0, options.noise_sigma > 0 ? options.noise_sigma : 1.0);
  for (int i = 0; i < m; ++i) {
    const double u = Uniform(rng, -1, 1), v = Uniform(rng, -1, 1);
    const Eigen::Vector3d p = patch.rotation * Eigen::Vector3d(u, v, patch.surface.Height(u, v)) + patch.translation;
    const Eigen::Vector2d g = patch.surface.Gradient(u, v);
    patch.surface_points_in_world.col(i) = p;
    patch.surface_normals_in_world.col(i) = patch.rotation * Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
    patch.points_in_world.col(i) = p;
    if (options.noise_sigma > 0) {
      patch.points_in_world.col(i) += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    }
  }
  return patch;
}

SyntheticPatchSet GenerateSyntheticPatchSet(const SyntheticPatchOptions& options, int count, uint64_t seed) {
  std::mt19937_64 rng(seed);
  SyntheticPatchSet set;
  set.patches.reserve(count);
  set.offsets.reserve(count + 1);
  set.offsets.push_back(0);
  for (int p = 0; p < count; ++p) {
    set.patches.push_back(GenerateSyntheticPatch(options, rng));
    set.offsets.push_back(set.offsets.back() + options.num_points);
  }
  set.points_in_world.resize(3, set.offsets.back());
  for (int p = 0; p < count; ++p) {
    set.points_in_world.middleCols(set.offsets[p], options.num_points) = set.patches[p].points_in_world;
  }
  return set;
}

}  // namespace polyfit
