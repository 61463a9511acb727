// How a burst's rolling shutter is known (core/camera/rolling_shutter.h has
// the model). No Eigen here: the daemon's configuration includes it beside
// cpp-httplib, which Eigen must not follow.
#pragma once

#include <string>

namespace dfsm {

// The readout limits the options and the adjustment share. A known readout is
// in [0, kMaxReadout]; an estimated one may come out negative, a sensor read
// from the bottom row up (a camera mounted upside down, a clip turned over).
inline constexpr double kMaxReadout = 1.0;

// How a burst's rolling shutter is known.
struct RollingShutterOptions {
  enum class Mode {
    kGlobal,    // every row at once (readout 0)
    kKnown,     // `readout` as given (a datasheet, an earlier estimate)
    kEstimate,  // the adjustment estimates it, in [-kMaxReadout, kMaxReadout]
  };
  // Estimated unless told: phones and most webcams read out row by row, and a
  // global shutter's burst estimates a readout of ~0 at no loss of accuracy
  // (docs/experiments/113-rolling-shutter.md); it costs ~0.2 s of adjustment
  // at 1080p.
  Mode mode = Mode::kEstimate;
  double readout = 0.0;  // kKnown: the readout; otherwise unused

  void Check() const;  // throws std::invalid_argument naming the problem
};

// The text of the default, for option tables and help texts.
inline constexpr const char* kDefaultRollingShutter = "estimate";

// "global" | "estimate" | a readout in [0, 1] (a number: known). Throws
// std::invalid_argument naming the accepted forms.
RollingShutterOptions ParseRollingShutter(const std::string& text);
std::string RollingShutterName(const RollingShutterOptions& options);  // the form Parse reads

}  // namespace dfsm
