#include "core/export/ply.h"

#include <cstring>
#include <string>

#include "core/io/file_util.h"

namespace dfsm {

void WritePly(const std::filesystem::path& path, const std::vector<ColoredPoint>& points,
              Flush flush) {
  std::string data =
      "ply\nformat binary_little_endian 1.0\ncomment written by dfsm\nelement vertex " +
      std::to_string(points.size()) +
      "\nproperty float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n";
  const size_t header = data.size();
  constexpr size_t kStride = 3 * sizeof(float) + 3;
  data.resize(header + points.size() * kStride);
  char* out = data.data() + header;
  // PLY binary_little_endian: every target of ours is little-endian.
  static_assert(sizeof(float) == 4);
  for (const ColoredPoint& point : points) {
    std::memcpy(out, point.position.data(), 3 * sizeof(float));
    out[12] = static_cast<char>(point.r);
    out[13] = static_cast<char>(point.g);
    out[14] = static_cast<char>(point.b);
    out += kStride;
  }
  WriteFileAtomically(path, data, flush);
}

}  // namespace dfsm
