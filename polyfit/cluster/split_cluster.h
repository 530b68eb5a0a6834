// Splits one cluster of faces in two where a single jet cannot hold it (a
// fold, a cuff): 2-means (kmeans.h) on each face's 6-d feature
//   (n_f, (c_f - mean) / radius)
// with n_f its unit normal, c_f its centroid, and mean and radius those of
// the cluster's centroids, so that orientation and position weigh alike at
// any size. Seeds: the face farthest from the first face, then the face
// farthest from that one.
#ifndef POLYFIT_CLUSTER_SPLIT_CLUSTER_H_
#define POLYFIT_CLUSTER_SPLIT_CLUSTER_H_

#include <vector>

#include <Eigen/Core>

namespace polyfit {

// normals, centroids: 3 by #F for the whole mesh (per_face_normals.h,
// face_centroids.h); faces: the cluster's face indices. Returns 0 or 1 per
// entry of `faces`, or an empty vector when the cluster has fewer than 4
// faces or does not separate.
std::vector<int> SplitClusterInTwo(const Eigen::Matrix3Xd& normals, const Eigen::Matrix3Xd& centroids,
                                   const std::vector<int>& faces);

}  // namespace polyfit

#endif  // POLYFIT_CLUSTER_SPLIT_CLUSTER_H_
