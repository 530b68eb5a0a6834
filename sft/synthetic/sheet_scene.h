// The project's own test scenes: a textured A4-like sheet in front of a
// camera under isometric bends, waves and rigid motion, with exact ground
// truth, rendered by a supersampled hard rasterizer with perspective-correct
// texturing (independent of the soft rasterizer the solver uses), written
// in the scene format of ../shared/docs/sft-scene-format.md.
#ifndef POLYFIT_SFT_SYNTHETIC_SHEET_SCENE_H_
#define POLYFIT_SFT_SYNTHETIC_SHEET_SCENE_H_

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "polyfit/mesh/triangle_mesh.h"
#include "sft/synthetic/cloth_simulation.h"
#include "sft/synthetic/footage_imperfections.h"

namespace polyfit {

enum class SheetMotion {
  kBend,        // cylindrical bend (isometric), curvature rising and falling
  kWave,        // a travelling wave across the sheet's height, isometric (arc length kept)
  kRigid,       // rotation and translation of the flat sheet
  kMixed,       // bend and rigid motion together
  kRoll,        // rolled into three quarters of a cylinder, unrolling to half (no height field)
  kCrease,      // a sharp vertical fold closing from flat to a 60 degree dihedral, toward the camera
  kWavePacket,  // about two periods of a travelling wave under a drifting envelope, with rigid motion
  // Simulated cloth (cloth_motion.h): near-inextensible, folds, gravity.
  kHanging,  // hanging from two pins drawn together (a V-shaped sag), gusts toward and away from the camera
  kFlag,     // pinned along one side to a pole, flapping in gusty wind
  kFall,     // released flat above a sphere (not rendered), falling onto it and draping over it
  kTable,    // lying on a table (not rendered), a corner lifted 17 cm and carried over it, folding it
};

// True for the motions that are simulated (no closed form in time).
bool IsSimulatedMotion(SheetMotion motion);

// "bend", "wave", "rigid", "mixed", "roll", "crease", "wave_packet",
// "hanging", "flag", "fall", "table";
// throws std::invalid_argument otherwise.
SheetMotion ParseSheetMotion(const std::string& name);

struct SheetSceneOptions {
  SheetMotion motion = SheetMotion::kMixed;
  int frame_count = 30;
  int width = 320;
  int height = 240;
  // Horizontal field of view of about 58 degrees at 320 pixels.
  double focal_length = 288.0;
  // The camera's fy / fx (fx = focal_length) and its principal point's
  // offset from the image centre (px; x right, y down).
  double focal_ratio = 1.0;
  double principal_offset_x = 0.0;
  double principal_offset_y = 0.0;
  // The sheet (metres) and its grid of template vertices.
  double sheet_width = 0.297;
  double sheet_height = 0.210;
  int grid_x = 24;
  int grid_y = 17;
  double distance = 0.4;
  // The wave's length (metres) and peak amplitude. The default, longer than
  // the sheet, is a gentle wave; 0.14 puts 1.5 periods across the sheet,
  // beyond what one 4-jet represents.
  double wavelength = 0.3;
  double wave_amplitude = 0.015;
  // The rigid motion's peak turn about the vertical axis (radians; pi / 2:
  // edge-on mid-sequence) and sideways travel (m; from about 0.25 the sheet
  // leaves the image and comes back).
  double yaw_amplitude = 0.35;
  double sideways_amplitude = 0.03;
  // Samples per pixel per axis for the hard rasterizer.
  int supersampling = 4;
  bool write_masks = true;
  // Gaussian pixel noise (standard deviation, in [0, 1] intensity units).
  double noise_sigma = 0.0;
  int texture_size = 512;
  std::uint64_t seed = 1;
  // Real footage's masks, lighting, blur and background (all off).
  FootageImperfections imperfections;
  // Simulated motions: frames per second, the cloth's physics, and a
  // factor on the motion's wind (cloth_motion.h).
  double frame_rate = 30.0;
  ClothSimulationOptions cloth;
  double wind_scale = 1.0;

  std::string Validate() const;
  // This scene as real footage would show it: FootageImperfections::
  // RealLike(), fy = 1.03 fx, the principal point 2.5% of the width right
  // and 2% of the height up of the centre, pixel noise of at least 0.01.
  void MakeRealLike();
  // A smaller scene with the same field of view: width x 3/4 width pixels,
  // grid_x x 2/3 grid_x cells, a texture of about 1.6 texels per pixel
  // (fast tests and benchmarks).
  static SheetSceneOptions Small(int width, int grid_x, int frame_count);
};

// Grid vertex v's place on the flat sheet, (x, y) about its centre (m):
// column i = v mod (grid_x + 1) across, row j down.
Eigen::Vector2d SheetGridPoint(const SheetSceneOptions& options, int vertex);

// The sheet's vertices (3 by #V, camera frame) at time tau in [0, 1], for
// the motions in closed form; throws std::invalid_argument for a
// simulated one.
Eigen::Matrix3Xd SheetVerticesAt(const SheetSceneOptions& options, double tau);

// The sheet's vertices at every frame (frame_count of 3 by #V; frame 0 is
// the template), in closed form or simulated. `report`, if given, receives
// the simulation's checks (zero for closed-form motions).
struct ClothMotionReport;
std::vector<Eigen::Matrix3Xd> SheetSequence(const SheetSceneOptions& options, ClothMotionReport* report = nullptr);

// The sheet's grid (grid_x by grid_y cells, two triangles each, vertex
// j (grid_x + 1) + i at column i and row j; texture coordinates spanning
// [0, 1]^2, v up) with the given vertices (3 by #V).
TriangleMesh MakeSheetMesh(const SheetSceneOptions& options, const Eigen::Matrix3Xd& vertices);

// Renders a textured mesh (corner texture coordinates, OBJ convention) over
// `background` (CV_32FC3 RGB) with ss x ss samples per pixel: colour and
// coverage (CV_32F in [0, 1]). face_shade: per face, a factor on its
// colours (none: 1).
void RenderHard(const TriangleMesh& mesh, const cv::Mat& texture, double fx, double fy, double cx, double cy,
                int supersampling, const cv::Mat& background, cv::Mat* color, cv::Mat* coverage,
                const std::vector<float>* face_shade = nullptr);

// Writes the scene into `directory` (created; existing files replaced).
// Throws std::runtime_error naming a file that cannot be written.
void GenerateSheetScene(const SheetSceneOptions& options, const std::string& directory);

}  // namespace polyfit

#endif  // POLYFIT_SFT_SYNTHETIC_SHEET_SCENE_H_
