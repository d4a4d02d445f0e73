// colmap-nav and colmap-free: COLMAP's SIFT and exact matching, then
// point_triangulator with the nav poses held fixed (colmap-nav) and the
// mapper aligned to the local frame with the nav poses (colmap-free), in one
// run of the real `colmap` program (reference/colmap/colmap_runner.h).
#include "reference/compare/methods/method_support.h"

namespace hdabench::reference {

namespace {

// A free reconstruction's ROIs when the pair's configuration cannot give a
// confident relative pose: the configuration as status, no slope.
void WithholdIllConditioned(const ConfigurationReport& configuration, std::vector<MethodRoi>* rois) {
  for (MethodRoi& roi : *rois) {
    roi.configuration = ToString(configuration.type);
    if (configuration.type == ConfigurationType::kWellConditioned || roi.status == MethodRoiStatus::kFailed) {
      continue;
    }
    if (roi.has_fit) {
      roi.reason = "pair " + std::string(ToString(configuration.type)) + "; the fit would give " +
                   std::to_string(roi.slope_deg) + " deg from " + std::to_string(roi.num_points) +
                   " points";
    }
    roi.status = StatusOfConfiguration(configuration.type);
    roi.has_fit = false;
  }
}

// The COLMAP methods' common part: the reconstruction's ROIs, where its logs
// are, and what COLMAP's extraction said.
const PairReconstruction& FillColmapMethod(const PairContext& ctx, bool nav, std::vector<MethodRoi>* rois,
                                           MethodSummary* summary) {
  const ColmapResults& results = ctx.Colmap();
  const PairReconstruction& recon = nav ? results.nav : results.free;
  methods::FillFromReconstruction(recon, ctx, rois, summary);
  if (!recon.log_dir.empty()) summary->note = "logs: " + recon.log_dir;
  if (!results.extraction_note.empty()) {
    summary->note += std::string(summary->note.empty() ? "" : "; ") + results.extraction_note;
  }
  return recon;
}

}  // namespace

MethodEntry ColmapNavMethod() {
  MethodEntry m;
  m.name = kMethodColmapNav;
  m.summary = "COLMAP SIFT + point_triangulator, the nav poses held fixed";
  m.needs.colmap = ColmapNeed::kNav;
  m.run = [](const PairContext& ctx, std::vector<MethodRoi>* rois, MethodSummary* summary) {
    const PairReconstruction& recon = FillColmapMethod(ctx, /*nav=*/true, rois, summary);
    methods::PoseErrorAgainstTruth(recon, ctx, summary);
  };
  return m;
}

MethodEntry ColmapFreeMethod() {
  MethodEntry m;
  m.name = kMethodColmapFree;
  m.summary = "COLMAP SIFT + mapper, aligned to the local frame with the nav poses";
  m.needs.colmap = ColmapNeed::kFree;
  m.needs.pair_matches = true;
  m.run = [](const PairContext& ctx, std::vector<MethodRoi>* rois, MethodSummary* summary) {
    const PairReconstruction& recon = FillColmapMethod(ctx, /*nav=*/false, rois, summary);
    if (!ctx.Matches().empty()) {
      const ConfigurationReport& configuration = ctx.PairConfiguration();
      summary->note += std::string(summary->note.empty() ? "" : "; ") + "pair configuration: " +
                       configuration.reason;
      // With every frame of the window the views are no longer two:
      // a plane's two-fold ambiguity is resolved, and the ROIs keep their fits.
      if (!ctx.options().colmap.use_all_frames) WithholdIllConditioned(configuration, rois);
    }
    methods::PoseErrorAgainstTruth(recon, ctx, summary);
  };
  return m;
}

}  // namespace hdabench::reference
