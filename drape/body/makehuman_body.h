// The CC0 MakeHuman hm08 body (../shared/data/drape/body): its mesh (the
// "body" group, helpers dropped), the CMU-named rig of MPFB2 with joints
// placed from the mesh's joint cubes, and linear blend skinning weights.
//
// Frame and units: metres, Y up, the OBJ's axes (base.obj is in decimetres,
// Y up, A-pose; the rig files are in Blender's frame, Z up, which maps to
// ours by (x, y, z) -> (x, z, -y)).
#ifndef POLYFIT_DRAPE_BODY_MAKEHUMAN_BODY_H_
#define POLYFIT_DRAPE_BODY_MAKEHUMAN_BODY_H_

#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "polyfit/mesh/triangle_mesh.h"
#include "polyfit/util/status.h"

namespace polyfit {

class BodyError : public Error {
 public:
  explicit BodyError(const std::string& message, ErrorKind kind = ErrorKind::kInput) : Error(kind, message) {}
};

struct Skeleton {
  std::vector<std::string> names;
  // Parents precede children; -1 for the root.
  std::vector<int> parents;
  // 3 by #joints: each bone's head (its pivot) in the rest pose.
  Eigen::Matrix3Xd rest_heads;
  // Per joint, the base-mesh vertices whose mean is its head (MakeHuman
  // bodies; empty otherwise), so that a reshaped body moves its joints.
  std::vector<std::vector<int>> head_vertices;

  int num_joints() const { return static_cast<int>(names.size()); }
  int Find(const std::string& name) const;
};

struct SkinnedBody {
  // Vertices (3 by #V, metres) in the rest pose, faces (quads split in two).
  TriangleMesh mesh;
  // Every vertex of base.obj, helpers included (3 by 19158, metres): what
  // garment bindings refer to.
  Eigen::Matrix3Xd base_vertices;
  Skeleton skeleton;
  // Vertex v's bones are weight_joint[weight_offsets[v] .. weight_offsets[v+1])
  // with weights summing to 1.
  std::vector<int> weight_offsets;
  std::vector<int> weight_joint;
  std::vector<double> weight_value;
};

// body_dir: the folder with makehuman/ and mpfb2_rigs/. Throws BodyError
// naming the file and the problem.
SkinnedBody LoadMakeHumanBody(const std::string& body_dir);

// Linear blend skinning: x_v = sum_j w_vj T_j x_v^rest, where T_j maps the
// rest pose to the posed one for bone j (#joints transforms). 3 by #V.
Eigen::Matrix3Xd SkinVertices(const SkinnedBody& body, const std::vector<Eigen::Isometry3d>& rest_to_posed);
// One point's linear blend skinning: its rest position and bones
// (joints[k] with weights[k], k < count), transforms not checked.
Eigen::Vector3d SkinPoint(const Eigen::Vector3d& rest, const int* joints, const double* weights, int count,
                          const std::vector<Eigen::Isometry3d>& rest_to_posed);

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_BODY_MAKEHUMAN_BODY_H_
