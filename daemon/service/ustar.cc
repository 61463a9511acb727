#include "daemon/service/ustar.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>

#include "core/io/file_util.h"

namespace dfsm::service {
namespace {

constexpr size_t kBlock = 512;

// Offsets of the ustar header fields (POSIX.1-1988).
struct Field {
  size_t offset, size;
};
constexpr Field kName{0, 100}, kMode{100, 8}, kSize{124, 12}, kMtime{136, 12}, kChecksum{148, 8},
    kType{156, 1}, kMagic{257, 6}, kVersion{263, 2}, kPrefix{345, 155};

std::string FieldString(const char* header, Field field) {
  const char* begin = header + field.offset;
  const char* end = static_cast<const char*>(std::memchr(begin, '\0', field.size));
  return std::string(begin, end ? end : begin + field.size);
}

// Octal numbers, space- or NUL-terminated, leading spaces allowed. Base-256
// (GNU's large-size extension) is refused: a burst never needs it.
int64_t ParseOctal(const char* header, Field field, const std::string& what,
                   const std::string& where) {
  const unsigned char first = static_cast<unsigned char>(header[field.offset]);
  if (first & 0x80) throw TarError(where + ": " + what + " in base-256 is not supported");
  int64_t value = 0;
  size_t i = 0;
  while (i < field.size && header[field.offset + i] == ' ') ++i;
  bool any = false;
  for (; i < field.size; ++i) {
    const char c = header[field.offset + i];
    if (c == '\0' || c == ' ') break;
    if (c < '0' || c > '7') throw TarError(where + ": " + what + " is not an octal number");
    if (value > (int64_t{1} << 58)) throw TarError(where + ": " + what + " is too large");
    value = value * 8 + (c - '0');
    any = true;
  }
  if (!any) throw TarError(where + ": " + what + " is empty");
  return value;
}

bool IsZeroBlock(const char* block) {
  return std::all_of(block, block + kBlock, [](char c) { return c == '\0'; });
}

// Splits and checks a name: relative, no '.', '..' or empty components
// except a leading "./" and a trailing '/', printable characters only.
std::string NormalizeName(const std::string& raw, const TarLimits& limits,
                          const std::string& where) {
  if (raw.empty()) throw TarError(where + ": empty file name");
  if (raw[0] == '/') throw TarError(where + ": absolute path '" + raw + "' is not allowed");
  for (const char c : raw) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f || c == '\\') {
      throw TarError(where + ": file name contains a control character or backslash");
    }
  }
  std::vector<std::string> parts;
  std::stringstream stream(raw);
  std::string part;
  while (std::getline(stream, part, '/')) {
    if (part.empty() || part == ".") continue;
    if (part == "..") throw TarError(where + ": path '" + raw + "' leaves the archive ('..')");
    parts.push_back(part);
  }
  if (parts.empty()) return "";
  if (static_cast<int>(parts.size()) > limits.max_depth) {
    throw TarError(where + ": path '" + raw + "' is nested too deeply");
  }
  std::string name;
  for (const std::string& p : parts) name += (name.empty() ? "" : "/") + p;
  return name;
}

void PutString(char* header, Field field, const std::string& value) {
  std::memcpy(header + field.offset, value.data(), std::min(value.size(), field.size));
}

void PutOctal(char* header, Field field, int64_t value) {
  // field.size - 1 digits and a NUL, as POSIX asks.
  std::string digits(field.size - 1, '0');
  for (size_t i = digits.size(); i-- > 0 && value > 0; value /= 8) digits[i] = '0' + value % 8;
  if (value > 0) throw TarError("value too large for a ustar header field");
  PutString(header, field, digits);
}

// The compressed formats `tar -czf` and friends write: named, instead of
// failing on the first header's checksum as if the bytes were a damaged tar.
const char* CompressionName(std::string_view archive) {
  const auto starts = [&](std::string_view magic) {
    return archive.size() >= magic.size() && archive.substr(0, magic.size()) == magic;
  };
  if (starts("\x1F\x8B")) return "gzip";
  if (starts("BZh")) return "bzip2";
  if (starts(std::string_view("\xFD"
                              "7zXZ\x00",
                              6)))
    return "xz";
  if (starts("\x28\xB5\x2F\xFD")) return "zstd";
  return nullptr;
}

}  // namespace

std::vector<TarEntry> ReadTar(std::string_view archive, const TarLimits& limits) {
  if (const char* compression = CompressionName(archive))
    throw TarError(std::string("a ") + compression +
                   "-compressed archive: upload an uncompressed tar (tar -cf, not tar -czf)");
  std::vector<TarEntry> entries;
  std::set<std::string> seen;
  int64_t total = 0;
  size_t offset = 0;
  bool ended = false;
  while (offset + kBlock <= archive.size()) {
    const char* header = archive.data() + offset;
    const std::string where_offset = "tar header at byte " + std::to_string(offset);
    if (IsZeroBlock(header)) {
      ended = true;
      break;
    }
    // The checksum is the byte sum of the header with its own field read as spaces.
    int64_t sum = 0;
    for (size_t i = 0; i < kBlock; ++i) {
      const bool in_checksum = i >= kChecksum.offset && i < kChecksum.offset + kChecksum.size;
      sum += in_checksum ? ' ' : static_cast<unsigned char>(header[i]);
    }
    if (ParseOctal(header, kChecksum, "checksum", where_offset) != sum) {
      throw TarError(where_offset + ": checksum mismatch (not a tar file, or damaged)");
    }
    const std::string magic(header + kMagic.offset, kMagic.size);
    if (magic != std::string("ustar\0", 6) && magic != "ustar ") {
      throw TarError(where_offset + ": not a ustar header (magic '" + FieldString(header, kMagic) +
                     "')");
    }
    std::string raw = FieldString(header, kName);
    const std::string prefix = FieldString(header, kPrefix);
    // GNU's "ustar  " format has no prefix field (its bytes hold times instead).
    if (magic == std::string("ustar\0", 6) && !prefix.empty()) raw = prefix + "/" + raw;
    const std::string where = "tar entry '" + raw + "'";
    const char type = header[kType.offset];
    const int64_t size = ParseOctal(header, kSize, "size", where);
    ParseOctal(header, kMode, "mode", where);
    ParseOctal(header, kMtime, "mtime", where);
    static_cast<void>(kVersion);

    const bool is_file = type == '0' || type == '\0' || type == '7';
    const bool is_dir = type == '5';
    if (type == '1' || type == '2') throw TarError(where + ": links are not allowed");
    if (type == 'x' || type == 'g' || type == 'L' || type == 'K') {
      throw TarError(where +
                     ": pax/GNU extended headers are not supported (use 'tar --format=ustar')");
    }
    if (!is_file && !is_dir) {
      throw TarError(where + ": entry type '" + std::string(1, type) +
                     "' is not a regular file or directory");
    }
    if (is_dir && size != 0) throw TarError(where + ": directory with a size");
    if (size > limits.max_file_bytes) {
      throw TarError(where + ": " + std::to_string(size) + " bytes exceeds the limit of " +
                     std::to_string(limits.max_file_bytes));
    }
    total += size;
    if (total > limits.max_total_bytes) throw TarError(where + ": archive content too large");
    const size_t data_offset = offset + kBlock;
    if (static_cast<uint64_t>(size) > archive.size() - data_offset) {
      throw TarError(where + ": truncated (" + std::to_string(size) + " bytes announced, " +
                     std::to_string(archive.size() - data_offset) + " left)");
    }
    const std::string name = NormalizeName(raw, limits, where);
    if (!name.empty()) {
      if (!seen.insert(name).second) throw TarError(where + ": duplicate entry");
      if (static_cast<int>(entries.size()) >= limits.max_entries) {
        throw TarError("tar archive has more than " + std::to_string(limits.max_entries) +
                       " entries");
      }
      TarEntry entry;
      entry.path = name;
      entry.is_directory = is_dir;
      if (is_file) entry.data = archive.substr(data_offset, static_cast<size_t>(size));
      entries.push_back(entry);
    }
    offset = data_offset + (static_cast<size_t>(size) + kBlock - 1) / kBlock * kBlock;
  }
  if (!ended && offset != archive.size()) {
    throw TarError("tar archive truncated at byte " + std::to_string(offset));
  }
  if (entries.empty()) throw TarError("tar archive is empty");
  // A file may not also be a directory, nor lie below a file.
  for (const TarEntry& entry : entries) {
    if (entry.is_directory) continue;
    for (const TarEntry& other : entries) {
      if (other.path.size() > entry.path.size() &&
          other.path.compare(0, entry.path.size() + 1, entry.path + "/") == 0) {
        throw TarError("tar entry '" + other.path + "' lies below the file '" + entry.path + "'");
      }
    }
  }
  return entries;
}

void ExtractTar(const std::vector<TarEntry>& entries, const std::filesystem::path& dir,
                const std::function<void(const char* end)>& consumed) {
  for (const TarEntry& entry : entries) {
    const std::filesystem::path path = dir / entry.path;
    if (!IsLexicallyInside(dir, path)) throw TarError("tar entry '" + entry.path + "' escapes");
    if (entry.is_directory) {
      std::filesystem::create_directories(path);
      continue;
    }
    std::filesystem::create_directories(path.parent_path());
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    constexpr size_t kPiece = 64 << 10;
    for (size_t at = 0; at < entry.data.size() && out; at += kPiece) {
      const size_t piece = std::min(kPiece, entry.data.size() - at);
      out.write(entry.data.data() + at, static_cast<std::streamsize>(piece));
      if (consumed && out) consumed(entry.data.data() + at + piece);
    }
    // A full disk often shows only when the buffer is flushed at close.
    out.close();
    if (!out) throw TarError("cannot write '" + path.string() + "': " + std::strerror(errno));
  }
}

namespace {

// The ustar header of a regular file.
std::string FileHeader(const std::string& path, int64_t size, int64_t mtime) {
  char header[kBlock] = {};
  std::string name = path, prefix;
  if (name.size() > kName.size) {
    // Split at a '/' so that the prefix fits in 155 and the name in 100.
    const size_t split = name.rfind('/', kPrefix.size);
    if (split == std::string::npos || name.size() - split - 1 > kName.size) {
      throw TarError("file name too long for ustar: '" + path + "'");
    }
    prefix = name.substr(0, split);
    name = name.substr(split + 1);
  }
  PutString(header, kName, name);
  PutString(header, kPrefix, prefix);
  PutOctal(header, kMode, 0644);
  PutOctal(header, Field{108, 8}, 0);  // uid
  PutOctal(header, Field{116, 8}, 0);  // gid
  PutOctal(header, kSize, size);
  PutOctal(header, kMtime, mtime);
  header[kType.offset] = '0';
  std::memcpy(header + kMagic.offset, "ustar\0", 6);
  std::memcpy(header + kVersion.offset, "00", 2);
  std::memset(header + kChecksum.offset, ' ', kChecksum.size);
  int64_t sum = 0;
  for (const char c : header) sum += static_cast<unsigned char>(c);
  PutOctal(header, Field{kChecksum.offset, 7}, sum);  // 6 digits, NUL, then the space
  header[kChecksum.offset + 6] = '\0';
  return std::string(header, kBlock);
}

int64_t Padded(int64_t size) {
  return (size + static_cast<int64_t>(kBlock) - 1) / static_cast<int64_t>(kBlock) *
         static_cast<int64_t>(kBlock);
}

}  // namespace

std::string WriteTar(const std::vector<TarFile>& files, int64_t mtime) {
  std::string archive;
  for (const TarFile& file : files) {
    archive += FileHeader(file.path, static_cast<int64_t>(file.data.size()), mtime);
    archive += file.data;
    archive.append((kBlock - file.data.size() % kBlock) % kBlock, '\0');
  }
  archive.append(2 * kBlock, '\0');
  return archive;
}

TarStream::TarStream(const std::filesystem::path& dir) {
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    members_.push_back({entry.path().lexically_relative(dir).generic_string(), entry.path(),
                        static_cast<int64_t>(entry.file_size()), 0});
  }
  std::sort(members_.begin(), members_.end(),
            [](const Member& a, const Member& b) { return a.name < b.name; });
  for (Member& member : members_) {
    FileHeader(member.name, member.size, 0);  // refuses a name ustar cannot hold, now
    member.offset = size_;
    size_ += static_cast<int64_t>(kBlock) + Padded(member.size);
  }
  size_ += 2 * static_cast<int64_t>(kBlock);
}

std::string TarStream::Read(int64_t offset, size_t length) const {
  std::string out;
  if (offset < 0 || offset >= size_) return out;
  length = static_cast<size_t>(std::min<int64_t>(static_cast<int64_t>(length), size_ - offset));
  // The member holding `offset`: the last whose start is not after it.
  auto member = std::upper_bound(members_.begin(), members_.end(), offset,
                                 [](int64_t at, const Member& m) { return at < m.offset; });
  while (out.size() < length) {
    const int64_t at = offset + static_cast<int64_t>(out.size());
    const size_t want = length - out.size();
    if (member == members_.begin() || at >= size_ - 2 * static_cast<int64_t>(kBlock)) {
      out.append(want, '\0');  // the end-of-archive blocks
      break;
    }
    const Member& m = *std::prev(member);
    const int64_t in = at - m.offset;
    const int64_t data_end = static_cast<int64_t>(kBlock) + m.size;
    const int64_t member_end = static_cast<int64_t>(kBlock) + Padded(m.size);
    if (in >= member_end) {
      ++member;
      continue;
    }
    size_t n;
    if (in < static_cast<int64_t>(kBlock)) {
      const std::string header = FileHeader(m.name, m.size, 0);
      n = std::min(want, kBlock - static_cast<size_t>(in));
      out.append(header, static_cast<size_t>(in), n);
    } else if (in < data_end) {
      n = static_cast<size_t>(std::min<int64_t>(static_cast<int64_t>(want), data_end - in));
      std::ifstream file(m.file, std::ios::binary);
      file.seekg(in - static_cast<int64_t>(kBlock));
      std::string piece(n, '\0');
      file.read(piece.data(), static_cast<std::streamsize>(n));
      if (file.gcount() != static_cast<std::streamsize>(n))
        throw TarError("'" + m.name + "' changed or vanished while it was being sent");
      out += piece;
    } else {
      n = static_cast<size_t>(std::min<int64_t>(static_cast<int64_t>(want), member_end - in));
      out.append(n, '\0');
    }
  }
  return out;
}

std::vector<TarFile> CollectFiles(const std::filesystem::path& dir) {
  std::vector<TarFile> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    files.push_back(
        {entry.path().lexically_relative(dir).generic_string(), ReadFileToString(entry.path())});
  }
  std::sort(files.begin(), files.end(),
            [](const TarFile& a, const TarFile& b) { return a.path < b.path; });
  return files;
}

}  // namespace dfsm::service
