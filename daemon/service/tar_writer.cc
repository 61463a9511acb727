#include "daemon/service/tar_writer.h"

#include <archive.h>
#include <archive_entry.h>

#include <algorithm>

namespace dfsm::service {
namespace fs = std::filesystem;
namespace {

la_ssize_t AppendTo(archive*, void* out, const void* data, size_t size) {
  static_cast<std::string*>(out)->append(static_cast<const char*>(data), size);
  return static_cast<la_ssize_t>(size);
}

// A warning (a name not in the locale's charset, kept as bytes) still wrote.
void Check(archive* a, la_ssize_t status, const std::string& what) {
  const char* message = archive_error_string(a);
  if (status < ARCHIVE_WARN)
    throw TarError("cannot write " + what + " to a tar: " + (message ? message : "failed"));
}

void WriteHeader(archive* a, const std::string& path, int64_t size) {
  const std::unique_ptr<archive_entry, void (*)(archive_entry*)> entry(archive_entry_new(),
                                                                       archive_entry_free);
  archive_entry_set_pathname(entry.get(), path.c_str());
  archive_entry_set_filetype(entry.get(), AE_IFREG);
  archive_entry_set_perm(entry.get(), 0644);
  archive_entry_set_size(entry.get(), size);
  Check(a, archive_write_header(a, entry.get()), "the header of '" + path + "'");
}

}  // namespace

DirectoryTar::DirectoryTar(const fs::path& dir)
    : archive_(archive_write_new(), archive_write_free) {
  if (!archive_) throw std::bad_alloc();
  for (const auto& entry : fs::recursive_directory_iterator(dir))
    if (entry.is_regular_file())
      files_.emplace_back(entry.path().lexically_relative(dir).generic_string(), entry.path());
  std::sort(files_.begin(), files_.end());
  // 512-byte blocks: the end is not padded to tar's 10 KiB records.
  archive_write_set_format_pax_restricted(archive_.get());
  archive_write_set_bytes_per_block(archive_.get(), 512);
  Check(archive_.get(), archive_write_open(archive_.get(), &out_, nullptr, &AppendTo, nullptr),
        "the start");
}

std::string DirectoryTar::Next() {
  // libarchive writes whole 512-byte blocks, so a step may write nothing.
  while (out_.empty() && !closed_) Step();
  return std::exchange(out_, {});
}

void DirectoryTar::Step() {
  if (left_ > 0) {
    std::string piece(static_cast<size_t>(std::min<int64_t>(left_, 256 << 10)), '\0');
    const std::string& name = files_[next_file_ - 1].first;
    if (!file_.read(piece.data(), static_cast<std::streamsize>(piece.size())))
      throw TarError("'" + name + "' changed or vanished while it was being sent");
    Check(archive_.get(), archive_write_data(archive_.get(), piece.data(), piece.size()), name);
    left_ -= static_cast<int64_t>(piece.size());
  } else if (next_file_ < files_.size()) {
    const auto& [name, path] = files_[next_file_++];
    file_ = std::ifstream(path, std::ios::binary);
    left_ = static_cast<int64_t>(fs::file_size(path));  // throws when it vanished
    WriteHeader(archive_.get(), name, left_);
  } else {
    Check(archive_.get(), archive_write_close(archive_.get()), "the end");
    closed_ = true;
  }
}

}  // namespace dfsm::service
