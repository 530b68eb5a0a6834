// Keypoint correspondences between the template and a frame: SIFT
// keypoints of the textured template as the first frame sees it, each
// located on the surface (a face and barycentric coordinates), matched to
// the frame's keypoints. They reach as far as the surface can
// move in one frame, where the image terms' gradients reach only the
// pyramid's coarsest blur: a falling or flapping cloth moves tens of
// pixels between frames.
//
// Matches are kept when they pass Lowe's ratio test and agree with their
// neighbours: the frame pixels of the K matches nearest in the texture
// predict, through their least-squares affine map, where this one should
// be (a smooth surface is locally affine between texture and image), and
// a match further from its prediction than the tolerance is dropped. What
// survives may still hold outliers; the solver's robust loss takes them.
#ifndef POLYFIT_SFT_SOLVER_TEXTURE_FEATURES_H_
#define POLYFIT_SFT_SOLVER_TEXTURE_FEATURES_H_

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace polyfit {

struct TextureFeatureOptions {
  // Keypoints kept (the strongest) in the texture and per frame.
  int max_texture_keypoints = 3000;
  int max_frame_keypoints = 3000;
  // Lowe's ratio: the best match's descriptor distance under this times
  // the second best's.
  double ratio = 0.8;
  // The neighbourhood consistency check: K nearest matches in the texture,
  // and the tolerance in frame pixels (at least; it grows with the
  // neighbourhood's spread in the frame by `relative_tolerance`).
  int neighbours = 8;
  double tolerance_px = 3.0;
  double relative_tolerance = 0.15;
  // Fewer matches than this in a frame: none (too few to trust).
  int min_matches = 8;
  // A cloth shows its back too: a flap turned over, a corner folded onto
  // the sheet. Seen from behind, its texture is the mirror image of the
  // view's, whose descriptors SIFT does not match; with this on, the
  // view's mirror image gives keypoints of its own (the same surface
  // points where a pattern is symmetric), matched apart from the view's.
  bool mirrored = true;

  std::string Validate() const;
};

// A point of the template's surface: face f, barycentric coordinates b
// over its corners, and where it is in a frame (pixels, full size).
struct FeatureMatch {
  int face = 0;
  Eigen::Vector3d barycentric = Eigen::Vector3d::Zero();
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();

  // The point on a surface with the template's faces (3 by #F) and these
  // vertices (3 by #V).
  Eigen::Vector3d PointOn(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& faces) const {
    return barycentric[0] * vertices.col(faces(0, face)) + barycentric[1] * vertices.col(faces(1, face)) +
           barycentric[2] * vertices.col(faces(2, face));
  }
};

class TextureFeatures {
 public:
  // The keypoints of `view` (RGB CV_32FC3 in [0, 1]), an image of the
  // template's surface: the template rendered where the first frame sees
  // it, so that later frames show its texture as this does (not mirrored,
  // foreshortened alike). view_mask (CV_32F or CV_8U, > 0.5 or nonzero:
  // usable; empty: all) says where keypoints may lie. corner_pixels (2 by
  // 3 #F) is each face corner's position in the view (pixels, centres at
  // integers), corner_depths (3 #F, or empty) their depths: where faces
  // overlap, the nearest holds the keypoint.
  TextureFeatures(const TextureFeatureOptions& options, const cv::Mat& view, const cv::Mat& view_mask,
                  const Eigen::Matrix2Xd& corner_pixels, const Eigen::VectorXd& corner_depths);

  // Keypoints of the view that lie on the surface, at distinct places: a
  // mirrored keypoint (TextureFeatureOptions::mirrored) within 3 pixels
  // of one of the view's (a symmetric pattern, an outline's corner) counts
  // once.
  int size() const { return distinct_; }

  // Correspondences in `frame` (RGB CV_32FC3 in [0, 1], pixels as the
  // frame's); with a mask (CV_32F, 1 inside), keypoints only within a few
  // pixels of it. Empty when fewer than min_matches survive.
  std::vector<FeatureMatch> Match(const cv::Mat& frame, const cv::Mat& mask) const;

 private:
  TextureFeatureOptions options_;
  // Per surface keypoint: its face and barycentric coordinates, its
  // position in the view, and its descriptor (a row): the view's first,
  // then (TextureFeatureOptions::mirrored) its mirror image's, whose
  // positions are mapped back into the view.
  std::vector<FeatureMatch> surface_;
  std::vector<Eigen::Vector2d> view_points_;
  cv::Mat descriptors_;
  cv::Mat mirrored_descriptors_;
  int distinct_ = 0;
};

// The consistency check alone (exposed for tests): of matches from points
// `from` (texture) to `to` (frame), which agree with the local affine map of
// their K nearest neighbours in `from` (see above).
std::vector<bool> ConsistentMatches(const std::vector<Eigen::Vector2d>& from, const std::vector<Eigen::Vector2d>& to,
                                    int neighbours, double tolerance_px, double relative_tolerance);

}  // namespace polyfit

#endif  // POLYFIT_SFT_SOLVER_TEXTURE_FEATURES_H_
