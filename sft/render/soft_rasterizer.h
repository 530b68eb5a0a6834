// A soft rasterizer (SoftRas: Liu et al., ICCV 2019) on OpenCV images, with
// exact derivatives of every pixel with respect to the projected vertices.
//
// For pixel p and triangle j (projected to pixels), with d_j the distance
// from p to the triangle's boundary and delta_j = +1 inside, -1 outside
// (edges shared with another triangle count as hard; see boundary_edges):
//   D_j = sigmoid(delta_j d_j^2 / sigma)                 coverage
//   S   = 1 - prod_j (1 - D_j)                            silhouette
//   w_j = D_j exp(z_j / gamma) / (sum_k D_k exp(z_k / gamma) + exp(eps / gamma))
//   I   = sum_j w_j C_j + w_b C_b                          colour
// or, with Compositing::kOver, each triangle laid over those behind it:
//   I   = sum_j T_j D_j C_j / (1 - T_n),  T_j = prod_{k nearer} (1 - D_k)
// or, with Compositing::kOverBackground, the same over the background:
//   I   = sum_j T_j D_j C_j + T_n C_b
// z_j is the normalised inverse depth of triangle j at p (1 nearest, 0
// farthest; perspective-correct), C_j the texture's bilinear colour at the
// triangle's interpolated texture coordinates (at the closest point of the
// triangle for pixels outside it; from the face's mip level with mipmap),
// C_b the background (a colour, or an
// image: the observed frame, so that pixels the object does not cover match
// exactly and only the object's own pixels carry residuals; for
// kOverBackground, what lies behind the object: sft/render/
// background_plate.h).
//
// Each triangle touches only pixels within sqrt(cutoff * sigma) of it
// (beyond, D_j < 1e-4): triangles are binned into 8 x 8 tiles, and pixels
// are rendered in parallel.
#ifndef POLYFIT_SFT_RENDER_SOFT_RASTERIZER_H_
#define POLYFIT_SFT_RENDER_SOFT_RASTERIZER_H_

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "sft/camera/pinhole_camera.h"

namespace polyfit {

// How a pixel's colour comes from the triangles that reach it.
enum class Compositing {
  // SoftRas: weights D_j exp(z_j / gamma), normalised with the
  // background's. A layer within gamma of the nearest shows through it,
  // and a soft edge shows its triangle's colour in full wherever a
  // nearer-than-background triangle reaches.
  kSoftZ,
  // Depth-sorted "over": each triangle, nearest first, covers what lies
  // behind it by D_j. The nearest layer wins, by its coverage at its
  // edges, as a camera's pixel sees it; gamma is not used.
  kOver,
  // kOver with the background as the last, opaque layer: a pixel the
  // surface covers by D shows D of its colour and 1 - D of the
  // background's, as a camera's pixel over the object's rim does. Right
  // only where the background is what lies behind the surface (not the
  // observed frame, which already holds the surface: against it the rim's
  // residual is not zero at the truth).
  kOverBackground,
};

struct SoftRasterizerOptions {
  // sigma, in pixels squared: the width of the coverage sigmoid.
  double sigma = 0.5;
  // gamma: the depth blending temperature (smaller: harder z-buffer).
  double gamma = 1e-2;
  // Whether the colour's derivatives include the blend weights' change
  // with depth (exact when true). False: which layer shows is left to
  // the geometry, so that the photometric term cannot pull a layer in
  // front of another or push it behind (with a hard z-buffer that pull
  // is 1/gamma strong); the derivatives are then those of the blend with
  // its depth weights frozen.
  bool depth_gradient = true;
  // eps: the background's normalised depth.
  double background_depth = 1e-3;
  // Coverage below sigmoid(-cutoff) is ignored.
  double cutoff = 9.2;
  // Each triangle's derivatives at a pixel by hand (true) or by Ceres'
  // jets (false: the reference they are tested against; slower).
  bool analytic_derivatives = true;
  Compositing compositing = Compositing::kSoftZ;
  // Mip-mapping: each face reads the texture prefiltered to its footprint
  // on screen (FaceMipLevels; trilinear between levels), so that a far or
  // grazing part does not alias. False: the texture as given everywhere.
  bool mipmap = false;
  // Added to each face's level. Below 0, a face reads the sharper level
  // for longer: trilinear blending already blurs, and a texture that the
  // caller prefiltered to about one texel per pixel where the surface is
  // nearest needs no more there.
  double mip_level_bias = -0.25;
  // Background colour when no background image is given (RGB in [0, 1]).
  Eigen::Vector3d background_color = Eigen::Vector3d::Zero();
  int num_threads = 0;

  std::string Validate() const;
};

// The mesh as the camera sees it.
struct ScreenMesh {
  // 2 by #V pixel coordinates and #V depths (> 0).
  Eigen::Matrix2Xd pixels;
  Eigen::VectorXd depths;
  // 3 by #F vertex indices.
  Eigen::Matrix3Xi faces;
  // 2 by 3#F texture coordinates per corner (OBJ convention: v up).
  Eigen::Matrix2Xd corner_texcoords;
  // Depth range for the normalised inverse depth z_j (fixed by the caller,
  // e.g. from the template, so that it is not a function of the vertices).
  double depth_near = 0.1;
  double depth_far = 10.0;
  // Per face, bit e set when edge e (corner e to e + 1) is on the mesh's
  // boundary (MeshBoundaryEdgeFlags). Interior edges are then hard: plain
  // SoftRas softens every edge, so two triangles sharing one each cover it
  // by 1/2 and the silhouette dips to 3/4 along every interior edge. Empty:
  // every edge is soft (plain SoftRas).
  std::vector<std::uint8_t> boundary_edges;
  // Per face, the mip level its texture is read at (options.mipmap), fixed
  // by the caller; empty: FaceMipLevels of these pixels. Either way the
  // levels are constants of the derivatives.
  std::vector<float> face_mip_levels;
};

// The gamma under which a surface `softness` metres behind another at
// `depth` weighs e times less: z's slope there is 1 / (depth^2 (1/near -
// 1/far)) per metre.
double SoftnessToGamma(double softness, double depth, double depth_near, double depth_far);

// Each face's mip level (#F): log2 of its texel footprint, the longer of
// d(texel)/d(pixel x) and d(texel)/d(pixel y) from the affine map of its
// corners on a texture_width by texture_height level 0, plus bias, within
// [0, num_levels - 1]. A face with no area on screen gets the coarsest.
void FaceMipLevels(const ScreenMesh& mesh, int texture_width, int texture_height, int num_levels, double bias,
                   std::vector<float>* levels);

// The boundary_edges flags of a mesh's faces (an edge used by one face only).
std::vector<std::uint8_t> MeshBoundaryEdgeFlags(const Eigen::Matrix3Xi& faces);

// Projects vertices (3 by #V, camera frame) into screen->pixels and
// screen->depths, and optionally the 3 by 3 Jacobian of (px, py, depth) per
// vertex stacked (3 #V by 3). False when a vertex is not in front of the
// camera.
bool ProjectVertices(const PinholeCamera& camera, const Eigen::Matrix3Xd& vertices, ScreenMesh* screen,
                     Eigen::MatrixXd* jacobian);

// One pixel's derivatives with respect to one vertex: d(R, G, B, S) /
// d(x, y, depth), row-major 4 by 3.
struct VertexGradient {
  int vertex = 0;
  float d[4][3] = {};
};

struct SoftRenderOutput {
  // CV_32FC3 RGB and CV_32F silhouette, width by height.
  cv::Mat color;
  cv::Mat silhouette;
  // With gradients: for pixel i = y * width + x, the vertices it depends on
  // are gradients[begin[i] .. end[i]).
  std::vector<int> begin, end;
  std::vector<VertexGradient> gradients;
  int num_covered_pixels = 0;
  // Scratch, per tile, kept so that rendering again into the same output
  // allocates nothing (fresh buffers cost more in page faults than the
  // rasterization of a small mesh).
  std::vector<std::vector<VertexGradient>> tile_gradients;
  std::vector<std::vector<int>> tile_triangles;
  std::vector<float> face_mip_levels;
};

class SoftRasterizer {
 public:
  // texture: CV_32FC3 RGB in [0, 1]; kept by reference (cv::Mat header).
  SoftRasterizer(const SoftRasterizerOptions& options, const cv::Mat& texture);

  // Renders width by height pixels. background: CV_32FC3 of that size, or
  // empty for options.background_color. Only pixels inside `roi` (if not
  // empty) are rendered; the others are background with no gradient.
  void Render(const ScreenMesh& mesh, int width, int height, const cv::Mat& background, bool with_gradients,
              SoftRenderOutput* output, const cv::Rect& roi = cv::Rect()) const;

  const SoftRasterizerOptions& options() const { return options_; }
  // 1 without mip-mapping; else level 0 (the texture) and each level half
  // the one before, down to 2 by 2.
  int num_mip_levels() const { return mips_.empty() ? 1 : static_cast<int>(mips_.size()); }

 private:
  SoftRasterizerOptions options_;
  cv::Mat texture_;
  std::vector<cv::Mat> mips_;  // options_.mipmap: level 0 the texture, each half the one before
};

}  // namespace polyfit

#endif  // POLYFIT_SFT_RENDER_SOFT_RASTERIZER_H_
