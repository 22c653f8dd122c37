#include "warp/methods/polyfem/lbfgs_rollback.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <optional>
#include <utility>
#include <vector>

namespace zoomwarp::warp {
namespace {

// c1 of the sufficient-decrease (Armijo) condition [Nocedal–Wright eq. 3.4], their suggested value.
constexpr double kArmijo = 1e-4;
// A pair with sᵀy ≤ this·|s||y| would make H indefinite or ill-conditioned. Neither a backtracking
// (Armijo-only) search nor a rolled-back step guarantees the curvature condition sᵀy > 0, so such a
// pair is skipped rather than stored.
constexpr double kCurvatureFloor = 1e-10;

struct CurvaturePair {
  Eigen::VectorXd s, y;
  double rho;  // 1 / sᵀy
};

// The last `capacity` pairs (s, y) and the L-BFGS product −H·g [Nocedal–Wright Alg. 7.4].
class CurvatureMemory {
 public:
  explicit CurvatureMemory(int capacity) : capacity_(capacity) {}

  bool empty() const { return pairs_.empty(); }
  void clear() { pairs_.clear(); }

  void add(Eigen::VectorXd s, Eigen::VectorXd y) {
    const double sy = s.dot(y);
    if (capacity_ <= 0 || !(sy > kCurvatureFloor * s.norm() * y.norm())) return;
    if (static_cast<int>(pairs_.size()) == capacity_) pairs_.pop_front();
    pairs_.push_back({std::move(s), std::move(y), 1.0 / sy});
  }

  // The two-loop recursion, H₀ = γI with γ = sᵀy / yᵀy of the newest pair [Nocedal–Wright eq. 7.20].
  Eigen::VectorXd descent_direction(const Eigen::VectorXd& gradient) const {
    Eigen::VectorXd q = gradient;
    std::vector<double> alpha(pairs_.size());
    for (std::size_t i = pairs_.size(); i-- > 0;) {
      alpha[i] = pairs_[i].rho * pairs_[i].s.dot(q);
      q -= alpha[i] * pairs_[i].y;
    }
    if (!pairs_.empty()) q /= pairs_.back().rho * pairs_.back().y.squaredNorm();
    for (std::size_t i = 0; i < pairs_.size(); ++i) {
      const double beta = pairs_[i].rho * pairs_[i].y.dot(q);
      q += (alpha[i] - beta) * pairs_[i].s;
    }
    return -q;
  }

 private:
  int capacity_;
  std::deque<CurvaturePair> pairs_;
};

struct Iterate {
  Eigen::VectorXd x, gradient;
  double energy = 0;
};

struct Step {
  Iterate next;
  int rollbacks = 0;
};

Iterate evaluate(Eigen::VectorXd x, const LbfgsObjective& objective) {
  Iterate at;
  at.gradient.resize(x.size());
  at.x = std::move(x);
  at.energy = objective(at.x, at.gradient);
  return at;
}

bool gradient_small(const Iterate& at, double tolerance) {
  return at.gradient.lpNorm<Eigen::Infinity>() <= tolerance * std::max(1.0, at.x.lpNorm<Eigen::Infinity>());
}

// Without curvature pairs the direction is −g, in the gradient's units rather than x's: the first
// trial then moves no coordinate by more than 1 (a pixel, for the warp's nodes). With pairs, the
// quasi-Newton step 1 [Nocedal–Wright §7.2].
double initial_length(const Eigen::VectorXd& direction, bool scaled_by_pairs) {
  if (scaled_by_pairs) return 1;
  return std::min(1.0, 1.0 / direction.lpNorm<Eigen::Infinity>());
}

// Backtracking along `direction` from `length`, halving: each trial is rolled back by the caller
// first and evaluated where it landed, so the objective never sees a point the rollback refuses.
// Accepted on Armijo's condition for the step actually taken (the rolled-back one) and a strictly
// lower energy — a step all rolled back, or one whose rolled-back part climbs, is not progress.
std::optional<Step> backtrack(const Iterate& current, const Eigen::VectorXd& direction, double length,
                              const LbfgsObjective& objective, const LbfgsRollback& rollback, int max_halvings) {
  for (int halvings = 0; halvings <= max_halvings; ++halvings, length /= 2) {
    Eigen::VectorXd trial = current.x + length * direction;
    const int rolled_back = rollback ? rollback(current.x, trial) : 0;
    const double slope = current.gradient.dot(trial - current.x);
    Iterate next = evaluate(std::move(trial), objective);
    if (next.energy < current.energy && next.energy <= current.energy + kArmijo * slope)
      return Step{std::move(next), rolled_back};
  }
  return std::nullopt;
}

}  // namespace

LbfgsResult minimize_lbfgs_with_rollback(Eigen::VectorXd& x, const LbfgsObjective& objective,
                                         const LbfgsRollback& rollback, const LbfgsOptions& options,
                                         const StopToken* stop) {
  Iterate current = evaluate(x, objective);
  CurvatureMemory memory(options.memory);
  LbfgsResult result;
  for (;;) {
    check_stop(stop);
    if (gradient_small(current, options.gradient_tolerance)) {
      result.converged = true;
      break;
    }
    if (result.iterations >= options.max_iterations) break;
    Eigen::VectorXd direction = memory.descent_direction(current.gradient);
    if (!(current.gradient.dot(direction) < 0)) {  // the pairs lost positive definiteness: start over
      memory.clear();
      direction = -current.gradient;
    }
    std::optional<Step> step = backtrack(current, direction, initial_length(direction, !memory.empty()), objective,
                                         rollback, options.max_halvings);
    if (!step) break;
    ++result.iterations;
    result.rollbacks += step->rollbacks;
    const double decrease = current.energy - step->next.energy;
    memory.add(step->next.x - current.x, step->next.gradient - current.gradient);
    current = std::move(step->next);
    if (decrease <= options.energy_tolerance * std::max(1.0, std::abs(current.energy))) {
      result.converged = true;
      break;
    }
  }
  x = std::move(current.x);
  result.energy = current.energy;
  return result;
}

}  // namespace zoomwarp::warp
