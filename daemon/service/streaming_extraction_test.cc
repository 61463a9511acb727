#include "daemon/service/streaming_extraction.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <map>

#include "core/io/file_util.h"
#include "daemon/service/tar_writer.h"

namespace dfsm::service {
namespace {

namespace fs = std::filesystem;

class StreamingExtractionTest : public ::testing::Test {
 protected:
  void SetUp() override { fs::remove_all(dir_); }
  void TearDown() override { fs::remove_all(dir_); }

  // A tar of `files` (name -> contents), as GET .../burst.tar writes it.
  std::string Tar(const std::map<std::string, std::string>& files) {
    const fs::path src = dir_.string() + "-src";
    for (const auto& [name, data] : files) {
      fs::create_directories((src / name).parent_path());
      WriteFileAtomically(src / name, data);
    }
    DirectoryTar tar(src);
    std::string archive;
    for (std::string piece = tar.Next(); !piece.empty(); piece = tar.Next()) archive += piece;
    fs::remove_all(src);
    return archive;
  }

  // Writes `archive` in pieces of `piece` bytes, as httplib hands them over.
  static void WriteInPieces(StreamingExtraction* extraction, const std::string& archive,
                            size_t piece) {
    for (size_t at = 0; at < archive.size(); at += piece)
      extraction->Write(archive.data() + at, std::min(piece, archive.size() - at));
  }

  const fs::path dir_ =
      fs::temp_directory_path() / ("dfsm-streaming-extraction-" + std::to_string(::getpid()));
};

// More than the pipe holds (64 KiB), so writing waits on the extraction.
TEST_F(StreamingExtractionTest, ExtractsWhileTheArchiveArrives) {
  const std::string big(1 << 20, 'f');
  const std::string archive = Tar({{"burst/manifest.json", "{}"}, {"burst/f.bin", big}});
  for (const size_t piece : {size_t{1000}, size_t{1} << 20}) {
    {
      StreamingExtraction extraction(dir_, {});
      WriteInPieces(&extraction, archive + std::string(10000, 'z'), piece);  // trailing junk
      extraction.Finish();
    }
    EXPECT_EQ(ReadFileToString(dir_ / "burst" / "f.bin"), big);
    fs::remove_all(dir_);
  }
}

// The body is still read to its end after the archive was refused, and the
// error is the archive's.
TEST_F(StreamingExtractionTest, AnErrorWaitsForTheEndOfTheBody) {
  TarLimits limits;
  limits.max_file_bytes = 1000;
  StreamingExtraction extraction(dir_, limits);
  WriteInPieces(&extraction, Tar({{"f.bin", std::string(4 << 20, 'f')}}), 64 << 10);
  try {
    extraction.Finish();
    FAIL() << "accepted";
  } catch (const TarError& e) {
    EXPECT_NE(std::string(e.what()).find("exceeds the limit of 1000"), std::string::npos);
  }
  EXPECT_FALSE(fs::exists(dir_ / "f.bin"));
}

// A body that ended early (the client went away): dropping the extraction
// ends its thread.
TEST_F(StreamingExtractionTest, DroppedMidArchive) {
  const std::string archive = Tar({{"f.bin", std::string(1 << 20, 'f')}});
  {
    StreamingExtraction extraction(dir_, {});
    WriteInPieces(&extraction, archive.substr(0, archive.size() / 2), 4096);
  }
  StreamingExtraction again(dir_ / "again", {});
  WriteInPieces(&again, archive.substr(0, archive.size() / 2), 4096);
  EXPECT_THROW(again.Finish(), TarError);
}

}  // namespace
}  // namespace dfsm::service
