#include "daemon/service/tar_writer.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>

#include "core/io/file_util.h"
#include "daemon/service/tar_extract.h"

namespace dfsm::service {
namespace {

namespace fs = std::filesystem;

class TarWriterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "burst" / "frames");
    std::string big(300000, '\0');  // more than one piece
    for (size_t i = 0; i < big.size(); ++i) big[i] = static_cast<char>(i * 7 + 3);
    WriteFileAtomically(dir_ / "burst" / "manifest.json", "{}");
    WriteFileAtomically(dir_ / "burst" / "frames" / "000000.png", big);
    WriteFileAtomically(dir_ / "burst" / "frames" / "empty.png", "");
    WriteFileAtomically(dir_ / "burst" / "frames" / std::string(150, 'n'), "long name");
  }
  void TearDown() override { fs::remove_all(dir_); }

  const fs::path dir_ =
      fs::temp_directory_path() / ("dfsm-tar-writer-" + std::to_string(::getpid()));
};

TEST_F(TarWriterTest, StreamsInPiecesWhatTarReads) {
  DirectoryTar stream(dir_ / "burst");
  std::string streamed;
  size_t largest = 0;
  for (std::string piece = stream.Next(); !piece.empty(); piece = stream.Next()) {
    largest = std::max(largest, piece.size());
    streamed += piece;
  }
  EXPECT_TRUE(stream.Next().empty());
  EXPECT_LE(largest, 300u << 10) << "a piece, not the burst";
  // What it writes extracts to the same files.
  fs::create_directories(dir_ / "out");
  ExtractTar(streamed, dir_ / "out", {});
  size_t files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir_ / "burst")) {
    if (!entry.is_regular_file()) continue;
    ++files;
    const fs::path copy = dir_ / "out" / entry.path().lexically_relative(dir_ / "burst");
    EXPECT_EQ(ReadFileToString(copy), ReadFileToString(entry.path())) << copy;
  }
  EXPECT_EQ(files, 4u);
  EXPECT_NE(streamed.find("path=frames/" + std::string(150, 'n')), std::string::npos)
      << "a pax header for the long name";
  // GNU tar reads it too, long name included.
  if (std::system("command -v tar >/dev/null 2>&1") != 0) GTEST_SKIP() << "no tar program";
  WriteFileAtomically(dir_ / "b.tar", streamed);
  fs::create_directories(dir_ / "tar");
  ASSERT_EQ(
      std::system(
          ("tar -C " + (dir_ / "tar").string() + " -xf " + (dir_ / "b.tar").string()).c_str()),
      0);
  EXPECT_EQ(ReadFileToString(dir_ / "tar" / "frames" / std::string(150, 'n')), "long name");
}

// A file that shrank after its header was sent is an error, not silent zeros.
TEST_F(TarWriterTest, AFileThatShrankIsAnError) {
  DirectoryTar stream(dir_ / "burst");
  EXPECT_EQ(stream.Next().size(), 512u);  // the header of frames/000000.png
  fs::resize_file(dir_ / "burst" / "frames" / "000000.png", 5);
  EXPECT_THROW(
      {
        while (!stream.Next().empty()) {
        }
      },
      TarError);
}

}  // namespace
}  // namespace dfsm::service
