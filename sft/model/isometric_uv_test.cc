#include "sft/model/isometric_uv.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "polyfit/jet/jet_basis.h"

namespace polyfit {
namespace {

// A flat 15 by 15 grid, 0.2 wide, at depth 1: its jet is flat, so the
// template's slopes are zero and the frame's (u, v) span the grid.
JetDeformationModel FlatModel() {
  Eigen::Matrix3Xd vertices(3, 225);
  for (int r = 0; r < 15; ++r) {
    for (int c = 0; c < 15; ++c) vertices.col(15 * r + c) = Eigen::Vector3d(0.2 * c / 14 - 0.1, 0.2 * r / 14 - 0.1, 1.0);
  }
  return JetDeformationModel(JetDeformationOptions(), vertices);
}

// The largest strain (uu, uv, vv) left at the patch's vertices by the uv
// field c under the jet alpha0 + dalpha: the bending's shortening
// (1 - 1 / sqrt(1 + g^2) along grad z) against the field's.
double LargestStrain(const JetDeformationModel& model, const std::vector<double>& block, const double* c) {
  const int order = model.patch().order, m = NumJetCoefficients(model.uv_order()) - 1;
  double largest = 0.0;
  for (int i = 0; i < model.num_vertices(); ++i) {
    const double u = model.uv()(0, i), v = model.uv()(1, i);
    double mono[kMaxJetCoefficients], mu[kMaxJetCoefficients], mv[kMaxJetCoefficients];
    JetMonomialGradients(order, u, v, mono, mu, mv);
    double zu = 0.0, zv = 0.0;
    for (int k = 1; k < NumJetCoefficients(order); ++k) {
      const double a = model.patch().coefficients[k] + (k >= 3 ? block[k - 3] : 0.0);
      zu += a * mu[k];
      zv += a * mv[k];
    }
    const double g2 = zu * zu + zv * zv;
    const double shorten = g2 > 0.0 ? (1.0 - 1.0 / std::sqrt(1.0 + g2)) / g2 : 0.5;
    JetMonomialGradients(model.uv_order(), u, v, mono, mu, mv);
    double du_u = 0.0, du_v = 0.0, dv_u = 0.0, dv_v = 0.0;
    for (int k = 0; k < m; ++k) {
      du_u += c[k] * mu[k + 1];
      du_v += c[k] * mv[k + 1];
      dv_u += c[m + k] * mu[k + 1];
      dv_v += c[m + k] * mv[k + 1];
    }
    largest = std::max({largest, std::abs(du_u + shorten * zu * zu),
                        std::abs(0.5 * (du_v + dv_u) + shorten * zu * zv), std::abs(dv_v + shorten * zv * zv)});
  }
  return largest;
}

// The template's largest |u|, |v|: the patch's reach.
double Reach(const JetDeformationModel& model) { return model.uv().cwiseAbs().maxCoeff(); }

// A block bending the flat template into the cylinder z = kappa s^2 / 2,
// s = a u + b v: the u^2, uv, v^2 coefficients (dalpha 0, 1, 2).
std::vector<double> Cylinder(const JetDeformationModel& model, double kappa, double a, double b) {
  std::vector<double> block(model.block_size(), 0.0);
  block[0] = 0.5 * kappa * a * a;
  block[1] = kappa * a * b;
  block[2] = 0.5 * kappa * b * b;
  return block;
}

// A gentle cylinder along any direction: to first order its isometric
// field is the cubic d = -(kappa^2 / 6) s^3 (a, b) (the turn, which
// strains nothing, left at zero), and unbent nothing slides.
TEST(IsometricUvFieldTest, AGentleCylinderSlidesAsVonKarmanSays) {
  const JetDeformationModel model = FlatModel();
  const IsometricUvField field(model, 0);
  ASSERT_EQ(field.num_duv(), model.num_duv());
  const double a = std::cos(0.6), b = std::sin(0.6);
  const double kappa = 0.05 / (2.0 * Reach(model));  // slopes up to 0.05
  std::vector<double> block = Cylinder(model, kappa, a, b);
  std::vector<double> c(field.num_duv());
  field.Evaluate(block.data(), c.data(), nullptr);
  const int u3 = NumJetCoefficients(2) - 1;  // du's u^3, after u, v, u^2, uv, v^2
  const double expected = -kappa * kappa / 6.0 * a * a * a * a;
  EXPECT_NEAR(c[u3], expected, 0.01 * std::abs(expected));
  std::fill(block.begin(), block.end(), 0.0);
  field.Evaluate(block.data(), c.data(), nullptr);
  for (double x : c) EXPECT_NEAR(x, 0.0, 1e-12);
}

// A steep cylinder (slopes up to about 1): the field takes off most of the
// bending's strain everywhere (a cubic cannot hold 1 - 1/sqrt(1 + g^2)
// exactly; its least squares leave 15% of the largest at the worst vertex).
TEST(IsometricUvFieldTest, ASteepCylindersStrainIsTakenOff) {
  const JetDeformationModel model = FlatModel();
  const IsometricUvField field(model, 0);
  const std::vector<double> block = Cylinder(model, 1.5 / (2.0 * Reach(model)), std::cos(2.0), std::sin(2.0));
  std::vector<double> c(field.num_duv());
  field.Evaluate(block.data(), c.data(), nullptr);
  const std::vector<double> zero(field.num_duv(), 0.0);
  const double bent = LargestStrain(model, block, zero.data());
  EXPECT_GT(bent, 0.2);
  EXPECT_LT(LargestStrain(model, block, c.data()), 0.2 * bent);
}

// A saddle has no isometric field: the field is a less strained one than
// none, and its Jacobian is right.
TEST(IsometricUvFieldTest, ASaddleIsLessStrainedAndTheJacobianIsRight) {
  const JetDeformationModel model = FlatModel();
  const IsometricUvField field(model, 0);
  std::vector<double> block(model.block_size(), 0.0);
  const double reach = Reach(model);
  for (int k = 0; k < model.num_dalpha(); ++k) block[k] = 0.2 * std::sin(1.0 + 2.0 * k) / std::pow(reach, 1 + k / 3);
  block[1] = 1.0 / reach;  // uv: slopes up to about 1
  const int nc = field.num_duv(), nd = field.num_dalpha();
  ASSERT_EQ(nd, model.num_dalpha());
  std::vector<double> c(nc), jacobian(static_cast<size_t>(nc) * nd), plus(nc), minus(nc);
  field.Evaluate(block.data(), c.data(), jacobian.data());
  const std::vector<double> zero(nc, 0.0);
  EXPECT_LT(LargestStrain(model, block, c.data()), 0.7 * LargestStrain(model, block, zero.data()));
  double error = 0.0, largest = 0.0;
  for (int j = 0; j < nd; ++j) {
    std::vector<double> p = block, q = block;
    const double h = 1e-6 / std::pow(reach, 1 + j / 3);
    p[j] += h;
    q[j] -= h;
    field.Evaluate(p.data(), plus.data(), nullptr);
    field.Evaluate(q.data(), minus.data(), nullptr);
    for (int k = 0; k < nc; ++k) {
      const double analytic = jacobian[static_cast<size_t>(k) * nd + j];
      // Relative to the column's scale: dalpha_j's units differ by order.
      error = std::max(error, std::abs((plus[k] - minus[k]) / (2 * h) - analytic) * h);
      largest = std::max(largest, std::abs(analytic) * h);
    }
  }
  EXPECT_GT(largest, 0.0);
  EXPECT_LT(error, 1e-6 * largest);
}

TEST(IsometricUvFieldTest, AnEmptyPatchOrNoCompactFieldThrows) {
  const JetDeformationModel model = FlatModel();
  EXPECT_THROW(IsometricUvField(model, 3), std::invalid_argument);
  JetDeformationOptions per_vertex;
  per_vertex.uv_displacement = UvDisplacement::kPerVertex;
  Eigen::Matrix3Xd grid(3, model.num_vertices());
  grid << model.uv(), Eigen::RowVectorXd::Ones(model.num_vertices());
  const JetDeformationModel other(per_vertex, grid);
  EXPECT_THROW(IsometricUvField(other, 0), std::invalid_argument);
  EXPECT_TRUE(IsometricUvFields(other).empty());
}

}  // namespace
}  // namespace polyfit
