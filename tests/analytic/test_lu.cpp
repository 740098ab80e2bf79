// The sparse LU (analytic/kinematics/newton.h, SmallLU) against a dense LU written here from
// LAPACK's dgetf2 (partial pivoting on the largest magnitude, the first on ties, the column scaled
// by the pivot's reciprocal, a rank-one update of the rest): the same factors and the same row
// swaps, bit for bit, on every bundled definition's Jacobian and on random sparse matrices full of
// ties. Its cost follows the factors' entries, so these must stay a few per row along a chain.
#include <gtest/gtest.h>

#include <Eigen/LU>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "analytic/kinematics/newton.h"
#include "analytic/model/loader.h"

namespace crosslink {
namespace {

struct DenseLU {
  Eigen::MatrixXd lu;
  std::vector<int> transpositions;
};

DenseLU dgetf2(Eigen::MatrixXd a) {
  const int n = static_cast<int>(a.rows());
  DenseLU out{a, std::vector<int>(static_cast<size_t>(n))};
  Eigen::MatrixXd& m = out.lu;
  for (int k = 0; k < n; ++k) {
    int p = k;
    for (int i = k + 1; i < n; ++i)
      if (std::abs(m(i, k)) > std::abs(m(p, k))) p = i;
    out.transpositions[static_cast<size_t>(k)] = p;
    if (m(p, k) == 0.0) continue;  // a singular column: nothing to eliminate
    m.row(k).swap(m.row(p));
    const double inverse = 1.0 / m(k, k);
    for (int i = k + 1; i < n; ++i) m(i, k) *= inverse;
    for (int j = k + 1; j < n; ++j)
      for (int i = k + 1; i < n; ++i) m(i, j) -= m(i, k) * m(k, j);
  }
  return out;
}

void expect_same_factors(const SmallLU& lu, const Eigen::MatrixXd& a, const std::string& what) {
  const DenseLU dense = dgetf2(a);
  EXPECT_EQ(lu.transpositions(), dense.transpositions) << what;
  const Eigen::MatrixXd packed = lu.packed();
  // == on every entry: the same arithmetic in the same order (a zero's sign aside).
  EXPECT_TRUE((packed.array() == dense.lu.array()).all())
      << what << ": largest difference " << (packed - dense.lu).cwiseAbs().maxCoeff();
}

std::vector<std::string> definitions() {
  std::vector<std::string> files;
  for (const char* folder : {"mechanisms", "mechanisms/scaling"})
    for (const auto& entry : std::filesystem::directory_iterator(folder))
      if (entry.path().extension() == ".toml") files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

TEST(SparseLU, EveryBundledJacobianFactorsAsTheDenseLoops) {
  int checked = 0;
  for (const std::string& file : definitions()) {
    const Mechanism m = load_mechanism(file);
    const NewtonSolver solver(m);
    KinematicState state(m);
    if (solver.assemble(state).status != PoseStatus::ok) continue;
    for (int k = 0; k < 3; ++k) {
      // The factorised matrix is the scaled Jacobian the state keeps; its pattern holds every
      // entry the dense Jacobian has.
      const Eigen::MatrixXd scaled = state.jacobian.dense();
      Eigen::MatrixXd dense(m.coordinate_count(), m.coordinate_count());
      solver.jacobian(state.q, dense);
      for (int r = 0; r < dense.rows(); ++r)
        for (int c = 0; c < dense.cols(); ++c)
          if (dense(r, c) != 0.0) {
            EXPECT_NE(scaled(r, c), 0.0) << file << ": (" << r << ", " << c << ")";
          }
      expect_same_factors(state.lu, scaled, file);
      // The norm the condition estimate divides by: Eigen's dense column sums, bit for bit.
      EXPECT_EQ(state.jacobian_norm, scaled.cwiseAbs().colwise().sum().maxCoeff()) << file;
      ++checked;
      state.swept().value += 0.3 * (m.drivers[0].angular() ? 1.0 : 0.1 * m.size());
      if (solver.solve(state).status != PoseStatus::ok) break;
    }
  }
  EXPECT_GT(checked, 40);
}

TEST(SparseLU, RandomSparseMatricesWithTiesFactorAsTheDenseLoops) {
  // Small integers, so that ties between candidate pivots are the rule, and exact zeros and
  // singular matrices appear.
  std::mt19937 random(20261127);
  std::uniform_int_distribution<int> value(-2, 2);
  for (int trial = 0; trial < 400; ++trial) {
    const int n = 1 + trial % 37;
    const double fill = 0.05 + 0.1 * (trial % 7);
    std::bernoulli_distribution present(fill);
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, n);
    for (int r = 0; r < n; ++r)
      for (int c = 0; c < n; ++c)
        if (present(random)) a(r, c) = value(random) * (trial % 3 == 0 ? 0.1 : 1.0);
    const SparseJacobian sparse(a);
    SmallLU lu(n, sparse.nonzeros());
    lu.factorize(sparse);
    expect_same_factors(lu, a, "trial " + std::to_string(trial));
    // The solves invert the matrix where it is regular.
    const Eigen::FullPivLU<Eigen::MatrixXd> check(a);
    if (!check.isInvertible()) continue;
    Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(n, 1.0, 2.0), x = b, y = b;
    lu.solve_in_place(x.data());
    lu.solve_transposed_in_place(y.data());
    const double scale = a.cwiseAbs().sum() * (1.0 + x.cwiseAbs().maxCoeff());
    EXPECT_LE((a * x - b).cwiseAbs().maxCoeff(), 1e-10 * scale) << "trial " << trial;
    EXPECT_LE((a.transpose() * y - b).cwiseAbs().maxCoeff(), 1e-10 * scale) << "trial " << trial;
  }
}

TEST(SparseLU, AChainsFactorsHoldAFewEntriesPerRow) {
  // IFToMM A02: the factors' entries per row of the Jacobian do not grow with the chain, so a
  // factorisation and a substitution cost in proportion to its bodies.
  std::vector<double> per_row;
  for (const char* file : {"mechanisms/iftomm_a02_double_fourbar.toml",
                           "mechanisms/scaling/iftomm_a02_nfourbar_10.toml",
                           "mechanisms/scaling/iftomm_a02_nfourbar_40.toml"}) {
    const Mechanism m = load_mechanism(file);
    const NewtonSolver solver(m);
    KinematicState state(m);
    ASSERT_EQ(solver.assemble(state).status, PoseStatus::ok) << file;
    per_row.push_back(static_cast<double>(state.lu.factor_nonzeros()) / m.coordinate_count());
  }
  EXPECT_LE(per_row[2], 1.1 * per_row[1]) << per_row[1] << " at N = 10, " << per_row[2];
  EXPECT_LE(per_row[2], 8.0);
}

}  // namespace
}  // namespace crosslink
