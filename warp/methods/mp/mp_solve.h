// method=mp, the per-target half: MpModel × target (W', H') → warped vertex positions, by
// minimising [Guo09 eq. 15] — the stretch energy toward ideal edge lengths [Guo09 eqs 8–10], the
// line term in cross-product form (eq. 7 corrected: printed with +b for −b, and its slope form
// cannot hold a vertical line) over each line's points, mesh vertices or (ours, issue 30) points
// between them written barycentrically in their source triangles, rigid objects through their poles [Guo09 eq. 3] and the hard boundary [Guo09
// eq. 1] — with Newton [Guo09 §3.4.2] on a per-edge PSD-projected Hessian and a line search that
// never lets a triangle flip.
//
// Everything is in analysis pixels (model.width × model.height onto target_w × target_h).
//
// The solve, in order (each step a function of mp_solve.cc: make_problem, rigid_start,
// shape_continuation, penalty_continuation, final_run, lowered_scale_solve):
//   1. z = mp_object_scale(): one scale for all objects, ≤ 1 and small enough that every row and
//      column keeps a background scale ≥ β·W'/W (β·H'/H), so the ideal lengths of eq. 8 stay
//      positive; z = 1 at W' = W, H' = H. Ours: each object's bounding box too (the row tables
//      under-count a slanted object, which eq. 3 could then not fit in the rectangle at all), and
//      on each row (column) the objects' mesh extents added up, an object on a border reaching it
//      (the tables count masks; vertices sharing rows that masks do not left z = 1 where eq. 3
//      could not put two objects side by side, and every continuation stalled between them).
//      Each object's map under eq. 3 is diag(s): s = (z, z), except (ours) across an object
//      touching two opposite borders, where eq. 1 fixes it: W'/W for the left and the right, H'/H
//      for the top and the bottom (one touching all four: the uniform stretch). Its bounding box
//      spans that side, so z ≤ W'/W (H'/H) already, and the map is a similarity when z reaches it.
//   2. The rigid start (ours): every object placed by eq. 3 at scale z, a pinned pole coordinate
//      as eq. 1 needs it, a free one putting the object's bounding box where eq. 8 puts a lone
//      object in its band (the gaps before and after scaled alike, so it stays inside the
//      rectangle); border vertices piecewise linear along their side between the corners and the
//      objects' border vertices; the rest by Floater's mean value coordinates [Floater03] on
//      the stretched mesh (positive weights reproducing affine maps). If that folds nothing, the
//      final run (5) starts from it at once. On the samples it does so in 18 of 32 cases.
//   3. Otherwise the shape continuation (ours): the hard parametrization with the objects' map
//      Q_i = Q_O + diag(s)(P_i − P_O) taken from the stretch s = (W'/W, H'/H) to eq. 3's (z, z) in
//      stages — each stage moves the rest along with the objects (the extension of step 2 applied
//      to the objects' displacement), is halved while that would fold, and is one Newton run with
//      the fold barrier ×30 that keeps thin triangles open for the next stage. Its last stage is
//      the final run. It replaces 001's path (the penalty continuation, step 4), which stalls
//      where an object fills most of a band between two borders — astronaut_portrait.png with
//      GBVS at 3:1, an object on the left border over 80 % of the height: its barrier holds the
//      object's rim while μ grows (residual 88 px after μ = 1e6), and substituting eq. 3 then
//      folds 34 rim triangles. With stages of the objects' shape instead of the penalty's weight,
//      every stage is rigid-in-form, so there is nothing left to substitute.
//   4. Only if that stalls (a stage below 1/1024 of the way): from the uniform stretch, with
//      objects' vertices free and rigidity as a penalty μ·Σ|Q_i − Q_O − z(P_i − P_O)|², μ = 1,
//      10, …, 1e6, one Newton run per μ (ours: 001 starts from the scaled image, which breaks eq.
//      3 whenever z ≠ W'/W or H'/H). A stage stops at a relative decrease of 1e-4 (ours); once
//      every object is within rigid_enough px of eq. 3, or after μ = 1e6, step 5 follows.
//   5. Eq. 3 substituted (unknowns: non-object vertices and one pole per object) and one more
//      Newton run to |∇E|∞ < 1e-7·(W' + H') or a relative decrease < 1e-12 — if the substitution
//      folds nothing; otherwise the continuation goes on, and after μ = 1e6 its result stands,
//      rigid = false and rigidity_residual saying how far from rigid it is.
//   6. Only if that ends not rigid (ours, issue 30), or rigid but torn (issue 41: a triangle below
//      5 % of its area under the uniform stretch, least_area_share): z lowered toward the fit scale
//      z_fit = min(W'/W, H'/H) — z_fit + (z − z_fit)/2, /4, then z_fit — each with steps 2–3 from
//      the stretch and its own step budget; the first rigid, untorn result stands (object_scale
//      says which z). Where two objects on a border leave the background too little
//      room, every path stalled and the penalty result collapsed triangles to 1e-11 of their area
//      (samples/planks_by_the_water.jpg at 9:16: z = 0.98, rigid at 0.69).
//   7. Still torn at z_fit (ours, issue 41): the objects give way. A held line crossing an object
//      cannot keep one slope in the object (a similarity) and in a background stretched by another
//      ratio unless the triangles where they meet collapse; each object's map goes from eq. 3's
//      toward the stretch's, s_stretch + k·(s − s_stretch) for k = 1/2, 1/4, 0 (object_shape_kept
//      = k), until the result is untorn; at k = 0 the objects follow the stretch as every line
//      does. If none is untorn: the least torn rigid result of steps 6–7, else step 5's.
//   Every run adds the rotation term (ours, rotation_weight below: eq. 8's row and column scales
//   shear the background around the objects, and the salient region beside them leaned 15–38°)
//   and a fold barrier to E (ours, fold_barrier below): eq. 10 prices an edge shrinking to nothing
//   at only l² while it prices stretching as |d|⁴, so without a barrier the cheapest way to make
//   room is to collapse a column of triangles (a tear through what it covers), and where the
//   descent points across a fold the fold-free line search alone stalls against it. The barrier is 0 with zero
//   gradient at the uniform stretch, so the identity and the pure stretch stay exact.
//   A Newton run takes at most 100 steps, a solve 1000 in all at each z (then the runs left end
//   at once).
//   With a warm start (the positions solved for a nearby target) the solve scales them onto the
//   new rectangle, substitutes eq. 3 and runs step 5 alone; if that folds, it starts cold.
//   The energy is not convex: different paths can end in different minima (on the samples the
//   shape continuation ended 11–12 % lower than the penalty one on the panorama at 1:1 and 16:9,
//   and higher on interior_wine_djembe_tall.jpg with GBVS at 16:9).
//
// Thread safety: mp_solve and the helpers are pure functions of their arguments: any number may
// run at once on a shared MpModel.
#pragma once

#include <vector>

#include "warp/core/stop_token.h"
#include "warp/methods/mp/mp_model.h"

namespace zoomwarp::warp {

struct MpSolveOptions {
  // λ of eq. 15. 001 uses 0.5 (METHODS §1); lines then bend 3–46 px on photographs, so ours is
  // 1e5, which keeps them within 1 px (the term is a squared distance, in px² like E_l): at most
  // 0.69 px on the samples and mp_property_test.cc's synthetic picture, all aspects 9:16 to 3:1
  // (5e4 left 1.34 px where a line leaves an object at z = 0.79 into a background stretched 1.69×).
  // Measured at chain vertices only; over whole lines (issue 30) the panorama with all 22 of its
  // detected lines keeps up to 3.1 px at 16:9 (mp_property_test.cc, failing). 1.4e5 with ρ = 600
  // below: at 1e5 the stiffer rotation term bent interior_wine_djembe_tall.jpg's lines (GBVS, 3:1)
  // 1.10 px; at 2e5 the 4:1 panorama at 640×360 ended in another minimum, 2.24 screen px.
  double line_weight = 1.4e5;
  double beta = 0.25;        // the least background scale, as a share of W'/W and H'/H
  // ε of the fold barrier ε·Σ_t A⁰_t(r_t − 1 − log r_t), r_t = area / area under the uniform
  // stretch (ours). At ε = 1 it kept the mesh unfolded but not open: on the samples and a
  // citrus-like picture (mp_property_test.cc), 9:16 to 3:1, triangles fell to 3·10⁻⁹ of their area
  // and the default map's salient anisotropy p99 reached 91× the stretch's (the citrus at 9:16).
  // ε = 10 / 100 / 300 / 1000: least area share 0.003 → 0.047 / 0.073 / 0.073 / 0.074, salient
  // p99 at most 7.9 / 5.3 / 3.1 / 4.3× the stretch's; 300 turned boats_lake_sunset.jpg's
  // salient rotation at 360×640 to 11.7° and 1000 bent interior_wine_djembe_tall.jpg's lines
  // 2.5 px (straight_lines_property_test.cc, 10°, 1 px). Every Newton run took fewer steps (2040
  // → 910 over those 36 solves at 100).
  double fold_barrier = 100;
  // ρ of the rotation term ρ·Σ_t A⁰_t(A10 − A01)² (ours, issue 30): the background may stretch
  // as eq. 8 asks but not turn. Without it the salient rotation p95 at 360×640 was 15–38° on the
  // corpus photographs; ρ = 10 / 30 / 100 left at most 18.8 / 15.4 / 12.2° (the 4:1 panorama on
  // a 9:16 screen), ≤ 6.8° on every other photograph at ρ = 100, the gain over traditional zoom
  // within 10 % except on the two panoramas (−12 %, −15 %). Holding whole lines (issue 30) then
  // left boats_lake_sunset.jpg at 360×640 at 10.7° (straight_lines_property_test.cc); ρ = 200 /
  // 300 brought it to 8.8 / 5.7°, the gain within 4 / 7 % of ρ = 100 on the samples; 300 because
  // at 200 a warm start took one Newton step more than a cold one (mp_solve_test.cc). 300 still
  // left the full-size bridge_cables_horizon.jpg (4352×2448, 360×640) at 13.5° (9.6° at 600, the
  // 1 MP copy 8.6 → 7.6°); every corpus photograph, full size and 1 MP, 360×640 and 640×360, is
  // ≤ 9.6° at 600 with λ = 1.4e5, the gain within ±1 % of ρ = 300.
  double rotation_weight = 600;
  // The rigidity residual (px) at which the continuation hands over to the hard parametrization.
  double rigid_enough = 0.5;
  // The positions of every mesh vertex for another target (a cached solve of the same model), or
  // empty: a cold start from the uniform stretch (also when the size does not match the mesh).
  std::vector<Point> warm_start;
  double warm_width = 0, warm_height = 0;  // the target warm_start was solved for
  const StopToken* stop = nullptr;         // checked before every Newton step (throws Stopped)
};

struct MpSolution {
  std::vector<Point> positions;  // per mesh vertex, analysis px of the target rectangle
  std::vector<Point> poles;      // Q_O per object
  double object_scale = 1;       // z, as step 6 left it
  std::vector<Point> object_scales;  // per object, the diagonal of its map (eq. 3 above; step 7's)
  bool rigid = true;             // eq. 3 holds exactly (step 5 ran); false: the penalty result, or step 7
  double rigidity_residual = 0;  // max over object vertices of |Q_i − Q_O − diag(s)(P_i − P_O)|, px
  int iterations = 0;            // Newton steps, all runs together
  double energy = 0;             // E_l + λ·E_line + the rotation term at the result (no penalty, no barrier)
  int folds = 0;                 // triangles with signed area ≤ 0 (0 by construction)
  // The smallest triangle's area over its area under the uniform stretch: under 0.05 the result
  // is torn (a crease through what the triangle covers) and step 6 lowers z (issue 41).
  double least_area_share = 1;
  // k of step 7: the share of eq. 3's shape the objects keep (1: rigid; 0: the uniform stretch's
  // map). object_scales holds the diagonals actually used.
  double object_shape_kept = 1;
  bool warm_started = false;     // the warm start was used (not discarded for folding)
  // The energy minimised by each Newton run (penalty and barrier included), before its first step and after
  // each accepted one: strictly decreasing within a run.
  std::vector<std::vector<double>> energy_history;
};

// z of METHODS §1: min(1, sqrt(W'H'/ΣA_O), min over object rows of (W' − β(W'/W)(W − Lr))/Lr,
// likewise over columns), and (ours) the same bound with each object's bounding-box width
// (height) for Lr (Lc), and with each row's (column's) sum of the objects' mesh extents on it.
double mp_object_scale(const MpModel& model, double target_w, double target_h, double beta = 0.25);

// Ideal edge lengths [Guo09 eqs 8–9] for every mesh edge (a, b), a < b, in the order returned.
struct MpEdge {
  int a = 0, b = 0;
  double length = 0;  // l_e
};
std::vector<MpEdge> mp_ideal_edges(const MpModel& model, double target_w, double target_h, double z);

// One edge's stretch term f(d) = (|d|² − l²)²/l² [Guo09 eq. 10], d = Q_i − Q_j: its value,
// gradient 4(|d|² − l²)d/l², and Hessian with both eigenvalues clamped at 0,
// (4/l²)[max(0, |d|² − l²)(I − uuᵀ) + max(0, 3|d|² − l²)uuᵀ], u = d/|d| — the exact Hessian when
// |d| ≥ l, positive semidefinite always.
// (Plain types, so that this header needs no Eigen.)
struct MpSym2 {
  double xx = 0, xy = 0, yy = 0;
};
double mp_edge_energy(Point d, double l);
Point mp_edge_gradient(Point d, double l);
MpSym2 mp_edge_hessian(Point d, double l);

// The solve above. Preconditions (the precompute guarantees them; std::invalid_argument
// otherwise): positive sizes, boundary vertices on the rectangle, CCW triangles, no vertex in two
// objects, lines of points with vertices in range, finite weights and two distinct ends.
MpSolution mp_solve(const MpModel& model, double target_w, double target_h, const MpSolveOptions& options = {});

}  // namespace zoomwarp::warp
