// The files of the web page (www/ in the source tree), compiled into dfsmd by
// api/CMakeLists.txt; served at / (index.html) and /ui/<path> (routes.cc).
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace dfsm::api {

struct WwwFile {
  std::string path;  // relative to www/, '/'-separated: "index.html", "vendor/three.module.min.js"
  std::string_view data;
};

// Every file, sorted by path. Empty when the tree has no www/.
const std::vector<WwwFile>& WwwFiles();

}  // namespace dfsm::api
