#include "drape/render/mesh_render.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <stdexcept>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>

#include "polyfit/mesh/per_face_normals.h"
#include "polyfit/util/atomic_file.h"

namespace polyfit {
namespace {

struct View {
  Eigen::Matrix3d rotation;  // world to view: x right, y up, z towards the viewer
};

void Rasterise(const TriangleMesh& mesh, const Eigen::Matrix3d& rotation, const Eigen::Vector2d& origin,
               double pixels_per_metre, const Eigen::Vector3d& colour, bool two_sided, cv::Mat* image,
               std::vector<float>* depth) {
  const int w = image->cols, h = image->rows;
  const Eigen::Vector3d light = Eigen::Vector3d(0.3, 0.5, 1.0).normalized();
  const Eigen::Matrix3Xd normals = PerFaceNormals(mesh);
  for (int f = 0; f < mesh.faces.cols(); ++f) {
    Eigen::Vector3d p[3];
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d q = rotation * mesh.vertices.col(mesh.faces(c, f));
      p[c] = Eigen::Vector3d((q.x() - origin.x()) * pixels_per_metre, h - 1 - (q.y() - origin.y()) * pixels_per_metre,
                             q.z());
    }
    const Eigen::Vector3d normal = rotation * normals.col(f);
    double shade = normal.dot(light);
    if (two_sided) shade = std::abs(shade);
    shade = 0.25 + 0.75 * std::max(shade, 0.0);
    if (!std::isfinite(shade)) continue;
    const cv::Vec3b bgr(static_cast<uchar>(std::min(255.0, colour[2] * shade)),
                        static_cast<uchar>(std::min(255.0, colour[1] * shade)),
                        static_cast<uchar>(std::min(255.0, colour[0] * shade)));
    const double area = (p[1].x() - p[0].x()) * (p[2].y() - p[0].y()) - (p[2].x() - p[0].x()) * (p[1].y() - p[0].y());
    if (std::abs(area) < 1e-12) continue;
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min({p[0].x(), p[1].x(), p[2].x()}))));
    const int x1 = std::min(w - 1, static_cast<int>(std::ceil(std::max({p[0].x(), p[1].x(), p[2].x()}))));
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min({p[0].y(), p[1].y(), p[2].y()}))));
    const int y1 = std::min(h - 1, static_cast<int>(std::ceil(std::max({p[0].y(), p[1].y(), p[2].y()}))));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const double px = x + 0.5, py = y + 0.5;
        const double b0 = ((p[1].x() - px) * (p[2].y() - py) - (p[2].x() - px) * (p[1].y() - py)) / area;
        const double b1 = ((p[2].x() - px) * (p[0].y() - py) - (p[0].x() - px) * (p[2].y() - py)) / area;
        const double b2 = 1.0 - b0 - b1;
        if (b0 < 0.0 || b1 < 0.0 || b2 < 0.0) continue;
        const float z = static_cast<float>(b0 * p[0].z() + b1 * p[1].z() + b2 * p[2].z());
        float& stored = (*depth)[static_cast<size_t>(y) * w + x];
        if (z <= stored) continue;
        stored = z;
        image->at<cv::Vec3b>(y, x) = bgr;
      }
    }
  }
}

}  // namespace

cv::Mat RenderBodyAndGarment(const TriangleMesh& body, const TriangleMesh& garment, const RenderOptions& options) {
  const Eigen::Matrix3d front = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d side = Eigen::AngleAxisd(-M_PI / 2.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  std::vector<cv::Mat> views;
  for (const Eigen::Matrix3d& rotation : {front, side}) {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d hi = -lo;
    for (const TriangleMesh* mesh : {&body, &garment}) {
      for (int v = 0; v < mesh->num_vertices(); ++v) {
        const Eigen::Vector3d q = rotation * mesh->vertices.col(v);
        if (!q.allFinite()) continue;
        lo = lo.cwiseMin(q);
        hi = hi.cwiseMax(q);
      }
    }
    if (!(hi.x() > lo.x()) || !(hi.y() > lo.y())) {
      views.emplace_back(options.view_height, options.view_height / 2, CV_8UC3, cv::Scalar(255, 255, 255));
      continue;
    }
    const double extent = (hi.y() - lo.y()) * (1.0 + 2.0 * options.margin);
    const double pixels_per_metre = options.view_height / extent;
    const double pad = options.margin * (hi.y() - lo.y());
    const int width = std::max(16, static_cast<int>(std::ceil((hi.x() - lo.x() + 2.0 * pad) * pixels_per_metre)));
    cv::Mat image(options.view_height, width, CV_8UC3, cv::Scalar(255, 255, 255));
    std::vector<float> depth(static_cast<size_t>(width) * options.view_height, -std::numeric_limits<float>::infinity());
    const Eigen::Vector2d origin(lo.x() - pad, lo.y() - pad);
    Rasterise(body, rotation, origin, pixels_per_metre, Eigen::Vector3d(200, 200, 200), false, &image, &depth);
    Rasterise(garment, rotation, origin, pixels_per_metre, Eigen::Vector3d(70, 130, 230), true, &image, &depth);
    views.push_back(image);
  }
  cv::Mat out;
  cv::hconcat(views, out);
  return out;
}

void WriteImage(const std::string& path, const cv::Mat& image) {
  std::vector<uchar> bytes;
  const std::string extension = std::filesystem::path(path).extension().string();
  if (!cv::imencode(extension.empty() ? ".png" : extension, image, bytes)) {
    throw std::runtime_error(path + ": cannot encode the image");
  }
  WriteFileAtomically(path,
                      [&](std::ostream& out) { out.write(reinterpret_cast<const char*>(bytes.data()), bytes.size()); });
}

}  // namespace polyfit
