#include "daemon/service/tar_extract.h"

#include <archive.h>
#include <archive_entry.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <memory>
#include <system_error>
#include <utility>
#include <vector>

#include "core/io/file_util.h"

namespace dfsm::service {
namespace fs = std::filesystem;
namespace {

constexpr size_t kBlock = 64 << 10;

// The compressed formats `tar -czf` and friends write: named, instead of
// libarchive's "Unrecognized archive format" as if the bytes were no tar.
const char* CompressionName(std::string_view start) {
  for (const auto& [magic, name] : {std::pair<std::string_view, const char*>{"\x1F\x8B", "gzip"},
                                    {"BZh", "bzip2"},
                                    {"\xFD\x37\x7A\x58\x5A", "xz"},
                                    {"\x28\xB5\x2F\xFD", "zstd"}})
    if (start.substr(0, magic.size()) == magic) return name;
  return nullptr;
}

// libarchive pulls the archive through this. Blocks are filled whole (or to
// the end), so the first one shows a compression's magic.
struct Reader {
  const TarSource& source;
  std::vector<char> buffer = std::vector<char>(kBlock);
  bool first = true;
  const char* compression = nullptr;
  uint64_t consumed = 0;  // archive bytes handed to libarchive

  static la_ssize_t Read(archive* a, void* self, const void** block) {
    auto* reader = static_cast<Reader*>(self);
    try {  // no exception may cross libarchive's C frames
      size_t filled = 0;
      for (size_t n = 1; n > 0 && filled < kBlock; filled += n)
        n = reader->source(reader->buffer.data() + filled, kBlock - filled);
      if (std::exchange(reader->first, false) &&
          (reader->compression = CompressionName({reader->buffer.data(), filled}))) {
        archive_set_error(a, EINVAL, "compressed");
        return -1;
      }
      *block = reader->buffer.data();
      reader->consumed += filled;
      return static_cast<la_ssize_t>(filled);
    } catch (const std::exception& e) {
      archive_set_error(a, EIO, "%s", e.what());
      return -1;
    }
  }
};

std::string ArchiveError(archive* a, const std::string& where) {
  const char* message = archive_error_string(a);
  return "tar archive damaged or truncated" + where + ": " +
         (message ? message : "it ends inside an entry");
}

// Writes the current entry's data, `size` bytes as its header declares, to
// `path`. `written` counts the archive's bytes written so far: they never
// exceed the bytes read (`reader.consumed`), so no entry expands on disk.
void WriteEntry(archive* a, const Reader& reader, const fs::path& path, const std::string& name,
                int64_t size, uint64_t* written) {
  std::ofstream out(path, std::ios::binary);
  std::vector<char> buffer(kBlock);
  int64_t bytes = 0;
  for (la_ssize_t n; out && (n = archive_read_data(a, buffer.data(), buffer.size())) != 0;) {
    if (n < 0) throw TarError(ArchiveError(a, " in '" + name + "'"));
    bytes += n;
    *written += static_cast<uint64_t>(n);
    if (*written > reader.consumed)
      throw TarError("tar entry '" + name + "' expands beyond the bytes uploaded");
    out.write(buffer.data(), n);
  }
  out.close();  // a full disk often shows only when the buffer is flushed
  if (!out) throw std::system_error(errno, std::generic_category(), "cannot write " + name);
  if (bytes != size) {
    throw TarError("tar entry '" + name + "' declares " + std::to_string(size) +
                   " bytes but holds " + std::to_string(bytes));
  }
}

}  // namespace

void ExtractTar(const TarSource& source, const fs::path& dir, const TarLimits& limits) {
  Reader reader{source};
  const std::unique_ptr<archive, int (*)(archive*)> a(archive_read_new(), archive_read_free);
  if (!a) throw std::bad_alloc();
  archive_read_support_format_tar(a.get());  // ustar, pax, GNU, v7; no filter
  if (archive_read_open(a.get(), &reader, nullptr, &Reader::Read, nullptr) != ARCHIVE_OK) {
    if (reader.compression) {
      throw TarError(std::string("a ") + reader.compression +
                     "-compressed archive: upload an uncompressed tar (tar -cf, not tar -czf)");
    }
    const char* message = archive_error_string(a.get());
    throw TarError(std::string("not a tar archive, or truncated in its first header: ") +
                   (message ? message : "unreadable"));
  }
  TarPolicy policy(limits);
  uint64_t written = 0;
  std::string last;
  archive_entry* entry = nullptr;
  for (int status; (status = archive_read_next_header(a.get(), &entry)) != ARCHIVE_EOF;) {
    // A warning (an unknown pax keyword, a name not in the locale's charset)
    // leaves a usable header: the policy judges the name.
    if (status < ARCHIVE_WARN)
      throw TarError(ArchiveError(a.get(), last.empty() ? "" : " after '" + last + "'"));
    const char* raw = archive_entry_pathname(entry);
    if (!raw) raw = archive_entry_pathname_utf8(entry);
    last = raw ? raw : "";
    const std::string name =
        policy.Admit(last, archive_entry_filetype(entry), archive_entry_hardlink(entry) != nullptr,
                     archive_entry_size(entry));
    const fs::path path = dir / name;
    if (name.empty()) continue;
    // A sparse file's holes come back as zeros: a few KiB of archive could
    // fill the disk, and what is stored would not be what was uploaded.
    if (archive_entry_sparse_count(entry) > 0) {
      throw TarError("tar entry '" + name +
                     "' is a sparse file; archive the burst without --sparse (-S)");
    }
    // The policy refused every escaping name; this guards against its bugs.
    if (!IsLexicallyInside(dir, path)) throw TarError("tar entry '" + name + "' escapes");
    if (archive_entry_filetype(entry) == AE_IFDIR) {
      fs::create_directories(path);
    } else {
      fs::create_directories(path.parent_path());
      WriteEntry(a.get(), reader, path, name, archive_entry_size(entry), &written);
    }
  }
  policy.Finish();
}

void ExtractTar(std::string_view archive, const fs::path& dir, const TarLimits& limits) {
  ExtractTar(
      [&archive](char* buffer, size_t size) {
        const size_t n = std::min(size, archive.size());
        std::memcpy(buffer, archive.data(), n);
        archive.remove_prefix(n);
        return n;
      },
      dir, limits);
}

std::optional<std::filesystem::path> BurstRootOf(const std::filesystem::path& extracted) {
  namespace fs = std::filesystem;
  std::error_code error;
  if (fs::is_regular_file(extracted / "manifest.json", error)) return extracted;
  std::vector<fs::path> children;
  for (const auto& child : fs::directory_iterator(extracted)) children.push_back(child.path());
  if (children.size() == 1 && fs::is_directory(children[0], error) &&
      fs::is_regular_file(children[0] / "manifest.json", error))
    return children[0];
  return std::nullopt;
}

}  // namespace dfsm::service
