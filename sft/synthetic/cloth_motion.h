// The generator's simulated cloth motions (SheetMotion kHanging, kFlag,
// kFall, kTable): the sheet's grid as XPBD cloth (cloth_simulation.h),
// scripted pins, wind and obstacles, in the camera frame (x right, y down,
// z forward). For the fall and the table the camera looks down on the
// scene (pitched 50 and 45 degrees), so gravity has a component along z.
// Obstacles are not rendered. Motions start from the sheet laid out flat
// (the hanging cloth first settles for two seconds between its pins);
// frame 0, the template, is where the frames start.
#ifndef POLYFIT_SFT_SYNTHETIC_CLOTH_MOTION_H_
#define POLYFIT_SFT_SYNTHETIC_CLOTH_MOTION_H_

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "sft/synthetic/sheet_scene.h"

namespace polyfit {

// What the simulation checked over the frames: the cloth's worst edge
// strain, the closest approach of vertices that are apart at rest (below
// the thickness: the cloth went through itself), and of any vertex to the
// obstacle's surface (< 0: inside it; +inf without an obstacle).
struct ClothMotionReport {
  double max_edge_strain = 0.0;
  double min_self_distance = 0.0;
  double min_obstacle_distance = 0.0;
  double thickness = 0.0;
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();  // m/s^2, camera frame
};

// frame_count frames of 3 by #V (the grid of MakeSheetMesh). Throws
// std::invalid_argument for a motion that is not simulated.
std::vector<Eigen::Matrix3Xd> SimulateClothMotion(const SheetSceneOptions& options, ClothMotionReport* report);

}  // namespace polyfit

#endif  // POLYFIT_SFT_SYNTHETIC_CLOTH_MOTION_H_
