#include "daemon/service/tar_extract.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <utility>
#include <vector>

#include "core/io/file_util.h"
#include "daemon/service/tar_writer.h"

namespace dfsm::service {
namespace {

namespace fs = std::filesystem;

class TarExtractTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A new empty directory to extract into.
  fs::path Fresh() {
    const fs::path out = dir_ / ("out" + std::to_string(next_++));
    fs::create_directories(out);
    return out;
  }
  std::string ErrorOf(std::string_view archive, const TarLimits& limits = {}) {
    try {
      ExtractTar(archive, Fresh(), limits);
    } catch (const TarError& e) {
      return e.what();
    }
    return "";
  }
  bool HasTar() { return std::system("command -v tar >/dev/null 2>&1") == 0; }
  // `tar -cf` of `what` under dir_ with `options`, read back.
  std::string Tar(const std::string& options, const std::string& what) {
    const fs::path file = dir_ / "made.tar";
    const std::string command =
        "tar -C " + dir_.string() + " " + options + " -cf " + file.string() + " " + what;
    EXPECT_EQ(std::system(command.c_str()), 0) << command;
    return ReadFileToString(file);
  }

  const fs::path dir_ =
      fs::temp_directory_path() / ("dfsm-tar-extract-" + std::to_string(::getpid()));
  int next_ = 0;
};

// Rewrites the checksum of the header at `offset` after a test edited it.
void FixChecksum(std::string* archive, size_t offset) {
  char* header = archive->data() + offset;
  std::memset(header + 148, ' ', 8);
  unsigned sum = 0;
  for (int i = 0; i < 512; ++i) sum += static_cast<unsigned char>(header[i]);
  std::snprintf(header + 148, 8, "%06o", sum);
}

using Files = std::vector<std::pair<std::string, std::string>>;  // name, data

// A ustar archive of regular files written by hand, so that any name, however
// hostile, can be put in it (dfsmd's writer only tars a directory).
std::string Ustar(const Files& files) {
  std::string archive;
  for (const auto& [name, data] : files) {
    std::string header(512, '\0');
    const auto octal = [&header](size_t at, int digits, uint64_t value) {
      std::ostringstream text;
      text << std::oct << std::setw(digits) << std::setfill('0') << value;
      text.str().copy(&header[at], static_cast<size_t>(digits));
    };
    name.copy(&header[0], 100);
    octal(100, 7, 0644);  // mode
    octal(124, 11, data.size());
    octal(136, 11, 0);  // mtime
    header[156] = '0';
    header.replace(257, 8,
                   std::string("ustar\0"
                               "00",
                               8));
    archive += header;
    FixChecksum(&archive, archive.size() - 512);
    archive += data + std::string((512 - data.size() % 512) % 512, '\0');
  }
  return archive + std::string(1024, '\0');
}

// How many regular files lie under `dir`.
size_t CountFiles(const fs::path& dir) {
  size_t count = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) count += entry.is_regular_file();
  return count;
}

// What GET .../burst.tar writes (pax for a long name) extracts the same.
TEST_F(TarExtractTest, RoundTripsFilesAndLongNames) {
  const std::string long_name(150, 'n');  // ustar's name field holds 100
  const Files files = {{"manifest.json", "{}"},
                       {"frames/000000.png", std::string(100000, '\x7f')},
                       {"frames/" + long_name, ""}};
  for (const auto& [name, data] : files) {
    fs::create_directories((dir_ / "src" / name).parent_path());
    WriteFileAtomically(dir_ / "src" / name, data);
  }
  DirectoryTar tar(dir_ / "src");
  std::string archive;
  for (std::string piece = tar.Next(); !piece.empty(); piece = tar.Next()) archive += piece;
  EXPECT_EQ(archive.size() % 512, 0u);
  EXPECT_NE(archive.find("path=frames/" + long_name), std::string::npos) << "a pax header";
  const fs::path out = Fresh();
  ExtractTar(archive, out, {});
  EXPECT_EQ(CountFiles(out), files.size());
  for (const auto& [name, data] : files) EXPECT_EQ(ReadFileToString(out / name), data);
}

// The burst is the top level or its single top-level directory; anything
// else is no burst.
TEST_F(TarExtractTest, BurstRootIsTheTopLevelOrItsOneDirectory) {
  const fs::path top = Fresh();
  WriteFileAtomically(top / "manifest.json", "{}");
  EXPECT_EQ(BurstRootOf(top), top);
  const fs::path nested = Fresh();
  fs::create_directories(nested / "burst");
  WriteFileAtomically(nested / "burst" / "manifest.json", "{}");
  EXPECT_EQ(BurstRootOf(nested), nested / "burst");
  fs::create_directories(nested / "other");
  EXPECT_EQ(BurstRootOf(nested), std::nullopt) << "two top-level directories";
  const fs::path empty = Fresh();
  fs::create_directories(empty / "burst");
  EXPECT_EQ(BurstRootOf(empty), std::nullopt) << "no manifest.json";
}

// tar's default format (GNU, with 'L' long-name headers), pax and ustar.
TEST_F(TarExtractTest, ReadsWhatTarWrites) {
  if (!HasTar()) GTEST_SKIP() << "no tar program";
  const std::string top(130, 'b');  // every name in it is over ustar's 100
  fs::create_directories(dir_ / top / "frames");
  std::ofstream(dir_ / top / "manifest.json") << "{\"format\":\"dfsm-burst/1\"}";
  std::ofstream(dir_ / top / "frames" / "000000.png") << "png";
  for (const char* format : {"", "--format=pax", "--format=gnu"}) {
    const fs::path out = Fresh();
    ExtractTar(Tar(format, top), out, {});
    EXPECT_EQ(ReadFileToString(out / top / "frames" / "000000.png"), "png") << format;
    EXPECT_EQ(ReadFileToString(out / top / "manifest.json"), "{\"format\":\"dfsm-burst/1\"}");
    EXPECT_EQ(CountFiles(out), 2u) << format;
  }
  // "./" as the archive's top, as `tar -C dir -cf x.tar .` writes it.
  const fs::path out = Fresh();
  ExtractTar(Tar("", "./" + top), out, {});
  EXPECT_TRUE(fs::is_regular_file(out / top / "manifest.json"));
}

// A sparse file's holes would come back as zeros: 20 KiB of archive wrote
// 240 MiB, and an all-hole file was stored as 0 bytes. Both are refused and
// nothing of them is written.
TEST_F(TarExtractTest, SparseFilesAreRefused) {
  if (!HasTar()) GTEST_SKIP() << "no tar program";
  {
    std::ofstream file(dir_ / "sparse.bin", std::ios::binary);
    file.seekp(8 << 20);
    file << "end of a mostly empty file";
  }
  fs::resize_file(dir_ / "sparse.bin", (8 << 20) + 26);
  { std::ofstream(dir_ / "holes.bin", std::ios::binary); }
  fs::resize_file(dir_ / "holes.bin", 8 << 20);
  for (const char* format : {"--format=gnu", "--format=pax", "--format=posix"}) {
    for (const char* file : {"sparse.bin", "holes.bin"}) {
      const std::string archive = Tar(std::string("-S ") + format, file);
      EXPECT_LT(archive.size(), 64u << 10) << format << " " << file;
      const fs::path out = Fresh();
      std::string error;
      try {
        ExtractTar(archive, out, {});
      } catch (const TarError& e) {
        error = e.what();
      }
      EXPECT_NE(error.find(file), std::string::npos) << format << " " << file << ": " << error;
      EXPECT_TRUE(error.find("sparse") != std::string::npos ||
                  error.find("expands") != std::string::npos ||
                  error.find("declares") != std::string::npos)
          << error;
      EXPECT_FALSE(fs::exists(out / file) && fs::file_size(out / file) >= (1u << 20))
          << format << " " << file;
    }
  }
}

TEST_F(TarExtractTest, RejectsLinksAndSpecialFiles) {
  if (!HasTar()) GTEST_SKIP() << "no tar program";
  std::ofstream(dir_ / "file") << "x";
  fs::create_symlink("file", dir_ / "symlink");
  fs::create_hard_link(dir_ / "file", dir_ / "hardlink");
  ASSERT_EQ(::mkfifo((dir_ / "fifo").c_str(), 0600), 0);
  EXPECT_NE(ErrorOf(Tar("", "symlink")).find("'symlink': links are not allowed"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Tar("", "file hardlink")).find("'hardlink': links are not allowed"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Tar("--format=pax", "fifo")).find("'fifo': not a regular file or directory"),
            std::string::npos);
}

TEST_F(TarExtractTest, RejectsPathsThatLeaveTheArchive) {
  EXPECT_NE(ErrorOf(Ustar({{"../etc/passwd", "x"}})).find("leaves the archive"), std::string::npos);
  EXPECT_NE(ErrorOf(Ustar({{"a/../../b", "x"}})).find("leaves the archive"), std::string::npos);
  EXPECT_NE(ErrorOf(Ustar({{"/etc/passwd", "x"}})).find("absolute path"), std::string::npos);
  EXPECT_NE(ErrorOf(Ustar({{"a\\b", "x"}})).find("backslash"), std::string::npos);
  EXPECT_NE(ErrorOf(Ustar({{"a", "x"}, {"./a", "y"}})).find("duplicate"), std::string::npos);
  EXPECT_NE(ErrorOf(Ustar({{"a", "x"}, {"a/b", "y"}})).find("below the file"), std::string::npos);
  TarLimits shallow;
  shallow.max_depth = 2;
  EXPECT_NE(ErrorOf(Ustar({{"a/b/c", "x"}}), shallow).find("nested too deeply"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / "etc"));
}

// A gzip upload was reported as "checksum in base-256 is not supported".
TEST_F(TarExtractTest, NamesACompressedArchive) {
  const std::string tar = Ustar({{"manifest.json", "{}"}});
  EXPECT_EQ(ErrorOf("\x1F\x8B\x08" + tar),
            "a gzip-compressed archive: upload an uncompressed tar (tar -cf, not tar -czf)");
  EXPECT_NE(ErrorOf("BZh9" + tar).find("a bzip2-compressed archive"), std::string::npos);
  EXPECT_NE(ErrorOf(std::string("\xFD"
                                "7zXZ\x00",
                                6) +
                    tar)
                .find("a xz-compressed archive"),
            std::string::npos);
  EXPECT_NE(ErrorOf("\x28\xB5\x2F\xFD" + tar).find("a zstd-compressed archive"), std::string::npos);
}

TEST_F(TarExtractTest, RejectsDamageAndOversize) {
  const std::string archive = Ustar({{"manifest.json", std::string(600, 'm')}});
  std::string corrupt = archive;
  corrupt[0] = 'n';  // the checksum no longer matches
  EXPECT_NE(ErrorOf(corrupt).find("not a tar archive"), std::string::npos) << ErrorOf(corrupt);
  EXPECT_NE(ErrorOf(archive.substr(0, 700)).find("truncated"), std::string::npos);
  EXPECT_NE(ErrorOf(archive.substr(0, 300)).find("truncated"), std::string::npos);
  const std::string two = Ustar({{"a", "x"}, {"b", std::string(600, 'b')}});
  EXPECT_NE(ErrorOf(two.substr(0, 2000)).find("truncated in 'b'"), std::string::npos);
  EXPECT_NE(ErrorOf(two.substr(0, 1300)).find("truncated after 'a'"), std::string::npos)
      << ErrorOf(two.substr(0, 1300));
  EXPECT_EQ(ErrorOf(std::string(1024, '\0')), "tar archive is empty");
  EXPECT_NE(
      ErrorOf("this is not a tar file at all" + std::string(600, ' ')).find("not a tar archive"),
      std::string::npos);
  EXPECT_NE(ErrorOf("").find("not a tar archive"), std::string::npos);
  TarLimits small;
  small.max_file_bytes = 512;
  EXPECT_NE(ErrorOf(archive, small).find("exceeds the limit of 512"), std::string::npos);
  small = TarLimits();
  small.max_entries = 1;
  EXPECT_NE(ErrorOf(Ustar({{"a", ""}, {"b", ""}}), small).find("more than 1 entries"),
            std::string::npos);
  small = TarLimits();
  small.max_total_bytes = 1000;
  EXPECT_NE(ErrorOf(Ustar({{"a", std::string(600, 'a')}, {"b", std::string(600, 'b')}}), small)
                .find("archive content exceeds the limit of 1000 bytes"),
            std::string::npos);
  std::string huge = archive;
  std::memcpy(huge.data() + 124, "77777777777", 11);  // 8 GiB announced
  FixChecksum(&huge, 0);
  EXPECT_NE(ErrorOf(huge).find("exceeds the limit"), std::string::npos);
}

}  // namespace
}  // namespace dfsm::service
