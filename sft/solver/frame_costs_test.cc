#include "sft/solver/frame_costs.h"

#include <cmath>
#include <memory>

#include <gtest/gtest.h>

#include "polyfit/mesh/mesh_topology.h"
#include "polyfit/util/scoped_temp_dir.h"
#include "sft/scene/scene.h"
#include "sft/solver/silhouette_band.h"
#include "sft/synthetic/sheet_scene.h"

namespace polyfit {
namespace {

// Central differences of a one-block cost's residuals against its Jacobian;
// returns the largest difference relative to the Jacobian's largest entry.
double RelativeJacobianError(const ceres::CostFunction& cost, std::vector<double> theta, double h,
                             double* largest = nullptr) {
  const int m = cost.num_residuals(), P = static_cast<int>(theta.size());
  std::vector<double> r(m), rp(m), rm(m), jacobian(static_cast<size_t>(m) * P);
  const double* parameters[1] = {theta.data()};
  double* jacobians[1] = {jacobian.data()};
  EXPECT_TRUE(cost.Evaluate(parameters, r.data(), jacobians));
  double max_entry = 0.0, max_error = 0.0;
  for (double j : jacobian) max_entry = std::max(max_entry, std::abs(j));
  for (int c = 0; c < P; ++c) {
    std::vector<double> plus = theta, minus = theta;
    plus[c] += h;
    minus[c] -= h;
    const double* pp[1] = {plus.data()};
    const double* pm[1] = {minus.data()};
    cost.Evaluate(pp, rp.data(), nullptr);
    cost.Evaluate(pm, rm.data(), nullptr);
    for (int i = 0; i < m; ++i) {
      max_error = std::max(max_error, std::abs((rp[i] - rm[i]) / (2 * h) - jacobian[static_cast<size_t>(i) * P + c]));
    }
  }
  if (largest != nullptr) *largest = max_entry;
  return max_error / max_entry;
}

class FrameCostsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    GenerateSheetScene(SheetSceneOptions::Small(80, 8, 2), dir_.path().string());
    scene_ = LoadScene(dir_.path().string());
    model_ = std::make_unique<JetDeformationModel>(JetDeformationOptions(), scene_.template_mesh.vertices);
    theta_.assign(model_->num_parameters(), 0.0);
    // Away from zero so that every term is exercised.
    for (size_t k = 0; k < theta_.size(); ++k) theta_[k] = 0.01 * std::sin(1.0 + 3.0 * k);
  }
  // The render term of `frame` over the whole image.
  RenderCost::Data RenderData(const SoftRasterizer& rasterizer, const SftFrame& frame) const {
    RenderCost::Data d;
    d.model = model_.get();
    d.rasterizer = &rasterizer;
    d.mesh.faces = scene_.template_mesh.faces;
    d.mesh.corner_texcoords = scene_.template_mesh.corner_texcoords;
    d.mesh.boundary_edges = MeshBoundaryEdgeFlags(d.mesh.faces);
    d.mesh.depth_near = 0.2;
    d.mesh.depth_far = 0.8;
    d.camera = scene_.camera;
    d.image = frame.image;
    d.mask = frame.mask;
    d.roi = cv::Rect(0, 0, 80, 60);
    return d;
  }
  ScopedTempDir dir_{"polyfit_frame_costs"};
  SftScene scene_;
  std::unique_ptr<JetDeformationModel> model_;
  std::vector<double> theta_;
};

TEST_F(FrameCostsTest, ModelJacobianMatchesFiniteDifferences) {
  Eigen::Matrix3Xd v, vp, vm;
  Eigen::MatrixXd jacobian;
  model_->Evaluate(theta_.data(), &v, &jacobian);
  double max_error = 0.0;
  for (int c = 0; c < model_->num_parameters(); ++c) {
    std::vector<double> plus = theta_, minus = theta_;
    plus[c] += 1e-7;
    minus[c] -= 1e-7;
    model_->Evaluate(plus.data(), &vp);
    model_->Evaluate(minus.data(), &vm);
    const Eigen::Matrix3Xd numeric = (vp - vm) / 2e-7;
    for (int i = 0; i < model_->num_vertices(); ++i) {
      max_error = std::max(max_error, (numeric.col(i) - jacobian.block(3 * i, c, 3, 1)).cwiseAbs().maxCoeff());
    }
  }
  EXPECT_LT(max_error, 1e-6);
  EXPECT_LT(model_->template_rms_error(), 1e-9);  // the flat sheet is a jet exactly
}

TEST(JetDeformationModelTest, TexturedCylinderFallsBackToTheTextureSpaceField) {
  // Three quarters of a cylinder: no height field over any plane.
  const int na = 24, nh = 6;
  Eigen::Matrix3Xd vertices(3, (na + 1) * (nh + 1));
  Eigen::Matrix2Xd texcoords(2, vertices.cols());
  for (int j = 0; j <= nh; ++j) {
    for (int i = 0; i <= na; ++i) {
      const double a = 1.5 * M_PI * i / na;
      vertices.col(j * (na + 1) + i) << 0.05 * std::cos(a), 0.1 * j / nh - 0.05, 0.4 + 0.05 * std::sin(a);
      texcoords.col(j * (na + 1) + i) << static_cast<double>(i) / na, static_cast<double>(j) / nh;
    }
  }
  EXPECT_THROW(JetDeformationModel(JetDeformationOptions(), vertices), std::invalid_argument);
  const JetDeformationModel model(JetDeformationOptions(), vertices, &texcoords);
  ASSERT_TRUE(model.texture_space());
  EXPECT_EQ(model.num_parameters(), 3 * 14 + 6);
  std::vector<double> theta(model.num_parameters(), 0.0);
  Eigen::Matrix3Xd at_zero;
  model.Evaluate(theta.data(), &at_zero);
  EXPECT_LT((at_zero - vertices).cwiseAbs().maxCoeff(), 1e-15);
  for (size_t k = 0; k < theta.size(); ++k) theta[k] = 0.01 * std::cos(2.0 + k);
  Eigen::Matrix3Xd v, vp, vm;
  Eigen::MatrixXd jacobian;
  model.Evaluate(theta.data(), &v, &jacobian);
  double max_error = 0.0;
  for (int c = 0; c < model.num_parameters(); ++c) {
    std::vector<double> plus = theta, minus = theta;
    plus[c] += 1e-7;
    minus[c] -= 1e-7;
    model.Evaluate(plus.data(), &vp);
    model.Evaluate(minus.data(), &vm);
    const Eigen::Matrix3Xd numeric = (vp - vm) / 2e-7;
    for (int i = 0; i < model.num_vertices(); ++i) {
      max_error = std::max(max_error, (numeric.col(i) - jacobian.block(3 * i, c, 3, 1)).cwiseAbs().maxCoeff());
    }
  }
  EXPECT_LT(max_error, 1e-7);
}

TEST_F(FrameCostsTest, RenderCostJacobianMatchesFiniteDifferences) {
  const SoftRasterizer rasterizer(SoftRasterizerOptions(), scene_.texture);
  const SftFrame frame = LoadFrame(scene_, 1);
  RenderCost::Data d = RenderData(rasterizer, frame);
  const RenderCost cost(d);
  double largest = 0.0;
  EXPECT_LT(RelativeJacobianError(cost, theta_, 1e-6, &largest), 0.02);
  EXPECT_GT(largest, 0.0);

  // The normal equations formed directly equal those of the full Jacobian.
  const int m = cost.num_residuals(), P = model_->num_parameters();
  std::vector<double> r(m), j(static_cast<size_t>(m) * P);
  const double* parameters[1] = {theta_.data()};
  double* jacobians[1] = {j.data()};
  ASSERT_TRUE(cost.Evaluate(parameters, r.data(), jacobians));
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(j.data(), m, P);
  const Eigen::Map<const Eigen::VectorXd> R(r.data(), m);
  double squared_norm = 0.0;
  Eigen::MatrixXd jtj;
  Eigen::VectorXd jtr;
  ASSERT_TRUE(cost.EvaluateNormalEquations(theta_.data(), &squared_norm, &jtj, &jtr));
  EXPECT_NEAR(squared_norm, R.squaredNorm(), 1e-9 * R.squaredNorm());
  EXPECT_LT((jtj - J.transpose() * J).norm(), 1e-9 * jtj.norm());
  EXPECT_LT((jtr - J.transpose() * R).norm(), 1e-9 * jtr.norm());
}

// With a band around the mask's border, a silhouette within the bounds
// costs nothing (residual and Jacobian row zero); elsewhere it is the
// plain residual S - M; and the Jacobian stays exact.
TEST_F(FrameCostsTest, ASilhouetteBandFreesTheBorderAndKeepsTheJacobianExact) {
  const SoftRasterizer rasterizer(SoftRasterizerOptions(), scene_.texture);
  const SftFrame frame = LoadFrame(scene_, 1);
  RenderCost::Data d = RenderData(rasterizer, frame);
  const RenderCost plain(d);
  MaskBounds(frame.mask, 2.0, &d.mask, &d.mask_upper);
  const RenderCost banded(d);
  EXPECT_LT(RelativeJacobianError(banded, theta_, 1e-6), 0.02);

  const int m = plain.num_residuals();
  std::vector<double> r_plain(m), r_band(m);
  const double* parameters[1] = {theta_.data()};
  ASSERT_TRUE(plain.Evaluate(parameters, r_plain.data(), nullptr));
  ASSERT_TRUE(banded.Evaluate(parameters, r_band.data(), nullptr));
  int freed = 0, kept = 0;
  for (int y = 0; y < 60; ++y) {
    for (int x = 0; x < 80; ++x) {
      const int i = (y * 80 + x) * 4 + 3;
      const float lo = d.mask.at<float>(y, x), hi = d.mask_upper.at<float>(y, x);
      if (lo == hi) {
        EXPECT_EQ(r_band[i], r_plain[i]);
        ++kept;
      } else {
        EXPECT_LE(std::abs(r_band[i]), std::abs(r_plain[i]) + 1e-12);
        if (r_band[i] == 0.0 && r_plain[i] != 0.0) ++freed;
      }
    }
  }
  EXPECT_GT(freed, 50);
  EXPECT_GT(kept, 1000);
}

TEST_F(FrameCostsTest, InextensibilityAndTemporalJacobiansMatchFiniteDifferences) {
  std::vector<Eigen::Vector2i> edges = {{0, 1}, {0, 9}, {10, 11}, {5, 14}};
  std::vector<double> lengths;
  for (const auto& e : edges) {
    lengths.push_back((scene_.template_mesh.vertices.col(e[0]) - scene_.template_mesh.vertices.col(e[1])).norm());
  }
  const InextensibilityCost inextensibility(model_.get(), edges, lengths, 2.0);
  EXPECT_LT(RelativeJacobianError(inextensibility, theta_, 1e-7), 1e-5);
  const Eigen::Matrix3Xd previous = scene_.template_mesh.vertices;
  const TemporalCost temporal(model_.get(), 0.3, 1.5, &previous);
  EXPECT_LT(RelativeJacobianError(temporal, theta_, 1e-7), 1e-5);
}

}  // namespace
}  // namespace polyfit
