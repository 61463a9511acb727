// How the bundle adjustment starts, in a header of its own so that dfsmd's
// configuration (daemon/service/config.h) holds the enum without including
// the reconstruction and Eigen.
#pragma once

#include <string>

namespace dfsm {

enum class InitMode { kRankOne, kNaive };
InitMode ParseInitMode(const std::string& name);  // "rank1" | "naive"; throws std::invalid_argument
const char* InitModeName(InitMode mode);

}  // namespace dfsm
