#include "tests/support/tar_files.h"

#include <archive.h>
#include <archive_entry.h>

#include <algorithm>
#include <memory>
#include <stdexcept>

#include "core/io/file_util.h"

namespace dfsm::service {
namespace fs = std::filesystem;

std::string WriteTar(const std::vector<TarFile>& files) {
  std::string out;
  const std::unique_ptr<archive, int (*)(archive*)> a(archive_write_new(), archive_write_free);
  archive_write_set_format_pax_restricted(a.get());
  archive_write_set_bytes_per_block(a.get(), 512);
  const auto append = [](archive*, void* out, const void* data, size_t size) -> la_ssize_t {
    static_cast<std::string*>(out)->append(static_cast<const char*>(data), size);
    return static_cast<la_ssize_t>(size);
  };
  bool ok = archive_write_open(a.get(), &out, nullptr, append, nullptr) == ARCHIVE_OK;
  for (const TarFile& file : files) {
    const std::unique_ptr<archive_entry, void (*)(archive_entry*)> entry(archive_entry_new(),
                                                                         archive_entry_free);
    archive_entry_set_pathname(entry.get(), file.path.c_str());
    archive_entry_set_filetype(entry.get(), AE_IFREG);
    archive_entry_set_perm(entry.get(), 0644);
    archive_entry_set_size(entry.get(), static_cast<int64_t>(file.data.size()));
    ok = ok && archive_write_header(a.get(), entry.get()) >= ARCHIVE_WARN &&
         archive_write_data(a.get(), file.data.data(), file.data.size()) >= 0;
  }
  if (!ok || archive_write_close(a.get()) != ARCHIVE_OK)
    throw std::runtime_error(std::string("WriteTar: ") + archive_error_string(a.get()));
  return out;
}

std::vector<TarFile> CollectFiles(const fs::path& dir) {
  std::vector<TarFile> files;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file())
      files.push_back(
          {entry.path().lexically_relative(dir).generic_string(), ReadFileToString(entry.path())});
  }
  std::sort(files.begin(), files.end(),
            [](const TarFile& a, const TarFile& b) { return a.path < b.path; });
  return files;
}

}  // namespace dfsm::service
