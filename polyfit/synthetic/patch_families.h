// Seeded synthetic patch families of the paper's supplement, on
// (u, v) in [-1, 1]^2, each amplitude alpha in [-0.5, 0.5]:
//   kJet4           a 4-jet, every coefficient in [-0.5, 0.5]
//   kTrigonometric  alpha cos(theta r), theta in [pi, 2 pi]
//   kGaussian       alpha exp(-r^2 / (2 sigma^2)), sigma in [0.5, 1]
//   kBessel         alpha J0(k r), k = 5
//   kSum            the four summed
// with r = |(u, v) - c|, the centre c in [-1, 1]^2 drawn per term. A patch
// is M points at uniform (u, v), placed by a random rotation and a
// translation in [-5, 5]^3, with optional isotropic Gaussian noise.
#ifndef POLYFIT_SYNTHETIC_PATCH_FAMILIES_H_
#define POLYFIT_SYNTHETIC_PATCH_FAMILIES_H_

#include <array>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace polyfit {

enum class SurfaceFamily { kJet4, kTrigonometric, kGaussian, kBessel, kSum };

const char* SurfaceFamilyName(SurfaceFamily family);
// Parses "jet4", "trig", "gaussian", "bessel" or "sum"; throws std::invalid_argument.
SurfaceFamily ParseSurfaceFamily(const std::string& name);

// A height function z(u, v) of one family with its drawn parameters.
class SyntheticSurface {
 public:
  static SyntheticSurface Random(SurfaceFamily family, std::mt19937_64& rng);

  double Height(double u, double v) const;
  // (dz/du, dz/dv).
  Eigen::Vector2d Gradient(double u, double v) const;

 private:
  struct Radial {
    double amplitude = 0.0, parameter = 0.0;  // theta, sigma or k
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  };
  bool has_jet_ = false;
  std::array<double, 15> jet_{};
  Radial trig_, gauss_, bessel_;
};

struct SyntheticPatchOptions {
  SurfaceFamily family = SurfaceFamily::kSum;
  int num_points = 64;
  // Standard deviation of the isotropic noise added to each point.
  double noise_sigma = 0.0;
  // Random rotation and translation in [-translation_range, +]^3.
  bool rigid_motion = true;
  double translation_range = 5.0;
};

struct SyntheticPatch {
  SyntheticSurface surface;
  // world_from_surface: p = rotation * (u, v, z(u, v)) + translation.
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  // 3 by M: the noisy samples, the noise-free surface points under them and
  // the surface's unit normals there (world).
  Eigen::Matrix3Xd points_in_world;
  Eigen::Matrix3Xd surface_points_in_world;
  Eigen::Matrix3Xd surface_normals_in_world;
};

SyntheticPatch GenerateSyntheticPatch(const SyntheticPatchOptions& options, std::mt19937_64& rng);

// count patches from seed, concatenated for FitJetPatches: points 3 by
// (count * M), offsets count + 1.
struct SyntheticPatchSet {
  std::vector<SyntheticPatch> patches;
  Eigen::Matrix3Xd points_in_world;
  std::vector<int> offsets;
};
SyntheticPatchSet GenerateSyntheticPatchSet(const SyntheticPatchOptions& options, int count, uint64_t seed);

}  // namespace polyfit

#endif  // POLYFIT_SYNTHETIC_PATCH_FAMILIES_H_
