// A burst from the footage people have: a folder of images, or a glob of
// them ("clip/*.jpg"), in name order, instead of a dfsm-burst/1 directory.
// Frames are PNG or JPEG, decoded as a burst's are; the reference is the
// first frame read, the frame times consecutive, and a JPEG reference's EXIF
// focal length is a prior as in a burst.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "core/io/burst.h"

namespace dfsm {

struct ImageSequenceOptions {
  int start = 0;   // skip this many images first
  int frames = 0;  // read this many from there (0: all)

  // Throws std::invalid_argument naming the option out of its range.
  void Check() const;
};

// Whether `input` names an image sequence rather than a burst: a directory
// without manifest.json, or a glob (* or ? in its last part).
bool IsImageSequence(const std::string& input);

// The images of `input` in name order, digit runs compared as numbers
// ("frame2.png" before "frame10.png"). Throws BurstError naming the input
// when there is none.
std::vector<std::filesystem::path> ListImageSequence(const std::string& input);

// Throws BurstError naming the file and the problem (too few images, mixed
// sizes, an undecodable file).
Burst ReadImageSequence(const std::string& input, const ImageSequenceOptions& options);

}  // namespace dfsm
