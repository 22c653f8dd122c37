// The L-BFGS with per-part rollback of method=polyfem's fold-free fallback
// (warp/methods/polyfem/lbfgs_rollback.h, [PolyFEM §4.5]). Without a rollback it is plain L-BFGS:
// on an ill-conditioned quadratic and the extended Rosenbrock
// function it reaches the minimiser that LBFGSpp (Debian's liblbfgspp-dev, the reference) reaches,
// in a comparable number of iterations (both counts recorded as test properties). With a rollback
// that forbids negative coordinates, one part at a time as the fallback forbids folded cells, the
// objective only ever sees feasible points and the energy never rises. A spent stop token stops it;
// a start at the minimiser returns at once.
#include "warp/methods/polyfem/lbfgs_rollback.h"

#include <gtest/gtest.h>

#include <LBFGS.h>

#include <Eigen/QR>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <vector>

namespace zoomwarp {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// ½(x − c)ᵀA(x − c), minimiser c, with A = Q·diag(λ)·Qᵀ, Q a random rotation, λ log-spaced over
// [1, condition]. Centred on c rather than expanded to ½xᵀAx − bᵀx: near the minimiser the energy
// then falls by what its rounding can still resolve, so neither line search stalls on rounding
// before the gradient tolerance (the expanded form stalls LBFGSpp at |g|₂ ≈ 6e-7 here).
struct Quadratic {
  MatrixXd a;
  VectorXd c;

  Quadratic(int n, double condition, unsigned seed) {
    std::srand(seed);
    const MatrixXd q = Eigen::HouseholderQR<MatrixXd>(MatrixXd::Random(n, n)).householderQ();
    VectorXd lambda(n);
    for (int i = 0; i < n; ++i) lambda[i] = std::pow(condition, double(i) / (n - 1));
    a = q * lambda.asDiagonal() * q.transpose();
    c = VectorXd::Random(n);
  }

  double operator()(const VectorXd& x, VectorXd& gradient) const {
    gradient = a * (x - c);
    return 0.5 * (x - c).dot(gradient);
  }
  double energy(const VectorXd& x) const { return 0.5 * (x - c).dot(a * (x - c)); }
};

// Σ 100(x₂ᵢ₊₁ − x₂ᵢ²)² + (1 − x₂ᵢ)², minimiser (1, …, 1).
double extended_rosenbrock(const VectorXd& x, VectorXd& gradient) {
  double f = 0;
  for (int i = 0; i + 1 < x.size(); i += 2) {
    const double valley = x[i + 1] - x[i] * x[i], offset = 1 - x[i];
    f += 100 * valley * valley + offset * offset;
    gradient[i] = -400 * x[i] * valley - 2 * offset;
    gradient[i + 1] = 200 * valley;
  }
  return f;
}

constexpr double kGradientTolerance = 1e-8;

warp::LbfgsOptions tight_options() {
  warp::LbfgsOptions options;
  options.max_iterations = 1000;
  options.gradient_tolerance = kGradientTolerance;
  options.energy_tolerance = 0;  // the gradient test alone decides, as in LBFGSpp below
  return options;
}

// LBFGSpp with the same memory and gradient tolerance (its test is on |g|₂, ours on |g|∞: theirs is
// the stricter). Its backtracking search with the Wolfe curvature condition: with Armijo's alone it
// stores pairs with sᵀy ≤ 0 and fails on Rosenbrock's valley.
int lbfgspp_minimize(const warp::LbfgsObjective& objective, VectorXd& x) {
  LBFGSpp::LBFGSParam<double> param;
  param.m = warp::LbfgsOptions{}.memory;
  param.epsilon = kGradientTolerance;
  param.epsilon_rel = 0;
  param.max_iterations = 1000;
  param.linesearch = LBFGSpp::LBFGS_LINESEARCH_BACKTRACKING_WOLFE;
  LBFGSpp::LBFGSSolver<double> solver(param);
  auto f = [&](const VectorXd& at, VectorXd& gradient) { return objective(at, gradient); };
  double fx = 0;
  return solver.minimize(f, x, fx);
}

// Both from `start`: each reaches `expected` within 1e-6 (∞-norm), ours converged, in at most
// 1.5 times LBFGSpp's iterations plus 5.
void expect_as_lbfgspp(const warp::LbfgsObjective& objective, const VectorXd& start, const VectorXd& expected) {
  VectorXd ours = start, theirs = start;
  const warp::LbfgsResult result = warp::minimize_lbfgs_with_rollback(ours, objective, {}, tight_options());
  const int their_iterations = lbfgspp_minimize(objective, theirs);
  ::testing::Test::RecordProperty("iterations_ours", result.iterations);
  ::testing::Test::RecordProperty("iterations_lbfgspp", their_iterations);
  EXPECT_TRUE(result.converged);
  EXPECT_EQ(result.rollbacks, 0);
  EXPECT_LT((ours - expected).lpNorm<Eigen::Infinity>(), 1e-6);
  EXPECT_LT((theirs - expected).lpNorm<Eigen::Infinity>(), 1e-6);
  EXPECT_LE(result.iterations, 1.5 * their_iterations + 5) << "LBFGSpp took " << their_iterations;
}

TEST(PolyfemLbfgs, IllConditionedQuadraticAsLbfgspp) {
  const Quadratic quadratic(50, 1e3, 15);
  expect_as_lbfgspp(quadratic, VectorXd::Zero(50), quadratic.c);
}

TEST(PolyfemLbfgs, ExtendedRosenbrockAsLbfgspp) {
  VectorXd start(10);
  for (int i = 0; i < 10; i += 2) start.segment(i, 2) << -1.2, 1;
  expect_as_lbfgspp(extended_rosenbrock, start, VectorXd::Ones(10));
}

// The quadratic's unconstrained minimiser has negative coordinates; the rollback resets each
// coordinate a trial would take below 0, one part at a time as the fallback resets a folded cell.
TEST(PolyfemLbfgs, RollbackKeepsIteratesFeasibleAndEnergyFalling) {
  const Quadratic quadratic(20, 1e2, 3);
  ASSERT_LT(quadratic.c.minCoeff(), 0);
  int infeasible_evaluations = 0;
  const warp::LbfgsObjective objective = [&](const VectorXd& x, VectorXd& gradient) {
    if (x.minCoeff() < 0) ++infeasible_evaluations;
    return quadratic(x, gradient);
  };
  std::vector<double> iterate_energies;  // at the iterate each trial starts from
  const warp::LbfgsRollback rollback = [&](const VectorXd& previous, VectorXd& trial) {
    iterate_energies.push_back(quadratic.energy(previous));
    int parts = 0;
    for (int i = 0; i < trial.size(); ++i)
      if (trial[i] < 0) {
        trial[i] = previous[i];
        ++parts;
      }
    return parts;
  };
  VectorXd x = VectorXd::Ones(20);
  const double start_energy = quadratic.energy(x);
  const warp::LbfgsResult result = warp::minimize_lbfgs_with_rollback(x, objective, rollback);
  RecordProperty("iterations", result.iterations);
  RecordProperty("rollbacks", result.rollbacks);
  EXPECT_EQ(infeasible_evaluations, 0);
  EXPECT_GE(x.minCoeff(), 0);
  EXPECT_GT(result.rollbacks, 0);
  EXPECT_LT(result.energy, start_energy);
  EXPECT_DOUBLE_EQ(result.energy, quadratic.energy(x));
  ASSERT_GT(iterate_energies.size(), 2u);
  for (std::size_t k = 1; k < iterate_energies.size(); ++k)
    EXPECT_LE(iterate_energies[k], iterate_energies[k - 1]) << "trial " << k;
  EXPECT_LE(result.energy, iterate_energies.back());
}

TEST(PolyfemLbfgs, SpentStopTokenThrowsStopped) {
  const Quadratic quadratic(10, 10, 7);
  const warp::StopToken stop(warp::StopToken::Clock::now() - std::chrono::seconds(1));
  VectorXd x = VectorXd::Zero(10);
  EXPECT_THROW(warp::minimize_lbfgs_with_rollback(x, quadratic, {}, {}, &stop), warp::Stopped);
}

TEST(PolyfemLbfgs, StartAtMinimiserConvergesAtOnce) {
  const Quadratic quadratic(50, 1e3, 15);
  const VectorXd minimiser = quadratic.c;
  VectorXd x = minimiser;
  const warp::LbfgsResult result = warp::minimize_lbfgs_with_rollback(x, quadratic, {});
  EXPECT_TRUE(result.converged);
  EXPECT_LE(result.iterations, 1);
  EXPECT_LT((x - minimiser).lpNorm<Eigen::Infinity>(), 1e-9);
  EXPECT_DOUBLE_EQ(result.energy, quadratic.energy(minimiser));
}

}  // namespace
}  // namespace zoomwarp
