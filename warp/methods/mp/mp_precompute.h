// method=mp's precomputation [Guo09 §3.2–3.3] (mp_model.h): MethodInput → MpModel, and the
// model's bytes for mp.<saliency>.bin (the payload; analysis/method_files adds the magic and the
// trailer). Everything in analysis pixels (Wa × Ha, the analysis image's size).
//
//   points   [Guo09 §3.2] N = 300 feature points at spacing d = sqrt(Wa·Ha/N): the border every
//            ~d (corners included), line points every ~d/2 along the lines, Canny pixels kept
//            greedily when ≥ d from every point kept so far, auxiliary points on the d-grid where
//            nothing lies within 0.75d;
//   mesh     their constrained Delaunay triangulation with consecutive line points as edges,
//            refined to a 20° minimum angle within a budget of 1.3·N vertices (ours: slivers make
//            the Newton solve ill-conditioned) — meshing/constrained_mesh.h;
//   lines    [Guo09 §3.3.3] the curator's lines, then the detected ones (MethodInput), scaled to
//            analysis px; as constraints of the mesh, clipped d/4 inside the border and cut back
//            to their pieces ≥ d/2 from every line taken before (ours: crossing constraints cannot
//            be meshed exactly), pieces shorter than d dropped. Each line inside the image is one
//            MpLine over its whole segment clipped to the image (ours, issue 30: what was cut
//            away bent 2.5–10 px on the samples): its ends and samples every ≤ d/4, each written
//            barycentrically in the triangle holding it, and its pieces' vertices, in order along
//            it — also a line clear_pieces left nothing of;
//   objects  [Guo09 §3.3.2 eq. 2] triangles whose mean saliency exceeds Sμ = 0.6 times the largest
//            triangle mean (ours: 001's maps peak at 1, ours at 0.5–0.7 on photographs) — for
//            saliency=gbvs instead [Kumar (004) §III-B] triangles with ≥ 50 % of their area in
//            attention regions with AV ≥ 0.1·max AV (saliency/attention.h) — grouped into
//            vertex-connected components, so no vertex is in two objects; objects under 0.2 % of
//            the image are dropped (ours), those touching two opposite borders kept (mp_solve
//            fixes their scale across them: ours); the pole is the mean of the object's vertices
//            [§3.3.2]. An object's region — its area A_O and its mask — is every
//            triangle whose corners are all its vertices: what moves rigidly under [eq. 3];
//   tables   Lr(y), Lc(x) [eqs 8–9]: the object pixels on analysis row y (pixel centres y + 0.5)
//            and column x, the objects' regions rasterised by pixel centre (edges included).
//
// Deterministic: the same input gives the same model and the same bytes.
// Thread safety: pure functions, safe to call concurrently.
#pragma once

#include <string>
#include <string_view>

#include "warp/methods/mp/mp_model.h"
#include "warp/methods/retargeting_method.h"

namespace zoomwarp::warp {

struct MpPrecomputeOptions {
  int point_count = 300;               // N [Guo09 §3.2: "several hundred"]
  double vertex_budget_factor = 1.3;   // refinement stops at this × N vertices (ours)
  double min_angle_degrees = 20;       // refinement's target (ours)
  double object_saliency = 0.6;        // Sμ [Guo09 §3.3.2], times the largest triangle mean (ours)
  double attention_fraction = 0.1;     // saliency=gbvs: regions with AV ≥ this × max AV (ours)
  double region_cover = 0.5;           // saliency=gbvs: object triangles' share inside them (ours)
  double min_object_fraction = 0.002;  // of Wa·Ha: smaller objects are dropped (ours)
};

// The model of one image version and saliency kind. An analysis image with no pixels gives an
// empty model (no mesh); any other gives a valid mesh, however small or thin the image.
MpModel build_mp_model(const MethodInput& input, const MpPrecomputeOptions& options = {});

// mp.<saliency>.bin's payload: little-endian doubles and 32-bit integers, field by field as in
// mp_model.h. The same model gives the same bytes.
std::string mp_model_bytes(const MpModel& model);

// The model back from its payload. Throws std::runtime_error for bytes that are not a
// well-formed model (truncated, trailing bytes, indices out of range, tables of the wrong size,
// non-finite numbers).
MpModel parse_mp_model(std::string_view bytes);

}  // namespace zoomwarp::warp
