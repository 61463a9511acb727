// The bursts `dfsm batch` is given: each named once in the batch, and split
// into deterministic shards for a cluster's array job.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace dfsm::tools {

// One burst of a batch: a dfsm-burst/1 directory, a burst.tar as dfsmd
// serves it, or a window of a video or of a folder or glob of images.
struct BatchItem {
  std::string name;   // its result is DIR/<name>/; unique in the batch
  std::string input;  // the path it is read from
  bool tar = false;   // `input` is a tar of a burst directory
  int start = 0;      // a window of a clip: skip `start`, then `frames` (0: all)
  int frames = 0;
  // Why the input cannot be cut into windows (a broken video in a directory
  // of bursts): the burst fails with it, the batch goes on.
  std::string error;
};

// Whether `path` is a .tar file (a burst as dfsmd serves it).
bool IsTarFile(const std::filesystem::path& path);

// The bursts `inputs` name, in name order. Each input is a burst directory
// (it holds manifest.json), a .tar file, a video, a folder or glob of images
// (a clip, cut into windows of `window_frames` where that is not 0), or a
// directory of bursts, tars, videos and dfsmd job directories (<job>/burst/
// or <job>/burst.tar), one level down. A burst is named after its directory,
// tar or video (dfsmd's bursts after their job), a window after its clip and
// first frame; a name taken twice (or the batch's own "calibration") gets its
// parent folder's name in front, then a number. Throws BurstError
// (core/io/burst.h) naming an input that holds no burst.
std::vector<BatchItem> ExpandBatchInputs(const std::vector<std::string>& inputs, int window_frames);

// The I-th of N shards (0 <= I < N).
struct Shard {
  int index = 0;
  int count = 1;
  bool whole() const { return count == 1; }
  std::string Suffix() const;  // "" for the whole batch, else ".shard-I-of-N"
};

// "I/N"; throws std::invalid_argument naming what is wrong.
Shard ParseShard(const std::string& text);

// The items of `shard`: of the batch in name order, every N-th from the I-th,
// so that every shard gets bursts of every part of the input alike.
std::vector<BatchItem> ItemsOfShard(const std::vector<BatchItem>& items, const Shard& shard);

}  // namespace dfsm::tools
