// Mesh warping by the local–global minimisation of [ICAZ §4.2–4.3]:
//
//   D = Σ_f w_f Σ_{e_ij ∈ f} ‖(v'_i − v'_j) − s_f (v_i − v_j)‖²  +  α D_Line  [+ ρ D_Rot, ours]
//
// subject to boundary constraints: vertices on the left/top edges of the source rectangle stay at
// x' = 0 / y' = 0, those on the right/bottom edges go to x' = W' / y' = H'; pinned vertices (a
// local solve inside a larger warp, see icaz.h) stay where the initial positions put them. Each iteration fixes
// the optimal scale s_f = Σ_e (d'_e·d_e) / Σ_e |d_e|² of every triangle (and the line parameters)
// from the current positions, which makes D quadratic, and solves the sparse SPD system with
// CHOLMOD.
//
// Structure exploited: the shape term's matrix is a weighted graph Laplacian that depends only on
// the mesh and the weights, never on s_f or on the target size (those only change the right-hand
// side), and x and y decouple. With no lines, or only horizontal/vertical ones held at vertices
// (orientation form D_Line_O with a fixed normal), each axis system is factored once in the constructor and every
// iteration — for any target size — is two back-substitutions. Oblique lines couple x and y and
// change the matrix every iteration (alternating D_Line_D / D_Line_O forms); then the joint
// system's pattern is analysed once and refactored numerically per iteration.
//
// Degenerate meshes: when every vertex is fixed along an axis (a mesh with no interior vertex —
// the coarsest mesh of any image whose short side is below the size criterion's edge, ~150 px
// for the default 10 000 px² area, e.g. two triangles on a 64×64 image), that axis has no
// unknowns; it is not factored and its coordinates are the boundary values.
//
// Not thread-safe: solve() is const but CHOLMOD's solve writes the factor's common workspace, so
// one object must not be solved from two threads at once (Icaz serialises its shared coarse
// warp). Distinct objects are independent and may be used from different threads.
#pragma once

#include <memory>
#include <vector>

#include "warp/core/mesh.h"
#include "warp/core/stop_token.h"
#include "warp/core/warp_result.h"

namespace zoomwarp::warp {

struct WarpOptions {
  double alpha = 100;  // line energy weight [ICAZ §4.3]
  // ρ of a rotation term ρ Σ_f w_f A_f (A_f,10 − A_f,01)² (ours, issue 30; 0: the paper's energy),
  // A_f the triangle's affine map source → target and A_f its source area: the antisymmetric
  // part that the angle of A_f's closest rotation grows with, 0 for any stretch along the axes.
  // The shape term keeps each triangle a scaled copy and lets it turn; a salient structure
  // spanning the image diagonally must turn or shear when the image is squeezed, and this term
  // makes it shear instead. Not 0 needs the joint path (it couples x and y): no fast path.
  double rotation_weight = 0;
  // Plain local–global converges linearly (2000 vertices, 8:3 squeezed to 1:1: 12 px from the
  // optimum after 10 iterations, 0.4 px after 40); the fast path's Anderson acceleration brings
  // that to 0.07 px after 10 and 0.0002 px after 20.
  int max_iterations = 100;
  // Converged when no vertex moved more than this many target pixels in an iteration.
  double tolerance = 0.02;
  int max_guard_rounds = 6;  // fold-over guard (see solve())
  // false: no fold-over guard at all (neither rounds nor the affine blend), so that a test can see
  // what the shape energy alone folds; every caller in the product keeps it on.
  bool fold_guard = true;
  // Local–global iterations per guard round (each round refactors the joint system and, with
  // fixed_line_normals, iterates it Anderson-accelerated like the main solve). Bounded well
  // below max_iterations: a round only has to unfold, and what it leaves folded the affine blend
  // unfolds — so the guard's cost is bounded (a 4:1 panorama on a square screen at z = 0).
  int max_guard_iterations = 20;
  // Oblique lines keep the normal they have in the start positions (orientation form only, no
  // alternating direction form): the joint system is then constant through the solve — factored
  // once and Anderson-accelerated like the fast path instead of refactored every iteration. For
  // solves started from a warp whose lines are already straight (the fine level, from the
  // coarse result, [ICAZ §6.2]), where the normal is all but settled.
  bool fixed_line_normals = false;
  // Checked before every local–global iteration and fold-over guard step (Stopped is thrown).
  // Not owned; none: runs to the end.
  const StopToken* stop = nullptr;
};

class ShapeWarp {
 public:
  // `mesh` lies in [0, width] × [0, height]; `weights` has one entry per triangle (significance,
  // > 0); `lines` are the line constraints in source pixels; `pinned` vertices keep their initial
  // positions in both axes (solve() must then be given a fold-free `initial`).
  //
  // A line is held at every point where it crosses a triangle edge, and at its ends, each written
  // in its triangle's corners: the warp is affine between two such points, so the warped line is
  // straight exactly when they are collinear. On a mesh built with the line as a constraint these
  // points are its vertices [ICAZ §4.3]; a line the mesh does not follow (a detected line cut back
  // where it nears another, issue 30) is held all the same. A line partly off the mesh (a local
  // solve) is held in each part it has on it.
  ShapeWarp(Mesh mesh, std::vector<double> weights, double width, double height, const std::vector<Segment>& lines = {},
            const std::vector<int>& pinned = {});
  ~ShapeWarp();
  ShapeWarp(ShapeWarp&&) noexcept;

  // Warps to a target_width × target_height rectangle, starting from `initial` (e.g. a coarser
  // warp, nested iteration [ICAZ §6.2]) or, when empty, from uniform scaling. With pinned vertices,
  // `initial` is required.
  WarpResult solve(double target_width, double target_height, const WarpOptions& options = {},
                   const std::vector<Point>& initial = {}) const;

  const Mesh& mesh() const;
  // Whether the fast path applies (no oblique lines, and every horizontal or vertical one held at
  // vertices only: matrices factored once).
  bool factored_once() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace zoomwarp::warp
