// The singular positions of a mechanism with several drivers (a parallel mechanism), in the terms
// of Gosselin & Angeles (1990), "Singularity analysis of closed-loop kinematic chains": with the
// loop equations A xdot + B qdot = 0 for the output x and the drivers q,
//   direct (forward) singularity   A singular: the drivers no longer determine the output, which
//                                  gains a freedom (the 3-RRR's platform where the three distal
//                                  links' lines meet);
//   inverse singularity            B singular: a driver's chain at a toggle (its links in line),
//                                  so the driver moves at first order with the output still, and
//                                  the output loses a direction (a five-bar's crank and coupler in
//                                  line).
//
// In crosslink's coordinates (every moving link's x, y, theta; constraints.h) the full Jacobian J
// holds the joints' rows C and the drivers' rows D. J is singular where the drivers fix every
// driven coordinate and the chain still moves: that is A singular (with each driver the
// absolute coordinate of its link, det J = +-det A, A the columns of C but the driven
// coordinates'), the direct singularity. An inverse singularity leaves J regular: it is seen
// driver by driver, in the block of C over one driver's chain with the output held:
//   driver d's chain  the moving links nearer (joints counted, through no ground) to d's driven
//                     link than to any other driver's; what is as near to two drivers' links or
//                     nearer to none is the output (the 3-RRR's platform; a five-bar's two
//                     couplers meet at their joint, the output point);
//   its block         the rows of every joint touching the chain, over the chain's columns only
//                     (the output and the ground held): square for a chain of two links between
//                     the ground and the output, and singular exactly where the chain can move
//                     with its ends held, a toggle.
// Along a sweep in time each block's determinant, and J's, is a smooth function of t whose sign
// change locates the singular position (analytic/reference/sweep.cpp, the timed sweep).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "analytic/model/constraints.h"
#include "analytic/model/mechanism.h"

namespace crosslink {

struct DriverChain {
  int driver = -1;           // index in Mechanism::drivers
  std::vector<int> links;    // Mechanism::links indices, the driven link first
  std::vector<int> rows;     // rows of J: those of every joint touching the chain
  std::vector<int> columns;  // columns of J: 3 per link of the chain
  // Whether the block is square (rows as many as columns): only then can it be at a toggle in
  // the sense above; a chain of another shape is not tested.
  bool square() const { return !links.empty() && rows.size() == columns.size(); }
};

class DriverChains {
 public:
  DriverChains(const Mechanism& mechanism, const ConstraintLayout& layout);

  const std::vector<DriverChain>& chains() const { return chains_; }
  // The output in words: the links in no chain, else the joints between two chains ("the
  // platform", "the joint C"); empty when the chains leave none.
  const std::string& output() const { return output_; }
  // "crank2, coupler3": the chain's links by name.
  std::string links_text(int chain) const;

  // The sign (+1, -1, 0) of the determinant of chain c's block of `jac` (the full Jacobian at a
  // pose); 0 for a chain that is not square.
  double sign(int chain, const Eigen::MatrixXd& jac) const;
  // Conditioning, size-free (lengths over the mechanism's size, rows of lengths over the size):
  // the smallest singular value over the largest, of the full Jacobian and of each square
  // chain's block (a chain not square: 1).
  struct Conditioning {
    double full = 1.0;
    std::vector<double> chain;
  };
  Conditioning conditioning(const Eigen::MatrixXd& jac) const;

 private:
  Eigen::MatrixXd block(int chain, const Eigen::MatrixXd& scaled) const;
  Eigen::MatrixXd scaled(const Eigen::MatrixXd& jac) const;

  const Mechanism& mechanism_;
  const ConstraintLayout& layout_;
  std::vector<DriverChain> chains_;
  std::vector<int> moving_links_;  // Mechanism::links index of each moving index
  std::string output_;
};

}  // namespace crosslink
