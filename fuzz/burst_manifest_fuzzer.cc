// Fuzzes the dfsm-burst/1 manifest reader (core/io/burst.h), which reads
// manifest.json from uploads and replay directories. Bad input must be
// rejected with a BurstError that names the problem; an accepted manifest
// must satisfy what CONTRACT.md promises and survive a write/read round trip.
#include <cstddef>
#include <cstdint>

#include "core/io/burst.h"
#include "fuzz/fuzz_check.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  dfsm::BurstManifest manifest;
  try {
    manifest = dfsm::ParseBurstManifest(dfsm::fuzz::AsText(data, size), "manifest.json");
  } catch (const dfsm::BurstError& error) {
    dfsm::fuzz::CheckNamedError(error);
    return 0;
  }
  FUZZ_CHECK(manifest.width > 0 && manifest.height > 0, "accepted a non-positive size");
  FUZZ_CHECK(manifest.frames.size() >= 3, "accepted fewer than 3 frames");
  FUZZ_CHECK(
      manifest.reference >= 0 && static_cast<size_t>(manifest.reference) < manifest.frames.size(),
      "accepted a reference outside the frames");
  FUZZ_CHECK(manifest.pixel_format == "gray8" || manifest.pixel_format == "bgr8",
             "accepted pixel_format " + manifest.pixel_format);
  for (const dfsm::BurstFrameInfo& frame : manifest.frames) {
    FUZZ_CHECK(!frame.file.empty(), "accepted a frame without a file");
  }

  // What the daemon writes back (WriteBurst) must read back the same.
  const dfsm::BurstManifest again =
      dfsm::ParseBurstManifest(dfsm::ToJson(manifest).dump(), "round trip");
  FUZZ_CHECK(again.width == manifest.width && again.height == manifest.height &&
                 again.pixel_format == manifest.pixel_format &&
                 again.reference == manifest.reference &&
                 again.frames.size() == manifest.frames.size() && again.source == manifest.source,
             "the manifest changed in a round trip");
  for (size_t i = 0; i < manifest.frames.size(); ++i) {
    FUZZ_CHECK(again.frames[i].file == manifest.frames[i].file &&
                   again.frames[i].timestamp_ns == manifest.frames[i].timestamp_ns &&
                   again.frames[i].sequence == manifest.frames[i].sequence,
               "frame " + std::to_string(i) + " changed in a round trip");
  }
  return 0;
}
