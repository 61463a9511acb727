#include "tools/dfsm/batch_inputs.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <stdexcept>
#include <tuple>

#include "core/io/burst.h"
#include "core/io/image_sequence.h"
#include "tools/dfsm/burst_input.h"
#include "tools/dfsm/video_input.h"

namespace dfsm::tools {
namespace fs = std::filesystem;
namespace {

bool IsBurstDirectory(const fs::path& path) {
  std::error_code error;
  return fs::is_regular_file(path / "manifest.json", error);
}

// Whether `dir` holds images of its own (a clip), not bursts.
bool HoldsImages(const fs::path& dir) {
  try {
    return !ListImageSequence(dir.string()).empty();
  } catch (const BurstError&) {
    return false;
  }
}

// The path absolute and normal, without a trailing separator, so that one
// burst given two ways ("in/a", "./in/a/") is one.
fs::path Normal(const fs::path& path) {
  fs::path normal = fs::absolute(path).lexically_normal();
  if (!normal.has_filename() && normal.has_parent_path() && normal != normal.root_path())
    normal = normal.parent_path();
  return normal;
}

bool IsGlob(const fs::path& path) {
  return path.filename().string().find_first_of("*?[") != std::string::npos;
}

// The path whose name a burst takes: the directory or tar itself, but for
// dfsmd's layout (<job>/burst/ and <job>/burst.tar: the job's) and a glob
// (its folder's).
fs::path NamedPath(const BatchItem& item) {
  const fs::path path(item.input);
  if (IsGlob(path)) return path.parent_path();
  if (item.tar ? path.stem() == "burst" : path.filename() == "burst") return path.parent_path();
  return path;
}

std::string Usable(const std::string& name) {
  return name.empty() || name == "." || name == ".." ? "burst" : name;
}

// A tar by its name less ".tar", anything else by its whole name.
std::string NameOf(const BatchItem& item) {
  const fs::path named = NamedPath(item);
  const bool file = (item.tar || IsVideoFile(item.input)) && named == fs::path(item.input);
  return Usable((file ? named.stem() : named.filename()).string());
}

// The item of `path`, named.
BatchItem ItemOf(const fs::path& path, bool tar) {
  BatchItem item;
  item.input = Normal(path).string();
  item.tar = tar;
  item.name = NameOf(item);
  return item;
}

void AddClip(const std::string& input, int window_frames, std::vector<BatchItem>* items) {
  const BatchItem clip = ItemOf(input, false);
  for (const BurstWindow& window : WindowsOf(clip.input, window_frames)) {
    BatchItem item = clip;
    if (window.frames > 0) item.name += "-from-" + std::to_string(window.start);
    item.start = window.start;
    item.frames = window.frames;
    items->push_back(item);
  }
}

// The bursts one level inside `dir`.
void AddDirectoryOfBursts(const fs::path& dir, int window_frames, std::vector<BatchItem>* items) {
  std::vector<fs::path> entries;
  std::error_code error;
  for (fs::directory_iterator it(dir, error), end; !error && it != end; it.increment(error))
    entries.push_back(it->path());
  if (error) throw BurstError("cannot list '" + dir.string() + "': " + error.message());
  std::sort(entries.begin(), entries.end());
  const size_t before = items->size();
  for (const fs::path& entry : entries) {
    if (entry.filename().string().front() == '.') continue;  // hidden, and the batch's scratch
    if (IsBurstDirectory(entry))
      items->push_back(ItemOf(entry, false));
    else if (IsTarFile(entry))
      items->push_back(ItemOf(entry, true));
    else if (IsBurstDirectory(entry / "burst"))  // a dfsmd job directory
      items->push_back(ItemOf(entry / "burst", false));
    else if (IsTarFile(entry / "burst.tar"))  // a job's burst as dfsmd serves it
      items->push_back(ItemOf(entry / "burst.tar", true));
    else if (IsVideoFile(entry.string()))
      try {
        AddClip(entry.string(), window_frames, items);
      } catch (const BurstError& e) {  // one broken clip fails alone
        BatchItem broken = ItemOf(entry, false);
        broken.error = e.what();
        items->push_back(broken);
      }
  }
  if (items->size() == before)
    throw BurstError("'" + dir.string() +
                     "' holds no burst: no manifest.json, no images, no burst directories, "
                     ".tar files, videos or dfsmd job directories one level down");
}

void AddInput(const std::string& input, int window_frames, std::vector<BatchItem>* items) {
  const fs::path path(input);
  std::error_code error;
  if (IsBurstDirectory(path)) {
    items->push_back(ItemOf(path, false));
  } else if (IsTarFile(path)) {
    items->push_back(ItemOf(path, true));
  } else if (fs::is_directory(path, error) && !HoldsImages(path)) {
    AddDirectoryOfBursts(path, window_frames, items);
  } else if (fs::exists(path, error) || IsImageSequence(input)) {
    if (fs::is_regular_file(path, error) && !IsVideoFile(input))
      throw BurstError("'" + input +
                       "' is a file but neither a .tar nor a video; give burst directories, "
                       "burst.tar files, videos, folders or globs of images, or directories of "
                       "them");
    AddClip(input, window_frames, items);
  } else {
    throw BurstError("'" + input + "': no such file or directory");
  }
}

// A name a burst cannot have: the batch's own entries in DIR.
bool Reserved(const std::string& name) { return name == "calibration" || name.front() == '.'; }

// Gives each name taken twice (or reserved) its parent folder's name in
// front, then a number, until every name is unique: the same inputs always
// give the same names.
void MakeNamesUnique(std::vector<BatchItem>* items) {
  std::map<std::string, int> uses;
  for (const BatchItem& item : *items) ++uses[item.name];
  for (BatchItem& item : *items)
    if (uses[item.name] > 1 || Reserved(item.name))
      item.name = Usable(NamedPath(item).parent_path().filename().string()) + "-" + item.name;
  std::set<std::string> taken;
  for (BatchItem& item : *items) {
    std::string name = item.name;
    for (int n = 2; taken.count(name) || Reserved(name); ++n)
      name = item.name + "-" + std::to_string(n);
    item.name = name;
    taken.insert(name);
  }
}

}  // namespace

bool IsTarFile(const fs::path& path) {
  std::error_code error;
  return path.extension() == ".tar" && fs::is_regular_file(path, error);
}

std::vector<BatchItem> ExpandBatchInputs(const std::vector<std::string>& inputs,
                                         int window_frames) {
  std::vector<BatchItem> items;
  for (const std::string& input : inputs) AddInput(input, window_frames, &items);
  std::sort(items.begin(), items.end(), [](const BatchItem& a, const BatchItem& b) {
    return std::tie(a.input, a.start) < std::tie(b.input, b.start);
  });
  items.erase(std::unique(items.begin(), items.end(),
                          [](const BatchItem& a, const BatchItem& b) {
                            return a.input == b.input && a.start == b.start;
                          }),
              items.end());
  MakeNamesUnique(&items);
  std::sort(items.begin(), items.end(),
            [](const BatchItem& a, const BatchItem& b) { return a.name < b.name; });
  return items;
}

std::string Shard::Suffix() const {
  if (whole()) return "";
  return ".shard-" + std::to_string(index) + "-of-" + std::to_string(count);
}

Shard ParseShard(const std::string& text) {
  const size_t slash = text.find('/');
  Shard shard;
  try {
    if (slash == std::string::npos) throw std::invalid_argument("");
    size_t used = 0;
    shard.index = std::stoi(text.substr(0, slash), &used);
    if (used != slash) throw std::invalid_argument("");
    shard.count = std::stoi(text.substr(slash + 1), &used);
    if (used != text.size() - slash - 1) throw std::invalid_argument("");
  } catch (const std::logic_error&) {
    throw std::invalid_argument("'" + text + "' is not I/N (e.g. 0/4)");
  }
  if (shard.count < 1) throw std::invalid_argument("N must be at least 1, got " + text);
  if (shard.index < 0 || shard.index >= shard.count)
    throw std::invalid_argument("I must be 0 to N-1, got " + text);
  return shard;
}

std::vector<BatchItem> ItemsOfShard(const std::vector<BatchItem>& items, const Shard& shard) {
  std::vector<BatchItem> mine;
  for (size_t k = shard.index; k < items.size(); k += shard.count) mine.push_back(items[k]);
  return mine;
}

}  // namespace dfsm::tools
