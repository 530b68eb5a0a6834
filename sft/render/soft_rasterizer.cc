#include "sft/render/soft_rasterizer.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <type_traits>

#include <ceres/jet.h>
#include <opencv2/imgproc.hpp>

#include "polyfit/mesh/mesh_topology.h"
#include "polyfit/util/parallel_for.h"

namespace polyfit {
namespace {

constexpr int kTile = 8;
// Local variables of one triangle: x, y of its three corners, then their depths.
using J9 = ceres::Jet<double, 9>;

// Bilinear texture lookup at OBJ texture coordinates (v up), clamped at the
// borders: colour and its derivatives with respect to u and v (or the
// colour alone, where d_du and d_dv are null).
void SampleTexture(const cv::Mat& texture, double u, double v, Eigen::Vector3d* color, Eigen::Vector3d* d_du,
                   Eigen::Vector3d* d_dv) {
  const int w = texture.cols, h = texture.rows;
  const double x = u * w - 0.5, y = (1.0 - v) * h - 0.5;
  const double xc = std::clamp(x, 0.0, w - 1.0), yc = std::clamp(y, 0.0, h - 1.0);
  const int x0 = std::min(static_cast<int>(xc), w - 2 < 0 ? 0 : w - 2);
  const int y0 = std::min(static_cast<int>(yc), h - 2 < 0 ? 0 : h - 2);
  const int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
  const double fx = xc - x0, fy = yc - y0;
  const auto px = [&texture](int yy, int xx) {
    const cv::Vec3f& c = texture.at<cv::Vec3f>(yy, xx);
    return Eigen::Vector3d(c[0], c[1], c[2]);
  };
  const Eigen::Vector3d c00 = px(y0, x0), c01 = px(y0, x1), c10 = px(y1, x0), c11 = px(y1, x1);
  *color = (1 - fy) * ((1 - fx) * c00 + fx * c01) + fy * ((1 - fx) * c10 + fx * c11);
  if (d_du == nullptr) return;  // the colour alone
  // Clamped coordinates have no derivative.
  const double dx_du = (x == xc) ? w : 0.0, dy_dv = (y == yc) ? -h : 0.0;
  const Eigen::Vector3d d_dx = (1 - fy) * (c01 - c00) + fy * (c11 - c10);
  const Eigen::Vector3d d_dy = (1 - fx) * (c10 - c00) + fx * (c11 - c01);
  *d_du = d_dx * dx_du;
  *d_dv = d_dy * dy_dv;
}

inline double Cross2(double ax, double ay, double bx, double by) { return ax * by - ay * bx; }

// Squared distance from p to segment (a, b) and the segment parameter.
inline double SegmentDistance2(double px, double py, double ax, double ay, double bx, double by, double* t) {
  const double ex = bx - ax, ey = by - ay;
  const double len2 = ex * ex + ey * ey;
  double s = len2 > 0.0 ? ((px - ax) * ex + (py - ay) * ey) / len2 : 0.0;
  s = std::clamp(s, 0.0, 1.0);
  *t = s;
  const double dx = px - (ax + s * ex), dy = py - (ay + s * ey);
  return dx * dx + dy * dy;
}

struct TriangleTerm {
  J9 coverage;  // D_j
  J9 depth;     // z_j, normalised inverse depth
  J9 color[3];  // C_j
  int vertices[3];
};

// Triangles binned into kTile-square tiles by their bounding boxes, grown
// by the reach of a soft edge where they have one (without edge flags,
// every edge is soft), within roi. Triangles with a corner behind the
// camera or not finite are left out.
void BinTrianglesIntoTiles(const ScreenMesh& mesh, const cv::Rect& roi, double soft_reach, int tiles_x, int tiles_y,
                           std::vector<std::vector<int>>* tiles_out) {
  std::vector<std::vector<int>>& tiles = *tiles_out;
  tiles.resize(static_cast<size_t>(tiles_x) * tiles_y);
  for (std::vector<int>& tile : tiles) tile.clear();
  const bool has_flags = static_cast<Eigen::Index>(mesh.boundary_edges.size()) == mesh.faces.cols();
  for (int f = 0; f < mesh.faces.cols(); ++f) {
    const double reach = !has_flags || mesh.boundary_edges[f] != 0 ? soft_reach : 0.0;
    double min_x = 1e300, max_x = -1e300, min_y = 1e300, max_y = -1e300;
    bool visible = true;
    for (int c = 0; c < 3; ++c) {
      const int v = mesh.faces(c, f);
      if (!(mesh.depths[v] > 0.0) || !mesh.pixels.col(v).allFinite()) visible = false;
      min_x = std::min(min_x, mesh.pixels(0, v));
      max_x = std::max(max_x, mesh.pixels(0, v));
      min_y = std::min(min_y, mesh.pixels(1, v));
      max_y = std::max(max_y, mesh.pixels(1, v));
    }
    if (!visible) continue;
    const int x0 = std::max(roi.x, static_cast<int>(std::floor(min_x - reach)));
    const int x1 = std::min(roi.x + roi.width - 1, static_cast<int>(std::ceil(max_x + reach)));
    const int y0 = std::max(roi.y, static_cast<int>(std::floor(min_y - reach)));
    const int y1 = std::min(roi.y + roi.height - 1, static_cast<int>(std::ceil(max_y + reach)));
    if (x0 > x1 || y0 > y1) continue;
    for (int ty = y0 / kTile; ty <= y1 / kTile; ++ty) {
      for (int tx = x0 / kTile; tx <= x1 / kTile; ++tx) tiles[ty * tiles_x + tx].push_back(f);
    }
  }
}

// What every pixel's triangle terms read.
struct TermContext {
  const ScreenMesh& mesh;
  const cv::Mat& texture;
  // The texture's mip levels (level 0 the texture) and each face's level,
  // or empty and null: no mip-mapping.
  const std::vector<cv::Mat>& mips;
  const float* face_levels = nullptr;
  double sigma = 1.0;
  double max_distance2 = 0.0;  // cutoff sigma: beyond, a soft edge is 0 or 1
  double reach = 0.0;          // a little more than its square root
  double inv_far = 0.0, depth_scale = 1.0;
  bool has_uv = false, has_flags = false;
};

// Variable i of a triangle's 9 as a jet, or its value alone.
template <typename T>
T Variable(double value, int i);
template <>
inline J9 Variable<J9>(double value, int i) {
  return J9(value, i);
}
template <>
inline double Variable<double>(double value, int) {
  return value;
}
inline void Store(const J9& x, J9* out) { *out = x; }
inline void Store(double x, J9* out) { out->a = x; }  // its derivatives are not read

// Where pixel p lies against triangle f, in doubles: its corners, the
// closest point on each edge (parameter t, squared distance d2), the
// nearest edge, whether p is inside, and the edge whose distance softens
// the coverage (-1: none, D = 1). False when the triangle does not reach
// the pixel.
struct TriangleAtPixel {
  int vertices[3];
  double x[3], y[3];
  double t[3], d2[3];
  // w_k: the signed area p spans with the edge opposite corner k.
  double w[3];
  int nearest = 0, edge = -1;
  bool inside = false;
};

// The texture's colour at (u, v) for face f (and its derivatives, unless
// null): trilinear between the two mip levels around the face's
// (fractional) level, which is a constant here.
void SampleFaceTexture(const TermContext& c, int f, double u, double v, Eigen::Vector3d* color, Eigen::Vector3d* d_du,
                       Eigen::Vector3d* d_dv) {
  const int levels = static_cast<int>(c.mips.size());
  if (levels <= 1 || c.face_levels == nullptr) {
    SampleTexture(c.texture, u, v, color, d_du, d_dv);
    return;
  }
  const double given = c.face_levels[f];  // a caller's level may be NaN: the coarsest then
  const double level = std::isfinite(given) ? std::clamp(given, 0.0, levels - 1.0) : levels - 1.0;
  const int k = std::min(static_cast<int>(level), levels - 2);
  const double a = level - k;
  SampleTexture(c.mips[k], u, v, color, d_du, d_dv);
  if (a > 0.0) {
    Eigen::Vector3d color1, d_du1, d_dv1;
    const bool derivatives = d_du != nullptr;
    SampleTexture(c.mips[k + 1], u, v, &color1, derivatives ? &d_du1 : nullptr, derivatives ? &d_dv1 : nullptr);
    *color = (1.0 - a) * *color + a * color1;
    if (derivatives) {
      *d_du = (1.0 - a) * *d_du + a * d_du1;
      *d_dv = (1.0 - a) * *d_dv + a * d_dv1;
    }
  }
}

bool LocateTriangle(const TermContext& c, int f, int px, int py, TriangleAtPixel* g) {
  const ScreenMesh& mesh = c.mesh;
  for (int k = 0; k < 3; ++k) {
    g->vertices[k] = mesh.faces(k, f);
    g->x[k] = mesh.pixels(0, g->vertices[k]);
    g->y[k] = mesh.pixels(1, g->vertices[k]);
  }
  const double *x = g->x, *y = g->y;
  // Soft edges: the mesh's boundary (all, without flags). A triangle
  // without any reaches only the pixels inside it: the sign tests below
  // settle it without a distance. Pixels outside the triangle's box grown
  // by its reach never get here (TriangleBox, tested by Render first).
  const std::uint8_t soft = c.has_flags ? mesh.boundary_edges[f] : 7;
  const double area = Cross2(x[1] - x[0], y[1] - y[0], x[2] - x[0], y[2] - y[0]);
  for (int k = 0; k < 3; ++k) {
    const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    g->w[k] = Cross2(x[k1] - px, y[k1] - py, x[k2] - px, y[k2] - py);
  }
  const double w0 = g->w[0], w1 = g->w[1], w2 = g->w[2];
  g->inside =
      area != 0.0 && ((area > 0 && w0 >= 0 && w1 >= 0 && w2 >= 0) || (area < 0 && w0 <= 0 && w1 <= 0 && w2 <= 0));
  g->edge = -1;
  if (soft == 0) {
    g->nearest = 0;
    g->t[0] = g->t[1] = g->t[2] = 0.0;
    return g->inside;
  }
  for (int k = 0; k < 3; ++k) {
    const int k1 = (k + 1) % 3;
    g->d2[k] = SegmentDistance2(px, py, x[k], y[k], x[k1], y[k1], &g->t[k]);
  }
  g->nearest = static_cast<int>(std::min_element(g->d2, g->d2 + 3) - g->d2);
  if (g->inside) {
    for (int k = 0; k < 3; ++k) {
      if ((soft >> k & 1) && (g->edge < 0 || g->d2[k] < g->d2[g->edge])) g->edge = k;
    }
    if (g->edge >= 0 && g->d2[g->edge] > c.max_distance2) g->edge = -1;  // saturated: D = 1
    return true;
  }
  g->edge = g->nearest;
  return (soft >> g->nearest & 1) && g->d2[g->nearest] <= c.max_distance2;
}

// Triangle f's term at pixel (px, py), as jets of its 9 screen variables
// (T = J9: the reference the hand-derived TriangleTermWithDerivatives is
// tested against, SoftRasterizerOptions::analytic_derivatives), or as
// values alone (T = double, for a render without gradients, several times
// cheaper): coverage D (a sigmoid of the squared distance to its nearest
// soft edge, 1 deep inside), normalised inverse depth and colour,
// interpolated at p inside or at the closest boundary point outside.
// False when the triangle does not reach the pixel.
template <typename T>
bool TriangleTermAt(const TermContext& c, int f, int px, int py, TriangleTerm* term) {
  TriangleAtPixel g;
  if (!LocateTriangle(c, f, px, py, &g)) return false;
  const ScreenMesh& mesh = c.mesh;
  const double pxd = px, pyd = py;
  const T Ax = Variable<T>(g.x[0], 0), Ay = Variable<T>(g.y[0], 1), Bx = Variable<T>(g.x[1], 2);
  const T By = Variable<T>(g.y[1], 3), Cx = Variable<T>(g.x[2], 4), Cy = Variable<T>(g.y[2], 5);
  const T Za = Variable<T>(mesh.depths[g.vertices[0]], 6), Zb = Variable<T>(mesh.depths[g.vertices[1]], 7);
  const T Zc = Variable<T>(mesh.depths[g.vertices[2]], 8);
  const T* X[3] = {&Ax, &Bx, &Cx};
  const T* Y[3] = {&Ay, &By, &Cy};
  const int e0 = g.nearest, e1 = (g.nearest + 1) % 3;
  const T ex = *X[e1] - *X[e0], ey = *Y[e1] - *Y[e0];
  T s(g.t[g.nearest]);
  if (!g.inside && g.t[g.nearest] > 0.0 && g.t[g.nearest] < 1.0) {
    s = ((T(pxd) - *X[e0]) * ex + (T(pyd) - *Y[e0]) * ey) / (ex * ex + ey * ey);
  }
  if (g.edge < 0) {
    term->coverage = J9(1.0);
  } else {
    const int f0 = g.edge, f1 = (g.edge + 1) % 3;
    const T fx = *X[f1] - *X[f0], fy = *Y[f1] - *Y[f0];
    T r(g.t[g.edge]);
    if (g.t[g.edge] > 0.0 && g.t[g.edge] < 1.0) {
      r = ((T(pxd) - *X[f0]) * fx + (T(pyd) - *Y[f0]) * fy) / (fx * fx + fy * fy);
    }
    const T qx = T(pxd) - (*X[f0] + r * fx), qy = T(pyd) - (*Y[f0] + r * fy);
    const T dist2 = qx * qx + qy * qy;
    const T q = (g.inside ? dist2 : -dist2) / c.sigma;
    using std::exp;
    Store(T(1.0) / (1.0 + exp(-q)), &term->coverage);
  }
  // Barycentrics: of p inside, of the closest boundary point outside.
  T b[3];
  if (g.inside) {
    const T A = (Bx - Ax) * (Cy - Ay) - (By - Ay) * (Cx - Ax);
    b[0] = ((Bx - pxd) * (Cy - pyd) - (By - pyd) * (Cx - pxd)) / A;
    b[1] = ((Cx - pxd) * (Ay - pyd) - (Cy - pyd) * (Ax - pxd)) / A;
    b[2] = 1.0 - b[0] - b[1];
  } else {
    b[e0] = 1.0 - s;
    b[e1] = s;
    b[(g.nearest + 2) % 3] = T(0.0);
  }
  const T inv_depth = b[0] / Za + b[1] / Zb + b[2] / Zc;
  Store((inv_depth - c.inv_far) * c.depth_scale, &term->depth);
  if (c.has_uv) {
    T u(0.0), v(0.0);
    for (int k = 0; k < 3; ++k) {
      u += b[k] * mesh.corner_texcoords(0, 3 * f + k);
      v += b[k] * mesh.corner_texcoords(1, 3 * f + k);
    }
    Eigen::Vector3d color, d_du, d_dv;
    if constexpr (std::is_same_v<T, J9>) {
      SampleFaceTexture(c, f, u.a, v.a, &color, &d_du, &d_dv);
      for (int ch = 0; ch < 3; ++ch) {
        term->color[ch].a = color[ch];
        term->color[ch].v = d_du[ch] * u.v + d_dv[ch] * v.v;
      }
    } else {
      SampleFaceTexture(c, f, u, v, &color, nullptr, nullptr);
      for (int ch = 0; ch < 3; ++ch) term->color[ch].a = color[ch];
    }
  } else {
    for (int ch = 0; ch < 3; ++ch) term->color[ch] = J9(1.0);
  }
  for (int k = 0; k < 3; ++k) term->vertices[k] = g.vertices[k];
  return true;
}

// Derivatives in a triangle's corner pixels (x0, y0, x1, y1, x2, y2).
using Vec6 = Eigen::Matrix<double, 6, 1>;

// The barycentrics of p inside triangle g (b_k = w_k / A, A = w_0 + w_1 +
// w_2) and their derivatives: dw_k / dP_{k+1} = (y_{k+2} - p_y, p_x -
// x_{k+2}), dw_k / dP_{k+2} = (p_y - y_{k+1}, x_{k+1} - p_x).
void InsideBarycentrics(const TriangleAtPixel& g, double px, double py, double b[3], Vec6 db[3]) {
  const double* w = g.w;
  Vec6 dw[3], d_area = Vec6::Zero();
  for (int k = 0; k < 3; ++k) {
    const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    dw[k].setZero();
    dw[k][2 * k1] = g.y[k2] - py;
    dw[k][2 * k1 + 1] = px - g.x[k2];
    dw[k][2 * k2] = py - g.y[k1];
    dw[k][2 * k2 + 1] = g.x[k1] - px;
    d_area += dw[k];
  }
  const double inv_area = 1.0 / (w[0] + w[1] + w[2]);
  for (int k = 0; k < 3; ++k) {
    b[k] = w[k] * inv_area;
    db[k] = (dw[k] - b[k] * d_area) * inv_area;
  }
}

// Outside: the closest point on the nearest edge (P_e0, P_e1), at
// s = (p - P_e0).e / e.e with e = P_e1 - P_e0 where not clamped:
// ds/dP_e1 = (p - P_e0 - 2 s e) / e.e, ds/dP_e0 = (2 s e - e - (p - P_e0)) / e.e.
void OutsideBarycentrics(const TriangleAtPixel& g, double px, double py, double b[3], Vec6 db[3]) {
  const int e0 = g.nearest, e1 = (g.nearest + 1) % 3;
  const double s = g.t[g.nearest];
  for (int k = 0; k < 3; ++k) db[k].setZero();
  b[e0] = 1.0 - s;
  b[e1] = s;
  b[(g.nearest + 2) % 3] = 0.0;
  if (!(s > 0.0 && s < 1.0)) return;
  const double ex = g.x[e1] - g.x[e0], ey = g.y[e1] - g.y[e0];
  const double gx = px - g.x[e0], gy = py - g.y[e0];
  const double inv_len2 = 1.0 / (ex * ex + ey * ey);
  db[e1][2 * e1] = (gx - 2.0 * s * ex) * inv_len2;
  db[e1][2 * e1 + 1] = (gy - 2.0 * s * ey) * inv_len2;
  db[e1][2 * e0] = (2.0 * s * ex - ex - gx) * inv_len2;
  db[e1][2 * e0 + 1] = (2.0 * s * ey - ey - gy) * inv_len2;
  db[e0] = -db[e1];
}

// TriangleTermAt<J9>'s values and derivatives, derived by hand (about
// three times fewer operations than the jets). The coverage's distance
// is to the closest point on its edge, at which d(dist2)/ds = 0, so
// d(dist2)/dP_f0 = -2 (1 - r) q and d(dist2)/dP_f1 = -2 r q, q = p - closest.
bool TriangleTermWithDerivatives(const TermContext& c, int f, int px, int py, TriangleTerm* term) {
  TriangleAtPixel g;
  if (!LocateTriangle(c, f, px, py, &g)) return false;
  const ScreenMesh& mesh = c.mesh;
  const double pxd = px, pyd = py;
  term->coverage = J9(1.0);
  if (g.edge >= 0) {
    const int f0 = g.edge, f1 = (g.edge + 1) % 3;
    const double r = g.t[g.edge];
    const double qx = pxd - (g.x[f0] + r * (g.x[f1] - g.x[f0])), qy = pyd - (g.y[f0] + r * (g.y[f1] - g.y[f0]));
    const double sign = g.inside ? 1.0 : -1.0;
    const double coverage = 1.0 / (1.0 + std::exp(-sign * (qx * qx + qy * qy) / c.sigma));
    const double d_dist2 = coverage * (1.0 - coverage) * sign / c.sigma;
    term->coverage.a = coverage;
    term->coverage.v[2 * f0] = -2.0 * (1.0 - r) * qx * d_dist2;
    term->coverage.v[2 * f0 + 1] = -2.0 * (1.0 - r) * qy * d_dist2;
    term->coverage.v[2 * f1] = -2.0 * r * qx * d_dist2;
    term->coverage.v[2 * f1 + 1] = -2.0 * r * qy * d_dist2;
  }
  double b[3];
  Vec6 db[3];
  if (g.inside) {
    InsideBarycentrics(g, pxd, pyd, b, db);
  } else {
    OutsideBarycentrics(g, pxd, pyd, b, db);
  }
  double inv_depth = 0.0;
  Vec6 d_inv_depth = Vec6::Zero();
  term->depth.v.setZero();
  for (int k = 0; k < 3; ++k) {
    const double inv_z = 1.0 / mesh.depths[g.vertices[k]];
    inv_depth += b[k] * inv_z;
    d_inv_depth += db[k] * inv_z;
    term->depth.v[6 + k] = -b[k] * inv_z * inv_z * c.depth_scale;
  }
  term->depth.a = (inv_depth - c.inv_far) * c.depth_scale;
  term->depth.v.head<6>() = d_inv_depth * c.depth_scale;
  if (c.has_uv) {
    double u = 0.0, v = 0.0;
    Vec6 du = Vec6::Zero(), dv = Vec6::Zero();
    for (int k = 0; k < 3; ++k) {
      u += b[k] * mesh.corner_texcoords(0, 3 * f + k);
      v += b[k] * mesh.corner_texcoords(1, 3 * f + k);
      du += db[k] * mesh.corner_texcoords(0, 3 * f + k);
      dv += db[k] * mesh.corner_texcoords(1, 3 * f + k);
    }
    Eigen::Vector3d color, d_du, d_dv;
    SampleFaceTexture(c, f, u, v, &color, &d_du, &d_dv);
    for (int ch = 0; ch < 3; ++ch) {
      term->color[ch].a = color[ch];
      term->color[ch].v.head<6>() = d_du[ch] * du + d_dv[ch] * dv;
      term->color[ch].v.tail<3>().setZero();
    }
  } else {
    for (int ch = 0; ch < 3; ++ch) term->color[ch] = J9(1.0);
  }
  for (int k = 0; k < 3; ++k) term->vertices[k] = g.vertices[k];
  return true;
}

// A tile's triangle with its box grown by the reach of its soft edges:
// beyond it the triangle cannot reach a pixel (LocateTriangle would find it
// outside and further than the cutoff). Kept contiguous, so that the many
// triangle-pixel pairs of a tile that fail it are settled without reading
// the mesh.
struct TriangleBox {
  int face;
  double x0, x1, y0, y1;
};

// A pixel's aggregate of its triangle terms. The silhouette is SoftRas':
//   S = 1 - prod_j (1 - D_j).
// The colour, by options.compositing:
//   kSoftZ (SoftRas)  I = (e_b C_b + sum_j e_j C_j) / (e_b + sum_j e_j),
//                     e_j = D_j exp((z_j - z_max) / gamma),
//                     e_b = exp((z_b - z_max) / gamma);
//   kOver             the terms sorted nearest first, each laid over those
//                     behind it by its coverage, the surface's own colour:
//                     I = sum_j T_j D_j C_j / A, T_j = prod_{k<j} (1 - D_k),
//                     A = 1 - T_n = sum_j T_j D_j (the background shows
//                     only where no triangle reaches, as with kSoftZ);
//   kOverBackground   the same with the background an opaque last layer:
//                     I = sum_j T_j D_j C_j + T_n C_b (A = 1).
constexpr int kOverSlots = 5;

struct PixelBlend {
  double color[3];
  double silhouette = 0.0;
  double e_sum = 0.0;
  double z_max = 0.0;
  // kSoftZ: e_j per term, e_sum their sum with e_b. kOver: per term (in
  // the terms' order) kOverSlots values: T_j, then the colour N_j and the
  // coverage A_j of what lies behind it; e_sum is A.
  const double* e = nullptr;
};

// Per thread, reused across tiles and pixels.
struct RenderScratch {
  std::vector<TriangleTerm> terms;
  std::vector<double> e;
  std::vector<int> order;
  std::vector<TriangleBox> boxes;
};

PixelBlend BlendPixel(const std::vector<TriangleTerm>& terms, const cv::Vec3f& background,
                      const SoftRasterizerOptions& o, RenderScratch* scratch) {
  PixelBlend blend;
  double keep = 1.0;  // prod (1 - D_j)
  blend.z_max = o.background_depth;
  for (const TriangleTerm& term : terms) {
    keep *= 1.0 - term.coverage.a;
    blend.z_max = std::max(blend.z_max, term.depth.a);
  }
  blend.silhouette = 1.0 - keep;
  std::vector<double>& e = scratch->e;
  if (o.compositing == Compositing::kOver || o.compositing == Compositing::kOverBackground) {
    const int n = static_cast<int>(terms.size());
    std::vector<int>& order = scratch->order;
    order.resize(n);
    for (int j = 0; j < n; ++j) order[j] = j;
    // Nearest first (z is the normalised inverse depth); ties keep the
    // triangles' order, so that a render does not depend on the threads.
    // An insertion sort: a pixel has a few terms, and std::stable_sort
    // would take a buffer from the heap for every pixel.
    for (int i = 1; i < n; ++i) {
      const int j = order[i];
      int k = i;
      for (; k > 0 && terms[order[k - 1]].depth.a < terms[j].depth.a; --k) order[k] = order[k - 1];
      order[k] = j;
    }
    e.resize(kOverSlots * n);
    // Back to front: what lies behind each triangle, its colour (with the
    // background only for kOverBackground) and its coverage.
    double behind[3] = {0.0, 0.0, 0.0}, behind_alpha = 0.0;
    if (o.compositing == Compositing::kOverBackground) {
      for (int ch = 0; ch < 3; ++ch) behind[ch] = background[ch];
      behind_alpha = 1.0;
    }
    for (int i = n - 1; i >= 0; --i) {
      const TriangleTerm& term = terms[order[i]];
      double* slot = &e[kOverSlots * order[i]];
      const double d = term.coverage.a;
      for (int ch = 0; ch < 3; ++ch) {
        slot[1 + ch] = behind[ch];
        behind[ch] = d * term.color[ch].a + (1.0 - d) * behind[ch];
      }
      slot[4] = behind_alpha;
      behind_alpha = d + (1.0 - d) * behind_alpha;
    }
    double transmitted = 1.0;
    for (int i = 0; i < n; ++i) {
      e[kOverSlots * order[i]] = transmitted;
      transmitted *= 1.0 - terms[order[i]].coverage.a;
    }
    blend.e_sum = behind_alpha;  // A > 0: 1, or 1 - prod (1 - D_j) where each term has D_j > 0
    for (int ch = 0; ch < 3; ++ch) blend.color[ch] = behind[ch] / behind_alpha;
    blend.e = e.data();
    return blend;
  }
  const double e_background = std::exp((o.background_depth - blend.z_max) / o.gamma);
  blend.e_sum = e_background;
  double numerator[3] = {e_background * background[0], e_background * background[1], e_background * background[2]};
  e.resize(terms.size());
  for (size_t j = 0; j < terms.size(); ++j) {
    e[j] = terms[j].coverage.a * std::exp((terms[j].depth.a - blend.z_max) / o.gamma);
    blend.e_sum += e[j];
    for (int ch = 0; ch < 3; ++ch) numerator[ch] += e[j] * terms[j].color[ch].a;
  }
  for (int ch = 0; ch < 3; ++ch) blend.color[ch] = numerator[ch] / blend.e_sum;
  blend.e = e.data();
  return blend;
}

// d(I, S)/d(screen variables) of a pixel, per vertex, appended to `grads`
// (a vertex's entries summed over its triangles). kOver holds the depth
// order fixed: dI/dD_j = T_j (C_j - R_j), dI/dC_j = T_j D_j, no depth
// derivative (the order is piecewise constant).
void AppendPixelGradients(const std::vector<TriangleTerm>& terms, const PixelBlend& blend,
                          const SoftRasterizerOptions& o, std::vector<VertexGradient>* grads) {
  // Without the depth gradient the blend's weights move with coverage only.
  const double depth_scale = o.depth_gradient ? 1.0 / o.gamma : 0.0;
  const bool over = o.compositing == Compositing::kOver || o.compositing == Compositing::kOverBackground;
  const int first = static_cast<int>(grads->size());
  const int n = static_cast<int>(terms.size());
  for (int j = 0; j < n; ++j) {
    const TriangleTerm& term = terms[j];
    // dS/dD_j = prod_{k != j} (1 - D_k), computed directly (D_j may be 1).
    double others = 1.0;
    for (int k = 0; k < n; ++k) {
      if (k != j) others *= 1.0 - terms[k].coverage.a;
    }
    // d colour / d local variables of triangle j.
    Eigen::Matrix<double, 4, 9> local;
    if (over) {
      // I = N / A: dI/dD_j = T_j ((C_j - N_j) - I (1 - A_j)) / A,
      // dI/dC_j = T_j D_j / A, with N_j, A_j the colour and coverage
      // behind triangle j.
      const double* slot = blend.e + kOverSlots * j;
      const double scale = slot[0] / blend.e_sum;
      for (int ch = 0; ch < 3; ++ch) {
        const double to_coverage = (term.color[ch].a - slot[1 + ch]) - blend.color[ch] * (1.0 - slot[4]);
        local.row(ch) = (scale * (to_coverage * term.coverage.v + term.coverage.a * term.color[ch].v)).transpose();
      }
    } else {
      const double exp_j = std::exp((term.depth.a - blend.z_max) / o.gamma);
      for (int ch = 0; ch < 3; ++ch) {
        const double to_e = (term.color[ch].a - blend.color[ch]) / blend.e_sum;
        local.row(ch) = (to_e * (exp_j * term.coverage.v + blend.e[j] * depth_scale * term.depth.v) +
                         blend.e[j] / blend.e_sum * term.color[ch].v)
                            .transpose();
      }
    }
    local.row(3) = (others * term.coverage.v).transpose();
    for (int c = 0; c < 3; ++c) {
      const int vertex = term.vertices[c];
      VertexGradient* g = nullptr;
      for (int k = first; k < static_cast<int>(grads->size()); ++k) {
        if ((*grads)[k].vertex == vertex) {
          g = &(*grads)[k];
          break;
        }
      }
      if (g == nullptr) {
        grads->emplace_back();
        g = &grads->back();
        g->vertex = vertex;
      }
      for (int r = 0; r < 4; ++r) {
        g->d[r][0] += static_cast<float>(local(r, 2 * c));
        g->d[r][1] += static_cast<float>(local(r, 2 * c + 1));
        g->d[r][2] += static_cast<float>(local(r, 6 + c));
      }
    }
  }
}

// The tiles' gradients concatenated into out->gradients, their pixels'
// tile-local ranges made global.
void ConcatenateTileGradients(const std::vector<std::vector<VertexGradient>>& tile_gradients, int tiles_x, int width,
                              int height, SoftRenderOutput* out) {
  std::vector<int> base(tile_gradients.size() + 1, 0);
  for (size_t t = 0; t < tile_gradients.size(); ++t) {
    base[t + 1] = base[t] + static_cast<int>(tile_gradients[t].size());
  }
  // With slack: a count that creeps up between renders would otherwise
  // reallocate (and fault in) megabytes every time.
  if (out->gradients.capacity() < static_cast<size_t>(base.back())) out->gradients.reserve(base.back() * 5 / 4);
  out->gradients.resize(base.back());
  for (size_t t = 0; t < tile_gradients.size(); ++t) {
    std::copy(tile_gradients[t].begin(), tile_gradients[t].end(), out->gradients.begin() + base[t]);
    if (tile_gradients[t].empty()) continue;
    const int tx = static_cast<int>(t) % tiles_x, ty = static_cast<int>(t) / tiles_x;
    for (int py = ty * kTile; py < std::min((ty + 1) * kTile, height); ++py) {
      for (int px = tx * kTile; px < std::min((tx + 1) * kTile, width); ++px) {
        const int pixel = py * width + px;
        if (out->end[pixel] > out->begin[pixel]) {
          out->begin[pixel] += base[t];
          out->end[pixel] += base[t];
        }
      }
    }
  }
}

// What a render's triangle terms read: the options' softness and the
// mesh's depth range, texture coordinates, edge flags and, with mip levels,
// each face's level (the mesh's own, or FaceMipLevels into *level_scratch).
TermContext MakeTermContext(const ScreenMesh& mesh, const cv::Mat& texture, const std::vector<cv::Mat>& mips,
                            const SoftRasterizerOptions& o, std::vector<float>* level_scratch) {
  const int num_faces = static_cast<int>(mesh.faces.cols());
  TermContext context{mesh, texture, mips};
  context.sigma = o.sigma;
  context.max_distance2 = o.cutoff * o.sigma;
  context.reach = std::sqrt(context.max_distance2) * (1.0 + 1e-9) + 1e-9;
  context.inv_far = 1.0 / mesh.depth_far;
  context.depth_scale = 1.0 / (1.0 / mesh.depth_near - context.inv_far);
  context.has_uv = mesh.corner_texcoords.cols() == 3 * num_faces;
  context.has_flags = static_cast<int>(mesh.boundary_edges.size()) == num_faces;
  if (!mips.empty()) {
    if (static_cast<int>(mesh.face_mip_levels.size()) == num_faces) {
      context.face_levels = mesh.face_mip_levels.data();
    } else {
      FaceMipLevels(mesh, texture.cols, texture.rows, static_cast<int>(mips.size()), o.mip_level_bias, level_scratch);
      context.face_levels = level_scratch->data();
    }
  }
  return context;
}

TriangleBox MakeTriangleBox(const TermContext& c, int f) {
  const ScreenMesh& mesh = c.mesh;
  double x[3], y[3];
  for (int k = 0; k < 3; ++k) {
    x[k] = mesh.pixels(0, mesh.faces(k, f));
    y[k] = mesh.pixels(1, mesh.faces(k, f));
  }
  const double reach = (c.has_flags ? mesh.boundary_edges[f] : 7) != 0 ? c.reach : 0.0;
  return {f, std::min({x[0], x[1], x[2]}) - reach, std::max({x[0], x[1], x[2]}) + reach,
          std::min({y[0], y[1], y[2]}) - reach, std::max({y[0], y[1], y[2]}) + reach};
}

}  // namespace

void FaceMipLevels(const ScreenMesh& mesh, int texture_width, int texture_height, int num_levels, double bias,
                   std::vector<float>* levels) {
  const int num_faces = static_cast<int>(mesh.faces.cols());
  levels->resize(num_faces);
  const bool has_uv = mesh.corner_texcoords.cols() == 3 * num_faces;
  const double top = std::max(num_levels - 1, 0);
  for (int f = 0; f < num_faces; ++f) {
    if (!has_uv) {
      (*levels)[f] = 0.0f;
      continue;
    }
    const Eigen::Vector2d p0 = mesh.pixels.col(mesh.faces(0, f)), p1 = mesh.pixels.col(mesh.faces(1, f)),
                          p2 = mesh.pixels.col(mesh.faces(2, f));
    const Eigen::Vector2d e1 = p1 - p0, e2 = p2 - p0;
    const auto texel = [&](int k) {
      return Eigen::Vector2d(mesh.corner_texcoords(0, 3 * f + k) * texture_width,
                             mesh.corner_texcoords(1, 3 * f + k) * texture_height);
    };
    const Eigen::Vector2d t1 = texel(1) - texel(0), t2 = texel(2) - texel(0);
    const double det = e1.x() * e2.y() - e2.x() * e1.y();
    double level = top;  // no area on screen: the coarsest
    if (std::abs(det) > 1e-12 && std::isfinite(det)) {
      // d(texel)/d(pixel x) and d(texel)/d(pixel y): the texel edges times
      // the inverse of the pixel edges; the footprint is the longer.
      const Eigen::Vector2d along_x = (t1 * e2.y() - t2 * e1.y()) / det;
      const Eigen::Vector2d along_y = (t2 * e1.x() - t1 * e2.x()) / det;
      const double footprint2 = std::max(along_x.squaredNorm(), along_y.squaredNorm());
      if (std::isfinite(footprint2)) level = 0.5 * std::log2(std::max(footprint2, 1e-300)) + bias;
    }
    (*levels)[f] = static_cast<float>(std::clamp(level, 0.0, top));
  }
}

double SoftnessToGamma(double softness, double depth, double depth_near, double depth_far) {
  return softness / (depth * depth * (1.0 / depth_near - 1.0 / depth_far));
}

std::vector<std::uint8_t> MeshBoundaryEdgeFlags(const Eigen::Matrix3Xi& faces) {
  TriangleMesh mesh;
  mesh.faces = faces;
  const std::vector<std::pair<std::uint64_t, int>> edges = SortedEdgeCorners(mesh);
  std::vector<std::uint8_t> flags(faces.cols(), 0);
  for (size_t i = 0; i < edges.size(); ++i) {
    const bool shared = (i > 0 && edges[i - 1].first == edges[i].first) ||
                        (i + 1 < edges.size() && edges[i + 1].first == edges[i].first);
    if (!shared) flags[edges[i].second / 3] |= static_cast<std::uint8_t>(1u << (edges[i].second % 3));
  }
  return flags;
}

std::string SoftRasterizerOptions::Validate() const {
  if (!(sigma > 0.0)) return "sigma must be > 0";
  if (!(gamma > 0.0)) return "gamma must be > 0";
  if (!(cutoff > 0.0)) return "cutoff must be > 0";
  if (!std::isfinite(mip_level_bias)) return "mip_level_bias must be finite";
  return {};
}

SoftRasterizer::SoftRasterizer(const SoftRasterizerOptions& options, const cv::Mat& texture)
    : options_(options), texture_(texture) {
  if (const std::string problem = options.Validate(); !problem.empty()) {
    throw std::invalid_argument("SoftRasterizerOptions: " + problem);
  }
  if (texture.empty() || texture.type() != CV_32FC3) {
    throw std::invalid_argument("SoftRasterizer: the texture must be a non-empty CV_32FC3 image");
  }
  if (options.mipmap) {
    mips_.push_back(texture);
    while (mips_.back().cols > 2 || mips_.back().rows > 2) {
      const cv::Mat& last = mips_.back();
      cv::Mat half;
      cv::resize(last, half, cv::Size(std::max(1, (last.cols + 1) / 2), std::max(1, (last.rows + 1) / 2)), 0, 0,
                 cv::INTER_AREA);
      mips_.push_back(half);
    }
  }
}

void SoftRasterizer::Render(const ScreenMesh& mesh, int width, int height, const cv::Mat& background,
                            bool with_gradients, SoftRenderOutput* out, const cv::Rect& roi_in) const {
  const SoftRasterizerOptions& o = options_;
  if (!background.empty() && (background.cols != width || background.rows != height || background.type() != CV_32FC3)) {
    throw std::invalid_argument("SoftRasterizer::Render: the background must be CV_32FC3 of the image's size");
  }
  const cv::Rect roi = roi_in.area() > 0 ? (roi_in & cv::Rect(0, 0, width, height)) : cv::Rect(0, 0, width, height);
  out->color.create(height, width, CV_32FC3);
  out->silhouette.create(height, width, CV_32F);
  out->silhouette.setTo(0.0f);
  const cv::Vec3f flat(o.background_color.x(), o.background_color.y(), o.background_color.z());
  if (background.empty()) {
    out->color.setTo(cv::Scalar(flat[0], flat[1], flat[2]));
  } else {
    background.copyTo(out->color);
  }
  if (with_gradients) {
    out->begin.assign(width * height, 0);
    out->end.assign(width * height, 0);
  }
  out->gradients.clear();
  out->num_covered_pixels = 0;

  const int tiles_x = (width + kTile - 1) / kTile, tiles_y = (height + kTile - 1) / kTile;
  std::vector<std::vector<int>>& tiles = out->tile_triangles;
  const TermContext context = MakeTermContext(mesh, texture_, mips_, o, &out->face_mip_levels);
  BinTrianglesIntoTiles(mesh, roi, context.reach, tiles_x, tiles_y, &tiles);

  // Per tile: its pixels' gradients, concatenated afterwards.
  std::vector<std::vector<VertexGradient>>& tile_gradients = out->tile_gradients;
  tile_gradients.resize(tiles.size());
  for (std::vector<VertexGradient>& g : tile_gradients) g.clear();
  std::vector<int> covered(tiles.size(), 0);
  std::vector<RenderScratch> scratch(ResolveNumThreads(o.num_threads));
  ParallelFor(
      static_cast<int>(tiles.size()), o.num_threads,
      [&](int thread, int tile) {
        const std::vector<int>& list = tiles[tile];
        if (list.empty()) return;
        std::vector<VertexGradient>& grads = tile_gradients[tile];
        if (with_gradients) grads.reserve(kTile * kTile * 12);
        RenderScratch& s = scratch[thread];
        s.boxes.clear();
        for (const int f : list) s.boxes.push_back(MakeTriangleBox(context, f));
        const int tx = tile % tiles_x, ty = tile / tiles_x;
        for (int py = std::max(ty * kTile, roi.y); py < std::min((ty + 1) * kTile, roi.y + roi.height); ++py) {
          for (int px = std::max(tx * kTile, roi.x); px < std::min((tx + 1) * kTile, roi.x + roi.width); ++px) {
            s.terms.clear();
            TriangleTerm term;
            for (const TriangleBox& box : s.boxes) {
              if (px < box.x0 || px > box.x1 || py < box.y0 || py > box.y1) continue;
              const int f = box.face;
              const bool reaches = !with_gradients          ? TriangleTermAt<double>(context, f, px, py, &term)
                                   : o.analytic_derivatives ? TriangleTermWithDerivatives(context, f, px, py, &term)
                                                            : TriangleTermAt<J9>(context, f, px, py, &term);
              if (reaches) s.terms.push_back(term);
            }
            if (s.terms.empty()) continue;
            ++covered[tile];
            const PixelBlend blend =
                BlendPixel(s.terms, background.empty() ? flat : background.at<cv::Vec3f>(py, px), o, &s);
            out->color.at<cv::Vec3f>(py, px) = cv::Vec3f(blend.color[0], blend.color[1], blend.color[2]);
            out->silhouette.at<float>(py, px) = static_cast<float>(blend.silhouette);
            if (!with_gradients) continue;
            const int pixel = py * width + px;
            out->begin[pixel] = static_cast<int>(grads.size());  // tile-local; made global below
            AppendPixelGradients(s.terms, blend, o, &grads);
            out->end[pixel] = static_cast<int>(grads.size());
          }
        }
      },
      1);

  for (int c : covered) out->num_covered_pixels += c;
  if (with_gradients) ConcatenateTileGradients(tile_gradients, tiles_x, width, height, out);
}

bool ProjectVertices(const PinholeCamera& camera, const Eigen::Matrix3Xd& vertices, ScreenMesh* screen,
                     Eigen::MatrixXd* jacobian) {
  const Eigen::Index n = vertices.cols();
  screen->pixels.resize(2, n);
  screen->depths.resize(n);
  if (jacobian != nullptr) jacobian->resize(3 * n, 3);
  Eigen::Vector2d pixel;
  Eigen::Matrix3d j;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!camera.ProjectWithJacobian(vertices.col(i), &pixel, jacobian != nullptr ? &j : nullptr)) return false;
    screen->pixels.col(i) = pixel;
    screen->depths[i] = vertices(2, i);
    if (jacobian != nullptr) jacobian->middleRows(3 * i, 3) = j;
  }
  return true;
}

}  // namespace polyfit
