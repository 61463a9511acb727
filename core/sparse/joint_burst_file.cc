#include "core/sparse/joint_burst_file.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/camera/rolling_shutter.h"
#include "core/io/file_util.h"

namespace dfsm {
namespace {

// The whole file is at most this large: 64 MiB holds 8192 tracks over 256
// frames several times over.
constexpr size_t kMaxFileBytes = 64u << 20;

class FileError {
 public:
  explicit FileError(const std::filesystem::path& path) : path_(path.string()) {}
  [[noreturn]] void operator()(const std::string& problem) const {
    throw std::runtime_error("tracks file " + path_ + ": " + problem);
  }

 private:
  std::string path_;
};

// `list`, `size` finite numbers (any size where `size` < 0), named `what`.
std::vector<double> Numbers(const nlohmann::json& list, const std::string& what, long size,
                            const FileError& refuse) {
  if (!list.is_array()) refuse(what + " is not a list");
  if (size >= 0 && list.size() != static_cast<size_t>(size))
    refuse(what + " holds " + std::to_string(list.size()) + " numbers, not " +
           std::to_string(size));
  std::vector<double> values;
  values.reserve(list.size());
  for (const nlohmann::json& value : list) {
    if (!value.is_number() || !std::isfinite(value.get<double>()))
      refuse(what + " holds something other than a finite number");
    values.push_back(value.get<double>());
  }
  return values;
}

const nlohmann::json& Member(const nlohmann::json& j, const char* key, const FileError& refuse) {
  if (!j.contains(key)) refuse(std::string("no \"") + key + "\"");
  return j[key];
}

double Number(const nlohmann::json& j, const char* key, const FileError& refuse) {
  if (!j.contains(key) || !j[key].is_number() || !std::isfinite(j[key].get<double>()))
    refuse(std::string("no finite number \"") + key + "\"");
  return j[key].get<double>();
}

int Count(const nlohmann::json& j, const char* key, int least, int most, const FileError& refuse) {
  if (!j.contains(key) || !j[key].is_number_integer() || j[key].get<int64_t>() < least ||
      j[key].get<int64_t>() > most)
    refuse(std::string("\"") + key + "\" is not a whole number in [" + std::to_string(least) +
           ", " + std::to_string(most) + "]");
  return static_cast<int>(j[key].get<int64_t>());
}

}  // namespace

void WriteJointBurst(const std::filesystem::path& path, const JointBurst& burst) {
  const FeatureTracks& tracks = burst.tracks;
  const SparseState& state = burst.state;
  nlohmann::json j = {{"format", kJointBurstFormat},
                      {"width", state.camera.width},
                      {"height", state.camera.height},
                      {"reference", tracks.reference},
                      {"camera",
                       {{"f", state.camera.f},
                        {"cx", state.camera.cx},
                        {"cy", state.camera.cy},
                        {"k1", state.camera.k1},
                        {"k2", state.camera.k2}}},
                      {"readout", state.readout},
                      {"frame_times", state.frame_times},
                      {"inverse_depths", state.inverse_depths},
                      {"noise_px", burst.noise_px},
                      {"sigma_f_percent", burst.sigma_f_percent}};
  nlohmann::json poses = nlohmann::json::array(), pixels = nlohmann::json::array();
  for (int i = 0; i < tracks.num_frames(); ++i) {
    const PoseParameters pose = ToPoseParameters(state.poses[i]);
    poses.push_back(std::vector<double>(pose.data(), pose.data() + 6));
    pixels.push_back(std::vector<double>(tracks.pixels[i].data(),
                                         tracks.pixels[i].data() + tracks.pixels[i].size()));
  }
  j["poses"] = std::move(poses);
  j["pixels"] = std::move(pixels);
  j["use"] = std::vector<int>(burst.use.begin(), burst.use.end());
  WriteFileAtomically(path, nlohmann::json::to_cbor(j));
}

JointBurst ReadJointBurst(const std::filesystem::path& path) {
  const FileError refuse(path);
  std::error_code error;
  const uintmax_t bytes = std::filesystem::file_size(path, error);
  if (error) refuse("unreadable: " + error.message());
  if (bytes > kMaxFileBytes) refuse("larger than " + std::to_string(kMaxFileBytes) + " bytes");
  const std::string data = ReadFileToString(path);
  const nlohmann::json j = nlohmann::json::from_cbor(data, true, false);
  if (j.is_discarded() || !j.is_object()) refuse("not a CBOR map");
  if (j.value("format", "") != kJointBurstFormat)
    refuse(std::string("not of format ") + kJointBurstFormat);
  JointBurst burst;
  burst.name = path.string();
  CameraModel& camera = burst.state.camera;
  camera.width = Count(j, "width", 1, 1 << 16, refuse);
  camera.height = Count(j, "height", 1, 1 << 16, refuse);
  if (!j.contains("camera") || !j["camera"].is_object()) refuse("no map \"camera\"");
  camera.f = Number(j["camera"], "f", refuse);
  camera.cx = Number(j["camera"], "cx", refuse);
  camera.cy = Number(j["camera"], "cy", refuse);
  camera.k1 = Number(j["camera"], "k1", refuse);
  camera.k2 = Number(j["camera"], "k2", refuse);
  if (!(camera.f > 0.0)) refuse("the focal length is not positive");
  burst.state.readout = Number(j, "readout", refuse);
  burst.noise_px = Number(j, "noise_px", refuse);
  burst.sigma_f_percent = Number(j, "sigma_f_percent", refuse);
  const nlohmann::json& pixels = Member(j, "pixels", refuse);
  if (!pixels.is_array() || pixels.size() < 2 || pixels.size() > 4096)
    refuse("\"pixels\" is not a list of 2 to 4096 frames");
  const int frames = static_cast<int>(pixels.size());
  FeatureTracks& tracks = burst.tracks;
  tracks.reference = Count(j, "reference", 0, frames - 1, refuse);
  burst.state.inverse_depths =
      Numbers(Member(j, "inverse_depths", refuse), "\"inverse_depths\"", -1, refuse);
  const long m = static_cast<long>(burst.state.inverse_depths.size());
  if (m < 1) refuse("it holds no track");
  for (int i = 0; i < frames; ++i) {
    const std::string what = "frame " + std::to_string(i) + "'s pixels";
    const std::vector<double> frame = Numbers(pixels[i], what, 2 * m, refuse);
    tracks.pixels.push_back(Eigen::Map<const Eigen::Matrix2Xd>(frame.data(), 2, m));
  }
  const nlohmann::json& poses = Member(j, "poses", refuse);
  if (!poses.is_array() || poses.size() != static_cast<size_t>(frames))
    refuse("\"poses\" does not hold one pose per frame");
  for (int i = 0; i < frames; ++i) {
    const std::vector<double> pose = Numbers(poses[i], "pose " + std::to_string(i), 6, refuse);
    burst.state.poses.push_back(FromPoseParameters(Eigen::Map<const PoseParameters>(pose.data())));
  }
  const nlohmann::json& times = Member(j, "frame_times", refuse);
  burst.state.frame_times = Numbers(times, "\"frame_times\"", times.empty() ? 0 : frames, refuse);
  for (size_t i = 1; i < burst.state.frame_times.size(); ++i)
    if (!(burst.state.frame_times[i] > burst.state.frame_times[i - 1]))
      refuse("\"frame_times\" do not increase");
  const std::vector<double> use = Numbers(Member(j, "use", refuse), "\"use\"", m, refuse);
  for (const double flag : use) burst.use.push_back(flag != 0.0);
  if (CountUsed(burst.use) < 1) refuse("no track is used");
  return burst;
}

}  // namespace dfsm
