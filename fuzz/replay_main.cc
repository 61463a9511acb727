// The main of the <name>_replay programs (builds without libFuzzer): feeds
// every file of the directories (or files) named on the command line to the
// harness's LLVMFuzzerTestOneInput, so the committed seeds and crash
// regressions are checked by every build. A missing directory is skipped (a
// harness with no crash yet has no regressions); no input at all fails.
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

namespace {

namespace fs = std::filesystem;

std::vector<fs::path> InputsOf(const fs::path& path) {
  std::vector<fs::path> inputs;
  if (fs::is_regular_file(path)) {
    inputs.push_back(path);
  } else if (fs::is_directory(path)) {
    for (const auto& entry : fs::directory_iterator(path)) {
      if (entry.is_regular_file()) inputs.push_back(entry.path());
    }
  }
  std::sort(inputs.begin(), inputs.end());
  return inputs;
}

}  // namespace

int main(int argc, char** argv) {
  size_t replayed = 0;
  for (int i = 1; i < argc; ++i) {
    for (const fs::path& input : InputsOf(argv[i])) {
      std::ifstream in(input, std::ios::binary);
      const std::string bytes((std::istreambuf_iterator<char>(in)),
                              std::istreambuf_iterator<char>());
      if (!in.good() && !in.eof()) {
        std::cerr << input.string() << ": cannot read\n";
        return 1;
      }
      std::cerr << "replay " << input.string() << " (" << bytes.size() << " bytes)\n";
      // A copy of exactly the input's size, so a sanitizer sees reads past its end.
      std::vector<uint8_t> copy(bytes.begin(), bytes.end());
      LLVMFuzzerTestOneInput(copy.data(), copy.size());
      ++replayed;
    }
  }
  std::cerr << "replayed " << replayed << " inputs\n";
  if (replayed == 0) {
    std::cerr << "no inputs found: the seed corpus is missing\n";
    return 1;
  }
  return 0;
}
