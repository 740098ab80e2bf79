#include "analytic/kinematics/driver_chains.h"

#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <limits>
#include <queue>

namespace crosslink {
namespace {

// The moving indices a block's rows read (a, b and a gear pair's third link), -1 left out.
std::vector<int> block_links(const ConstraintRows& r) {
  std::vector<int> out;
  for (const int k : {r.a, r.b, r.c})
    if (k >= 0) out.push_back(k);
  return out;
}

}  // namespace

DriverChains::DriverChains(const Mechanism& mechanism, const ConstraintLayout& layout)
    : mechanism_(mechanism), layout_(layout) {
  const int n = mechanism.moving_count();
  for (int l = 0; l < static_cast<int>(mechanism.links.size()); ++l)
    if (!mechanism.links[static_cast<size_t>(l)].ground) moving_links_.push_back(l);
  // Joints between moving links, as edges (the ground is not passed through).
  const size_t joints = mechanism.joints.size();
  std::vector<std::vector<int>> next(static_cast<size_t>(n));
  for (size_t j = 0; j < joints; ++j) {
    const std::vector<int> ks = block_links(layout.blocks()[j]);
    for (const int a : ks)
      for (const int b : ks)
        if (a != b) next[static_cast<size_t>(a)].push_back(b);
  }
  // Each driver's distance (joints counted) to every moving link from its driven link.
  const int drivers = layout.driver_count();
  constexpr int kFar = std::numeric_limits<int>::max();
  std::vector<std::vector<int>> distance(static_cast<size_t>(drivers),
                                         std::vector<int>(static_cast<size_t>(n), kFar));
  std::vector<int> driven(static_cast<size_t>(drivers), -1);
  for (int d = 0; d < drivers; ++d) {
    const ConstraintRows& r = layout.driver(d);
    const int start = r.b >= 0 ? r.b : r.a;
    driven[static_cast<size_t>(d)] = start;
    if (start < 0) continue;
    std::vector<int>& dist = distance[static_cast<size_t>(d)];
    std::queue<int> open;
    dist[static_cast<size_t>(start)] = 0;
    open.push(start);
    while (!open.empty()) {
      const int k = open.front();
      open.pop();
      for (const int o : next[static_cast<size_t>(k)])
        if (dist[static_cast<size_t>(o)] == kFar) {
          dist[static_cast<size_t>(o)] = dist[static_cast<size_t>(k)] + 1;
          open.push(o);
        }
    }
  }
  // Each link to the driver strictly nearest it; -1: the output (a tie) or reached by none.
  std::vector<int> owner(static_cast<size_t>(n), -1);
  for (int k = 0; k < n; ++k) {
    int best = kFar, who = -1;
    bool tie = false;
    for (int d = 0; d < drivers; ++d) {
      const int dk = distance[static_cast<size_t>(d)][static_cast<size_t>(k)];
      if (dk < best) {
        best = dk;
        who = d;
        tie = false;
      } else if (dk == best && dk != kFar) {
        tie = true;
      }
    }
    owner[static_cast<size_t>(k)] = tie ? -1 : who;
  }
  for (int d = 0; d < drivers; ++d) {
    DriverChain c;
    c.driver = d;
    const int start = driven[static_cast<size_t>(d)];
    if (start >= 0 && owner[static_cast<size_t>(start)] == d) {
      c.links.push_back(moving_links_[static_cast<size_t>(start)]);
      for (int k = 0; k < n; ++k)
        if (k != start && owner[static_cast<size_t>(k)] == d)
          c.links.push_back(moving_links_[static_cast<size_t>(k)]);
      for (int k = 0; k < n; ++k)
        if (owner[static_cast<size_t>(k)] == d)
          for (int i = 0; i < 3; ++i) c.columns.push_back(3 * k + i);
      for (size_t j = 0; j < joints; ++j) {
        const ConstraintRows& r = layout.blocks()[j];
        const std::vector<int> ks = block_links(r);
        if (std::any_of(ks.begin(), ks.end(),
                        [&](int k) { return owner[static_cast<size_t>(k)] == d; }))
          for (int i = 0; i < r.rows(); ++i) c.rows.push_back(r.first_row + i);
      }
    }
    chains_.push_back(std::move(c));
  }
  // The output: the links in no chain, else the joints between two chains.
  std::string links, between;
  for (int k = 0; k < n; ++k)
    if (owner[static_cast<size_t>(k)] < 0)
      links += (links.empty() ? "" : ", ") +
               mechanism.links[static_cast<size_t>(moving_links_[static_cast<size_t>(k)])].name;
  for (size_t j = 0; j < joints; ++j) {
    const ConstraintRows& r = layout.blocks()[j];
    if (r.a >= 0 && r.b >= 0 && owner[static_cast<size_t>(r.a)] >= 0 &&
        owner[static_cast<size_t>(r.b)] >= 0 &&
        owner[static_cast<size_t>(r.a)] != owner[static_cast<size_t>(r.b)])
      between += (between.empty() ? "" : ", ") + mechanism.joints[j].name;
  }
  output_ = !links.empty()     ? "link " + links
            : !between.empty() ? "joint " + between
                               : std::string();
}

std::string DriverChains::links_text(int chain) const {
  std::string out;
  for (const int l : chains_[static_cast<size_t>(chain)].links)
    out += (out.empty() ? "" : ", ") + mechanism_.links[static_cast<size_t>(l)].name;
  return out;
}

Eigen::MatrixXd DriverChains::block(int chain, const Eigen::MatrixXd& jac) const {
  const DriverChain& c = chains_[static_cast<size_t>(chain)];
  const int size = static_cast<int>(c.rows.size());
  Eigen::MatrixXd out(size, size);
  for (int i = 0; i < size; ++i)
    for (int j = 0; j < size; ++j)
      out(i, j) = jac(c.rows[static_cast<size_t>(i)], c.columns[static_cast<size_t>(j)]);
  return out;
}

double DriverChains::sign(int chain, const Eigen::MatrixXd& jac) const {
  if (!chains_[static_cast<size_t>(chain)].square()) return 0.0;
  const double det = block(chain, jac).partialPivLu().determinant();
  return det > 0.0 ? 1.0 : det < 0.0 ? -1.0 : 0.0;
}

Eigen::MatrixXd DriverChains::scaled(const Eigen::MatrixXd& jac) const {
  // Size-free: a length column times the size, a length row over it.
  const double size = mechanism_.size();
  Eigen::MatrixXd out = jac;
  for (Eigen::Index c = 0; c < out.cols(); ++c)
    if (c % 3 != 2) out.col(c) *= size;
  for (Eigen::Index r = 0; r < out.rows(); ++r)
    if (!layout_.angle_row(static_cast<int>(r))) out.row(r) /= size;
  return out;
}

DriverChains::Conditioning DriverChains::conditioning(const Eigen::MatrixXd& jac) const {
  const auto ratio = [](const Eigen::MatrixXd& a) {
    const Eigen::VectorXd s = Eigen::JacobiSVD<Eigen::MatrixXd>(a).singularValues();
    return s.size() == 0 || s(0) == 0.0 ? 0.0 : s(s.size() - 1) / s(0);
  };
  const Eigen::MatrixXd z = scaled(jac);
  Conditioning out;
  out.full = ratio(z);
  for (int c = 0; c < static_cast<int>(chains_.size()); ++c)
    out.chain.push_back(chains_[static_cast<size_t>(c)].square() ? ratio(block(c, z)) : 1.0);
  return out;
}

}  // namespace crosslink
