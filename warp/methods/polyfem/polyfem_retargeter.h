// method=polyfem [PolyFEM] as a Retargeter, and its precomputation (polyfem.<saliency>.bin):
//
//   precompute  the saliency-adaptive polygon mesh of the analysis image (meshing/cvt_mesh.h),
//               the global system and its two decoupled solves g_x, g_y (polyfem_system.h);
//               stored: the mesh and g per node;
//   load        the nodes again, the cells sampled at kExportLevel (polyfem_export.h) and G at
//               every sample, once per version;
//   view        the samples warped by one axpy to the screen's aspect (the image's area), any
//               fold blended out toward the uniform stretch (core/fold_blend.h — interim: the
//               paper's L-BFGS with per-cell rollback [PolyFEM §4.5] is not built yet), then
//               traditional zoom as every method does.
//
// Thread safety: read-only after construction; view() may run concurrently.
#pragma once

#include <string>
#include <string_view>

#include "warp/meshing/polygon_mesh.h"
#include "warp/methods/polyfem/polyfem_export.h"
#include "warp/methods/polyfem/polyfem_system.h"
#include "warp/methods/retargeter.h"
#include "warp/methods/retargeting_method.h"

namespace zoomwarp::warp {

struct PolyfemModel {
  PolygonMesh mesh;                // analysis px
  std::vector<double> g_x, g_y;    // per node (polyfem_nodes(mesh) order)
};

PolyfemModel build_polyfem_model(const MethodInput& input);
std::string polyfem_model_bytes(const PolyfemModel& model);
PolyfemModel parse_polyfem_model(std::string_view bytes);  // throws std::runtime_error

class PolyfemRetargeting final : public Retargeter {
 public:
  // Export level: chord error ≤ 0.21 analysis px with the width halved on the test mesh (4× less
  // per level), ~18 500 triangles for 200 cells.
  static constexpr int kExportLevel = 2;

  PolyfemRetargeting(double width, double height, PolyfemModel model);
  View view(const ViewRequest& request) override;
  std::size_t memory_bytes() override;

  const Mesh& mesh() const { return source_; }  // the samples in image pixels
  // The samples' warp onto tw × th image pixels and the blend the fold guard needed.
  std::vector<Point> warped(double tw, double th, double* blend, const StopToken* stop = nullptr) const;

 private:
  const double width_, height_;
  const PolyfemModel model_;
  const PolyfemSampling sampling_;
  const SampledField field_;
  const Mesh source_;
};

const RetargetingMethod& polyfem_method();

}  // namespace zoomwarp::warp
