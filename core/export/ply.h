// Binary little-endian PLY point clouds with optional per-point colour.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <vector>

#include "core/io/file_util.h"

namespace dfsm {

struct ColoredPoint {
  Eigen::Vector3f position;
  uint8_t r = 255, g = 255, b = 255;
};

// Writes atomically (file_util.h: `flush`); throws std::runtime_error naming
// the path on failure.
void WritePly(const std::filesystem::path& path, const std::vector<ColoredPoint>& points,
              Flush flush = Flush::kEach);

}  // namespace dfsm
