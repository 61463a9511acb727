#include "core/sparse/sparse_layers.h"

#include <algorithm>
#include <stdexcept>
#include <utility>

namespace dfsm {

const std::vector<SparseLayerInfo>& SparseLayers() {
  static const std::vector<SparseLayerInfo> layers = {
      {SparseLayer::kFramesLeftOut, "frames-left-out",
       "a frame that would cut the tracks the others share by more than the bound",
       "the frames used (fewer), the tracks (more)", "features.max_frame_track_loss",
       [](const SparseOptions& o) { return o.features.max_frame_track_loss < 1.0; },
       [](SparseOptions* o) { o->features.max_frame_track_loss = 1.0; }},
      {SparseLayer::kAngularVelocity, "angular-velocity",
       "a rolling shutter: a known camera held, every adjustment under it (the line again "
       "where it leaves too few tracks in front); a burst's own calibration that is observed, "
       "its solution on the line refined (kept unless its calibration comes out degenerate "
       "or unusable)",
       "poses, inverse depths and each frame's angular velocity; a refined calibration",
       "angular_velocity_sigma_px",
       [](const SparseOptions& o) { return o.angular_velocity_sigma_px > 0.0; },
       [](SparseOptions* o) { o->angular_velocity_sigma_px = 0.0; }},
      {SparseLayer::kFocalStarts, "focal-starts",
       "self-calibration with the rank-1 start: each focal start after the first, probed",
       "the solution, where its truncated cost over every track is clearly lower", "focal_starts",
       [](const SparseOptions& o) { return o.focal_starts.size() > 1; },
       [](SparseOptions* o) { o->focal_starts.resize(1); }},
      {SparseLayer::kNaiveProbe, "naive-probe", "the rank-1 start: the naive start, probed",
       "the solution, as a focal start", "naive_probe",
       [](const SparseOptions& o) { return o.naive_probe; },
       [](SparseOptions* o) { o->naive_probe = false; }},
      {SparseLayer::kReadoutRestarts, "readout-restarts",
       "an estimated readout, where the first adjustment measured one",
       "the solution, where its median track error is lower", "readout_restarts",
       [](const SparseOptions& o) { return o.readout_restarts; },
       [](SparseOptions* o) { o->readout_restarts = false; }},
      {SparseLayer::kOutlierRounds, "outlier-rounds", "every solution that is settled",
       "the tracks kept, and the solution refitted on them", "outlier_rounds",
       [](const SparseOptions& o) { return o.outlier_rounds > 0; },
       [](SparseOptions* o) { o->outlier_rounds = 0; }},
      {SparseLayer::kReweight, "reweight", "the chosen solution",
       "poses and inverse depths (the camera held)", "reweight_rounds",
       [](const SparseOptions& o) { return o.reweight_rounds > 0; },
       [](SparseOptions* o) { o->reweight_rounds = 0; }},
      {SparseLayer::kMirroredRelief, "mirrored-relief",
       "every solution adjusted from its starts (a refinement with each frame's angular "
       "velocity starts from a solution checked, and is not checked again)",
       "the solution: replaced by the mirror's where it fits the tracks better", "mirrored_relief",
       [](const SparseOptions& o) { return o.mirrored_relief; },
       [](SparseOptions* o) { o->mirrored_relief = false; }},
      {SparseLayer::kLensRelief, "lens-relief", "self-calibration of k1 and k2",
       "nothing of the solution: the depth check's verdict", "measure_lens_relief",
       [](const SparseOptions& o) { return o.measure_lens_relief; },
       [](SparseOptions* o) { o->measure_lens_relief = false; }},
      {SparseLayer::kBootstrapBias, "bias",
       "the self-calibrated solution reported (the line's or its refinement; not a fallback's "
       "camera, nor one held under its mirrored relief), where its tracks' noise alone gives a "
       "sigma_f above bootstrap.min_sigma_f_percent",
       "nothing of this burst: its report, and the camera a fusion takes", "bootstrap.replicas",
       [](const SparseOptions& o) { return o.bootstrap.replicas > 0; },
       [](SparseOptions* o) { o->bootstrap.replicas = 0; }},
      {SparseLayer::kKnownFitCheck, "known-fit",
       "a known camera to check (KnownCalibration::check_fit): the burst calibrated alone first",
       "the verdict, and one more start under the known camera", "max_known_fit_ratio",
       [](const SparseOptions& o) { return o.max_known_fit_ratio > 0.0; },
       [](SparseOptions* o) { o->max_known_fit_ratio = 0.0; }},
      {SparseLayer::kUncheckedKnownRetry, "unchecked-known-retry",
       "a known camera not checked whose adjustment keeps too few of the tracks",
       "the solution: adjusted again with the burst's own as one more start",
       "min_known_inlier_share",
       [](const SparseOptions& o) { return o.min_known_inlier_share > 0.0; },
       [](SparseOptions* o) { o->min_known_inlier_share = 0.0; }},
  };
  return layers;
}

namespace {

const SparseLayerInfo& InfoOf(SparseLayer layer) {
  const std::vector<SparseLayerInfo>& layers = SparseLayers();
  return *std::find_if(layers.begin(), layers.end(),
                       [layer](const SparseLayerInfo& info) { return info.layer == layer; });
}

}  // namespace

const char* SparseLayerName(SparseLayer layer) { return InfoOf(layer).name; }

SparseLayer ParseSparseLayer(const std::string& name) {
  std::string names;
  for (const SparseLayerInfo& info : SparseLayers()) {
    if (name == info.name) return info.layer;
    names += std::string(names.empty() ? "" : ", ") + info.name;
  }
  throw std::invalid_argument("no sparse layer is called \"" + name + "\" (the layers: " + names +
                              ")");
}

bool UsesLayer(const SparseOptions& options, SparseLayer layer) {
  return InfoOf(layer).uses(options);
}

SparseOptions WithoutLayer(SparseOptions options, SparseLayer layer) {
  InfoOf(layer).switch_off(&options);
  return options;
}

SparseOptions WithoutLayers(SparseOptions options, const std::string& names) {
  size_t begin = 0;
  while (begin <= names.size()) {
    const size_t comma = std::min(names.find(',', begin), names.size());
    options =
        WithoutLayer(std::move(options), ParseSparseLayer(names.substr(begin, comma - begin)));
    begin = comma + 1;
  }
  return options;
}

}  // namespace dfsm
