// The body's tangent plane under each garment vertex, per frame, without a
// distance query: every vertex within `reach` of the body at rest is bound
// to its closest body point there (a face and barycentric coordinates);
// per pose, the bound faces' corners are skinned as the body is (linear
// blend skinning), and each contact is its point on the posed face and
// the face's normal. Where the garment stays over its binding (a tight
// garment) the plane is the posed body's; these are the contacts
// StrainLimiter (strain_limit.h) keeps vertices above, so that the
// network's drape can be relaxed within its inference
// (network_relaxation.h).
#ifndef POLYFIT_DRAPE_SIMULATE_SKINNED_CONTACTS_H_
#define POLYFIT_DRAPE_SIMULATE_SKINNED_CONTACTS_H_

#include <array>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "drape/body/makehuman_body.h"
#include "drape/simulate/strain_limit.h"

namespace polyfit {

class SkinnedContacts {
 public:
  // body: its rest mesh and skinning weights (copied: the body need not
  // outlive this); garment_rest: 3 by #V, the garment in the body's rest
  // pose; reach (m): vertices further than this from the body at rest (or
  // inside it by more) are not bound.
  SkinnedContacts(const SkinnedBody& body, const Eigen::Matrix3Xd& garment_rest, double reach);

  // rest_to_posed: one transform per joint of the body's skeleton.
  // contacts: one per bound vertex (resized; reuse it across frames). Not
  // thread-safe (the posed corners are kept in a buffer).
  void Pose(const std::vector<Eigen::Isometry3d>& rest_to_posed, std::vector<BodyContact>* contacts) const;

 private:
  struct Bound {
    int vertex;                 // garment vertex
    std::array<int, 3> corner;  // its face's corners, in corner_rest_'s columns
    Eigen::Vector3d barycentric;
  };
  std::vector<Bound> bound_;
  // The bound faces' corners (each body vertex once): rest positions (3 by
  // #corners) and bones, corner c's joint_[offset_[c] .. offset_[c + 1]).
  Eigen::Matrix3Xd corner_rest_;
  std::vector<int> offset_{0}, joint_;
  std::vector<double> weight_;
  int num_joints_ = 0;
  mutable Eigen::Matrix3Xd corner_posed_;
};

}  // namespace polyfit

#endif  // POLYFIT_DRAPE_SIMULATE_SKINNED_CONTACTS_H_
