#include "daemon/service/ustar.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/io/file_util.h"

namespace dfsm::service {
namespace {

namespace fs = std::filesystem;

std::string ErrorOf(std::string_view archive, const TarLimits& limits = {}) {
  try {
    ReadTar(archive, limits);
  } catch (const TarError& e) {
    return e.what();
  }
  return "";
}

// Rewrites the checksum of the header at `offset` after a test edited it.
void FixChecksum(std::string* archive, size_t offset) {
  char* header = archive->data() + offset;
  std::memset(header + 148, ' ', 8);
  unsigned sum = 0;
  for (int i = 0; i < 512; ++i) sum += static_cast<unsigned char>(header[i]);
  std::snprintf(header + 148, 8, "%06o", sum);
}

TEST(UstarTest, RoundTripsFilesAndLongNames) {
  const std::string long_dir(120, 'd');
  const std::vector<TarFile> files = {{"manifest.json", "{}"},
                                      {"frames/000000.png", std::string(1000, '\x7f')},
                                      {long_dir + "/x.bin", ""}};
  const std::string archive = WriteTar(files);
  EXPECT_EQ(archive.size() % 512, 0u);
  const std::vector<TarEntry> entries = ReadTar(archive);
  ASSERT_EQ(entries.size(), 3u);
  for (size_t i = 0; i < files.size(); ++i) {
    EXPECT_EQ(entries[i].path, files[i].path);
    EXPECT_EQ(entries[i].data, files[i].data);
  }
}

TEST(UstarTest, ReadsWhatGnuTarWrites) {
  if (std::system("command -v tar >/dev/null 2>&1") != 0) GTEST_SKIP() << "no tar program";
  const fs::path dir = fs::temp_directory_path() / ("ustar-test-" + std::to_string(::getpid()));
  fs::create_directories(dir / "burst" / "frames");
  std::ofstream(dir / "burst" / "manifest.json") << "{\"format\":\"dfsm-burst/1\"}";
  std::ofstream(dir / "burst" / "frames" / "000000.png") << "png";
  for (const char* format : {"ustar", "gnu"}) {
    const std::string command = "tar -C " + dir.string() + " --format=" + format + " -cf " +
                                (dir / "a.tar").string() + " burst";
    ASSERT_EQ(std::system(command.c_str()), 0);
    const std::string archive = ReadFileToString(dir / "a.tar");
    const std::vector<TarEntry> entries = ReadTar(archive);
    std::vector<std::string> paths;
    for (const TarEntry& entry : entries) paths.push_back(entry.path);
    std::sort(paths.begin(), paths.end());
    EXPECT_EQ(paths, (std::vector<std::string>{"burst", "burst/frames", "burst/frames/000000.png",
                                               "burst/manifest.json"}))
        << format;
    const fs::path out = dir / (std::string("out-") + format);
    fs::create_directories(out);
    ExtractTar(entries, out);
    EXPECT_EQ(ReadFileToString(out / "burst" / "frames" / "000000.png"), "png");
  }
  fs::remove_all(dir);
}

TEST(UstarTest, RejectsPathsThatLeaveTheArchive) {
  EXPECT_NE(ErrorOf(WriteTar({{"../etc/passwd", "x"}})).find("leaves the archive"),
            std::string::npos);
  EXPECT_NE(ErrorOf(WriteTar({{"a/../../b", "x"}})).find("leaves the archive"), std::string::npos);
  EXPECT_NE(ErrorOf(WriteTar({{"/etc/passwd", "x"}})).find("absolute path"), std::string::npos);
  EXPECT_NE(ErrorOf(WriteTar({{"a\\b", "x"}})).find("backslash"), std::string::npos);
  EXPECT_NE(ErrorOf(WriteTar({{"a", "x"}, {"./a", "y"}})).find("duplicate"), std::string::npos);
  EXPECT_NE(ErrorOf(WriteTar({{"a", "x"}, {"a/b", "y"}})).find("below the file"),
            std::string::npos);
  TarLimits shallow;
  shallow.max_depth = 2;
  EXPECT_NE(ErrorOf(WriteTar({{"a/b/c", "x"}}), shallow).find("nested too deeply"),
            std::string::npos);
}

TEST(UstarTest, RejectsLinksDevicesAndExtendedHeaders) {
  for (const auto& [type, message] :
       std::vector<std::pair<char, std::string>>{{'1', "links are not allowed"},
                                                 {'2', "links are not allowed"},
                                                 {'3', "not a regular file"},
                                                 {'6', "not a regular file"},
                                                 {'x', "extended headers"},
                                                 {'L', "extended headers"}}) {
    std::string archive = WriteTar({{"frames/link", ""}});
    archive[156] = type;
    FixChecksum(&archive, 0);
    EXPECT_NE(ErrorOf(archive).find(message), std::string::npos)
        << type << ": " << ErrorOf(archive);
  }
}

// A gzip upload was reported as "checksum in base-256 is not supported".
TEST(UstarTest, NamesACompressedArchive) {
  const std::string tar = WriteTar({{"manifest.json", "{}"}});
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

TEST(UstarTest, RejectsDamageAndOversize) {
  std::string archive = WriteTar({{"manifest.json", std::string(600, 'm')}});
  std::string corrupt = archive;
  corrupt[0] = 'n';
  EXPECT_NE(ErrorOf(corrupt).find("checksum mismatch"), std::string::npos);
  EXPECT_NE(ErrorOf(archive.substr(0, 700)).find("truncated"), std::string::npos);
  EXPECT_NE(ErrorOf(archive.substr(0, 300)).find("truncated"), std::string::npos);
  EXPECT_EQ(ErrorOf(std::string(1024, '\0')), "tar archive is empty");
  EXPECT_NE(
      ErrorOf("this is not a tar file at all" + std::string(600, ' ')).find("header at byte 0"),
      std::string::npos);
  std::string bad_magic = archive;
  std::memcpy(bad_magic.data() + 257, "xxxxx", 5);
  FixChecksum(&bad_magic, 0);
  EXPECT_NE(ErrorOf(bad_magic).find("not a ustar header"), std::string::npos);
  TarLimits small;
  small.max_file_bytes = 512;
  EXPECT_NE(ErrorOf(archive, small).find("exceeds the limit of 512"), std::string::npos);
  small = TarLimits();
  small.max_entries = 1;
  EXPECT_NE(ErrorOf(WriteTar({{"a", ""}, {"b", ""}}), small).find("more than 1 entries"),
            std::string::npos);
  std::string huge = archive;
  std::memcpy(huge.data() + 124, "77777777777", 11);  // 8 GiB announced
  FixChecksum(&huge, 0);
  EXPECT_NE(ErrorOf(huge).find("exceeds the limit"), std::string::npos);
}

}  // namespace
}  // namespace dfsm::service

namespace dfsm::service {
namespace {

TEST(TarStreamTest, ReadsTheSameBytesAsWriteTarInAnyPieces) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("dfsm-tar-stream-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "frames");
  std::string big(70000, '\0');
  for (size_t i = 0; i < big.size(); ++i) big[i] = static_cast<char>(i * 7 + 3);
  WriteFileAtomically(dir / "manifest.json", "{}");
  WriteFileAtomically(dir / "frames" / "000000.png", big);
  WriteFileAtomically(dir / "frames" / "empty.png", "");
  WriteFileAtomically(dir / "frames" / std::string(95, 'n'), "long name");
  const std::string whole = WriteTar(CollectFiles(dir));
  const TarStream stream(dir);
  ASSERT_EQ(stream.size(), static_cast<int64_t>(whole.size()));
  for (const size_t piece : {1, 511, 512, 4096, 65536, 1 << 20}) {
    std::string read;
    for (int64_t at = 0; at < stream.size();) {
      const std::string part = stream.Read(at, piece);
      ASSERT_FALSE(part.empty()) << piece;
      read += part;
      at += static_cast<int64_t>(part.size());
    }
    EXPECT_EQ(read, whole) << "pieces of " << piece;
  }
  // Random access (HTTP ranges): any offset.
  EXPECT_EQ(stream.Read(1000, 3000), whole.substr(1000, 3000));
  EXPECT_TRUE(stream.Read(stream.size(), 10).empty());
  // A file that shrank after the listing is an error, not silent zeros.
  WriteFileAtomically(dir / "frames" / "000000.png", "short");
  EXPECT_THROW(stream.Read(0, static_cast<size_t>(stream.size())), TarError);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace dfsm::service
