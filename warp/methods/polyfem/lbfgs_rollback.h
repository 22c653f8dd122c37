// L-BFGS whose every accepted step may be cut back in parts: the minimiser of [PolyFEM §4.5]'s
// fold-free fallback. After each line-search step the caller's `rollback` sees the previous and
// the trial iterate and may reset some coordinates of the trial to their previous values (the
// nodes of the cells that folded); the step is then taken as rolled back, so the iterate never
// leaves the set the caller guards (no fold), and the energy never increases (a rolled-back trial
// that raises it is retried with half the step).
//
// Why our own two-loop recursion [Nocedal–Wright Alg. 7.4] rather than LBFGSpp's (Debian's
// liblbfgspp-dev): LBFGSpp runs its line search and update as one call with no hook between a
// step and the curvature pair it stores, so a per-part rollback would either be invisible to it
// (wrong pairs s, y) or need the whole step rejected by an infinite energy — which stalls as soon
// as one cell folds. Here the pair is taken from the rolled-back step. Tested against LBFGSpp on
// problems both solve (tests/unit/polyfem_lbfgs_test.cc).
//
// Thread safety: a pure function; the callbacks run on the caller's thread.
#pragma once

#include <functional>

#include <Eigen/Core>

#include "warp/core/stop_token.h"

namespace zoomwarp::warp {

struct LbfgsOptions {
  int memory = 8;                    // curvature pairs kept (m)
  int max_iterations = 200;
  double gradient_tolerance = 1e-6;  // stop when |g|∞ ≤ tolerance·max(1, |x|∞)
  double energy_tolerance = 1e-12;   // or when a step lowers the energy by less than this, relative
  int max_halvings = 30;             // per iteration, in the line search
};

// Energy at x, its gradient written to `gradient` (same size as x).
using LbfgsObjective = std::function<double(const Eigen::VectorXd& x, Eigen::VectorXd& gradient)>;

// May set trial[i] = previous[i] for any i (and nothing else); returns how many parts it rolled
// back (0: the trial is accepted as is). Empty: no rollback.
using LbfgsRollback = std::function<int(const Eigen::VectorXd& previous, Eigen::VectorXd& trial)>;

struct LbfgsResult {
  int iterations = 0;
  int rollbacks = 0;          // parts rolled back in the accepted steps, over all iterations
  double energy = 0;          // at the returned x
  bool converged = false;     // a tolerance was met (not the iteration limit or a stalled search)
};

// Minimises from x (which the rollback must accept as it is), x overwritten by the result.
// Checks `stop` once per iteration (throws Stopped, x then left as given).
LbfgsResult minimize_lbfgs_with_rollback(Eigen::VectorXd& x, const LbfgsObjective& objective,
                                         const LbfgsRollback& rollback, const LbfgsOptions& options = {},
                                         const StopToken* stop = nullptr);

}  // namespace zoomwarp::warp
