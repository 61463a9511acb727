#include "core/sparse/sparse_layers.h"

#include <algorithm>
#include <stdexcept>
#include <utility>

namespace dfsm {

const std::vector<SparseLayerInfo>& SparseLayers() {
  static const std::vector<SparseLayerInfo> layers = {
      {SparseLayer::kFocalStarts, "focal-starts",
       "self-calibration with the rank-1 start: each focal start after the first, probed",
       "the solution, where its truncated cost over every track is clearly lower", "focal_starts"},
      {SparseLayer::kNaiveProbe, "naive-probe", "the rank-1 start: the naive start, probed",
       "the solution, as a focal start", "naive_probe"},
      {SparseLayer::kReadoutRestarts, "readout-restarts",
       "an estimated readout, where the first adjustment measured one",
       "the solution, where its median track error is lower", "readout_restarts"},
      {SparseLayer::kOutlierRounds, "outlier-rounds", "every solution that is settled",
       "the tracks kept, and the solution refitted on them", "outlier_rounds"},
      {SparseLayer::kReweight, "reweight", "the chosen solution",
       "poses and inverse depths (the camera held)", "reweight_rounds"},
      {SparseLayer::kBootstrapBias, "bias",
       "self-calibration whose tracks' noise alone gives a sigma_f above "
       "bootstrap.min_sigma_f_percent",
       "nothing of this burst: its report, and the camera a fusion takes", "bootstrap.replicas"},
      {SparseLayer::kLensRelief, "lens-relief", "self-calibration of k1 and k2",
       "nothing of the solution: the depth check's verdict", "measure_lens_relief"},
      {SparseLayer::kKnownFitCheck, "known-fit",
       "a known camera to check (KnownCalibration::check_fit): the burst calibrated alone first",
       "the verdict, and one more start under the known camera", "max_known_fit_ratio"},
      {SparseLayer::kUncheckedKnownRetry, "unchecked-known-retry",
       "a known camera not checked whose adjustment keeps too few of the tracks",
       "the solution: adjusted again with the burst's own as one more start",
       "min_known_inlier_share"},
  };
  return layers;
}

const char* SparseLayerName(SparseLayer layer) {
  for (const SparseLayerInfo& info : SparseLayers())
    if (info.layer == layer) return info.name;
  return "?";
}

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
  switch (layer) {
    case SparseLayer::kFocalStarts:
      return options.focal_starts.size() > 1;
    case SparseLayer::kNaiveProbe:
      return options.naive_probe;
    case SparseLayer::kReadoutRestarts:
      return options.readout_restarts;
    case SparseLayer::kOutlierRounds:
      return options.outlier_rounds > 0;
    case SparseLayer::kReweight:
      return options.reweight_rounds > 0;
    case SparseLayer::kBootstrapBias:
      return options.bootstrap.replicas > 0;
    case SparseLayer::kLensRelief:
      return options.measure_lens_relief;
    case SparseLayer::kKnownFitCheck:
      return options.max_known_fit_ratio > 0.0;
    case SparseLayer::kUncheckedKnownRetry:
      return options.min_known_inlier_share > 0.0;
  }
  return false;
}

SparseOptions WithoutLayer(SparseOptions options, SparseLayer layer) {
  switch (layer) {
    case SparseLayer::kFocalStarts:
      options.focal_starts.resize(1);
      break;
    case SparseLayer::kNaiveProbe:
      options.naive_probe = false;
      break;
    case SparseLayer::kReadoutRestarts:
      options.readout_restarts = false;
      break;
    case SparseLayer::kOutlierRounds:
      options.outlier_rounds = 0;
      break;
    case SparseLayer::kReweight:
      options.reweight_rounds = 0;
      break;
    case SparseLayer::kBootstrapBias:
      options.bootstrap.replicas = 0;
      break;
    case SparseLayer::kLensRelief:
      options.measure_lens_relief = false;
      break;
    case SparseLayer::kKnownFitCheck:
      options.max_known_fit_ratio = 0.0;
      break;
    case SparseLayer::kUncheckedKnownRetry:
      options.min_known_inlier_share = 0.0;
      break;
  }
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
