// The sparse stage's layers: what runs beyond the paper's one start, one
// adjustment and its outlier rule, each the answer to a failure measured on
// some burst. They are listed here, in the order they run, with when each
// runs and what it may change, so that a maintainer reads the policy in one
// place and a bench can switch any of them off by name
// (`--without naive-probe,bias`) to measure what it earns on each witness
// (docs/experiments/138-sparse-layers.md). Each layer is switched by the
// SparseOptions field that configures it, read and written beside its
// entry in the list, so the options stay the one place of the fact.
#pragma once

#include <string>
#include <vector>

#include "core/sparse/sparse_reconstruction.h"

namespace dfsm {

enum class SparseLayer {
  kFramesLeftOut,        // frames the tracker lost, left out of the burst
  kAngularVelocity,      // frames turning at their own velocity under a pinned camera
  kFocalStarts,          // the focal starts after the first
  kNaiveProbe,           // the naive start beside the rank-1 ones
  kReadoutRestarts,      // restarts from other readouts where it is estimated
  kOutlierRounds,        // tracks judged again under the adjusted camera
  kReweight,             // tracks weighed by their own noise
  kMirroredRelief,       // the mirrored relief as one more start
  kLensRelief,           // the relief's shift under a k1-only lens model
  kBootstrapBias,        // the intrinsics' bias from the tracks' noise
  kKnownFitCheck,        // a known camera compared with the burst's own
  kUncheckedKnownRetry,  // the burst's own solution as a start, if needed
};

struct SparseLayerInfo {
  SparseLayer layer;
  const char* name;                            // as benches and logs spell it
  const char* runs_when;                       // the bursts it runs on
  const char* may_change;                      // what of the result it can change
  const char* option;                          // the SparseOptions field that switches it
  bool (*uses)(const SparseOptions& options);  // reads that field
  void (*switch_off)(SparseOptions* options);  // writes it
};

// Every layer, in the order the stage runs them.
const std::vector<SparseLayerInfo>& SparseLayers();

const char* SparseLayerName(SparseLayer layer);
// Throws std::invalid_argument listing the names where `name` is none.
SparseLayer ParseSparseLayer(const std::string& name);

// Whether `options` runs `layer` (on the bursts SparseLayerInfo::runs_when
// names).
bool UsesLayer(const SparseOptions& options, SparseLayer layer);
// `options` with `layer` off.
SparseOptions WithoutLayer(SparseOptions options, SparseLayer layer);
// `options` without each layer of a comma-separated list of names.
SparseOptions WithoutLayers(SparseOptions options, const std::string& names);

}  // namespace dfsm
