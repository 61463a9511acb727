#include "tools/dfsm/video_input.h"

#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <mutex>

#include "tools/dfsm/video/video_module.h"

#ifndef DFSM_VIDEO_MODULE_DIR
#define DFSM_VIDEO_MODULE_DIR ""
#endif
#ifndef DFSM_VIDEO_MODULE_LIBDIR
#define DFSM_VIDEO_MODULE_LIBDIR "lib"
#endif

namespace dfsm::tools {
namespace fs = std::filesystem;
namespace {

constexpr const char* kModuleName = "dfsm-video.so";
// Frame intervals that differ by more than this share of the median are a
// variable frame rate: the pipeline takes the frames as evenly spaced.
constexpr double kMaxIntervalDeviation = 0.25;
constexpr double kTimeBaseMs = 1.0;
// A video read whole (no --frames) longer than this is refused: a burst is
// 10-30 frames, and every frame read is held in memory.
constexpr int kMaxWholeVideoFrames = 120;

// Where the module is: $DFSM_VIDEO_MODULE (which must then exist), else
// beside the running binary (a build tree), else in the install's library
// directory, relative to the binary first (an install moved or made with
// --prefix), then where it was configured.
std::vector<fs::path> ModuleCandidates(const std::string& input) {
  if (const char* path = std::getenv("DFSM_VIDEO_MODULE"); path && *path) {
    const fs::path module = fs::absolute(path);
    std::error_code error;
    if (!fs::exists(module, error))
      throw BurstError("'" + input + "': $DFSM_VIDEO_MODULE names " + module.string() +
                       ", which does not exist");
    return {module};
  }
  std::vector<fs::path> candidates;
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  if (!error) {
    candidates.push_back(self.parent_path() / kModuleName);
    candidates.push_back(self.parent_path().parent_path() / DFSM_VIDEO_MODULE_LIBDIR / "dfsm" /
                         kModuleName);
  }
  if (*DFSM_VIDEO_MODULE_DIR) candidates.push_back(fs::path(DFSM_VIDEO_MODULE_DIR) / kModuleName);
  return candidates;
}

ReadVideoFunction LoadModule(const std::string& input) {
  static std::mutex mutex;
  static ReadVideoFunction function = nullptr;
  std::lock_guard<std::mutex> lock(mutex);
  if (function) return function;
  std::string failures;
  for (const fs::path& candidate : ModuleCandidates(input)) {
    std::error_code error;
    if (!fs::exists(candidate, error)) continue;
    void* module = dlopen(candidate.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!module) {
      failures += std::string("; cannot load ") + candidate.string() + ": " + dlerror();
      continue;
    }
    function = reinterpret_cast<ReadVideoFunction>(dlsym(module, kReadVideoSymbol));
    if (function) return function;
    failures += "; " + candidate.string() + " is of another build (no " + kReadVideoSymbol + ")";
    dlclose(module);
  }
  throw BurstError("'" + input + "': the video module " + kModuleName +
                   (failures.empty() ? std::string(" is not installed") : failures) +
                   "; extract the frames instead (ffmpeg -i " + input + " frames/%04d.png)");
}

VideoFrames Read(const std::string& input, const VideoReadRequest& request) {
  const ReadVideoFunction read = LoadModule(input);  // throws where there is none
  VideoFrames frames;
  read(input.c_str(), &request, &frames);
  if (!frames.error.empty()) throw BurstError("'" + input + "': " + frames.error);
  return frames;
}

// Refuses a variable frame rate: the pipeline takes the frames as evenly
// spaced. Intervals may differ from their median by a quarter of it, or by a
// millisecond (the 1 ms time base of WebM and Matroska); a video whose frames
// carry no times is taken as evenly spaced.
void CheckFrameRate(const std::string& input, const std::vector<int64_t>& timestamps_ns) {
  std::vector<double> intervals;
  for (size_t i = 1; i < timestamps_ns.size(); ++i)
    intervals.push_back(static_cast<double>(timestamps_ns[i] - timestamps_ns[i - 1]) * 1e-6);
  if (intervals.empty()) return;
  std::vector<double> sorted = intervals;
  std::sort(sorted.begin(), sorted.end());
  if (sorted.front() == 0.0 && sorted.back() == 0.0) return;
  const double median = sorted[sorted.size() / 2];
  const double tolerance = std::max(kMaxIntervalDeviation * median, kTimeBaseMs);
  if (median > 0.0 && sorted.front() >= median - tolerance && sorted.back() <= median + tolerance)
    return;
  char text[200];
  std::snprintf(text, sizeof text,
                "variable frame rate: frames %.1f to %.1f ms apart (median %.1f ms); extract "
                "them at a constant rate (ffmpeg -i VIDEO -vsync cfr frames/%%04d.png)",
                sorted.front(), sorted.back(), median);
  throw BurstError("'" + input + "': " + text);
}

}  // namespace

bool IsVideoFile(const std::string& input) {
  static const std::vector<std::string> kExtensions = {".mp4", ".mov",  ".m4v", ".mkv",
                                                       ".avi", ".webm", ".mts", ".3gp"};
  std::string extension = fs::path(input).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  std::error_code error;
  return std::find(kExtensions.begin(), kExtensions.end(), extension) != kExtensions.end() &&
         fs::is_regular_file(input, error);
}

int CountVideoFrames(const std::string& input) {
  VideoReadRequest request;
  request.count_only = true;
  return Read(input, request).total;
}

Burst ReadVideoBurst(const std::string& input, int start, int frames) {
  VideoReadRequest request;
  request.start = start;
  request.frames = frames;
  request.max_frames = kMaxWholeVideoFrames;
  VideoFrames video = Read(input, request);
  const int count = static_cast<int>(video.gray.size());
  if (count < 3 || (frames > 0 && count < frames))
    throw BurstError("'" + input + "': " + std::to_string(count) + " frames from frame " +
                     std::to_string(start) +
                     (frames > 0 ? ", " + std::to_string(frames) + " were asked for"
                                 : "; a burst needs at least 3"));
  CheckFrameRate(input, video.timestamps_ns);
  Burst burst;
  BurstManifest& manifest = burst.manifest;
  manifest.width = video.gray.front().cols;
  manifest.height = video.gray.front().rows;
  manifest.pixel_format = "bgr8";
  manifest.reference = 0;
  for (int i = 0; i < count; ++i) {
    BurstFrameInfo info;
    info.file = fs::path(input).filename().string() + "#" + std::to_string(start + i);
    info.sequence = start + i;
    info.timestamp_ns = video.timestamps_ns[i];
    manifest.frames.push_back(info);
  }
  manifest.source = {{"driver", "video"}, {"input", input}, {"fps", video.fps}};
  burst.gray = std::move(video.gray);
  burst.reference_color = video.first_bgr;
  return burst;
}

}  // namespace dfsm::tools
