#include "core/scene/scene_cache.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <utility>
#include <vector>

#include "core/scene/scene_file.h"
#include "core/util/pinned_kernels.h"

namespace kgd {
namespace fs = std::filesystem;
namespace {

constexpr uint64_t kFnvOffset = 1469598103934665603ull, kFnvPrime = 1099511628211ull;
// Bump when the exported scene format or what a built-in scene holds changes.
constexpr int kCacheFormat = 1;
// Entries kept per scene name (measurements, program builds); the least recently used go first. A
// scene takes 8-15 MB.
constexpr size_t kEntriesPerScene = 6;

uint64_t Fnv(const void* data, size_t n, uint64_t h = kFnvOffset) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * kFnvPrime;
  return h;
}

bool HashFile(const fs::path& path, uint64_t* hash) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  uint64_t h = kFnvOffset;
  std::vector<char> buf(1 << 16);
  while (in.read(buf.data(), buf.size()) || in.gcount() > 0) h = Fnv(buf.data(), static_cast<size_t>(in.gcount()), h);
  *hash = h;
  return true;
}

std::string Hex(uint64_t v) {
  char b[17];
  std::snprintf(b, sizeof b, "%016llx", static_cast<unsigned long long>(v));
  return b;
}

// The folder of one scene: name, measurements, the program's identity and its kernel level.
fs::path EntryDir(const std::string& dir, const std::string& name, const BodyMeasurements& m) {
  if (dir.empty()) return {};
  struct stat st {};
  uint64_t key = Fnv(&kCacheFormat, sizeof kCacheFormat);
  key = Fnv(name.data(), name.size(), key);
  key = Fnv(&m, sizeof m, key);  // every measurement (all doubles)
  if (stat("/proc/self/exe", &st) == 0) {
    key = Fnv(&st.st_size, sizeof st.st_size, key);
    key = Fnv(&st.st_mtim, sizeof st.st_mtim, key);
  }
  // A scene built with other numeric kernels differs in its last bits (core/util/pinned_kernels.h).
  const std::string kernels = RunningKernels();
  key = Fnv(kernels.data(), kernels.size(), key);
  return fs::path(dir) / "scenes" / (name + "-" + Hex(key));
}

// Removes the least recently used entries of scene `name` beyond kEntriesPerScene (a rebuilt program
// leaves its predecessor's entries behind).
void PruneEntries(const fs::path& scenes, const std::string& name) {
  std::error_code ec;
  std::vector<std::pair<fs::file_time_type, fs::path>> entries;
  for (const fs::directory_entry& e : fs::directory_iterator(scenes, ec)) {
    const std::string file = e.path().filename().string();
    if (!e.is_directory() || file.rfind(name + "-", 0) != 0 || file.find(".tmp") != std::string::npos) continue;
    entries.emplace_back(fs::last_write_time(e.path(), ec), e.path());
  }
  if (entries.size() <= kEntriesPerScene) return;
  std::sort(entries.begin(), entries.end());
  for (size_t i = 0; i + kEntriesPerScene < entries.size(); ++i) fs::remove_all(entries[i].second, ec);
}

}  // namespace

std::string SceneCacheDir() {
  if (const char* d = std::getenv("KGD_CACHE_DIR"); d && *d) return std::string(d) == "off" ? "" : d;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return (fs::path(x) / "kgd").string();
  if (const char* h = std::getenv("HOME"); h && *h) return (fs::path(h) / ".cache" / "kgd").string();
  return "";
}

std::optional<SceneSpec> LoadCachedScene(const std::string& cache_dir, const std::string& name, const BodyMeasurements& measurements) {
  const fs::path dir = EntryDir(cache_dir, name, measurements);
  if (dir.empty()) return std::nullopt;
  std::ifstream manifest(dir / "manifest.txt");
  if (!manifest) return std::nullopt;
  int files = 0;
  for (std::string hash, file; manifest >> hash >> file; ++files) {
    uint64_t h = 0;
    if (!HashFile(dir / file, &h) || Hex(h) != hash) return std::nullopt;  // damaged or partly written
  }
  if (files == 0) return std::nullopt;
  Result<SceneSpec> s = LoadScene((dir / "scene.json").string());
  if (!s.ok()) return std::nullopt;
  std::error_code ec;
  fs::last_write_time(dir, fs::file_time_type::clock::now(), ec);  // recently used
  return std::move(s).value();
}

Status StoreCachedScene(const std::string& cache_dir, const std::string& name, const BodyMeasurements& measurements,
                        const SceneSpec& scene) {
  const fs::path dir = EntryDir(cache_dir, name, measurements);
  if (dir.empty()) return Status::Error("scene cache: off");
  std::error_code ec;
  fs::create_directories(dir.parent_path(), ec);
  if (ec) return Status::Error("scene cache: " + dir.parent_path().string() + ": " + ec.message());
  const fs::path tmp = dir.string() + ".tmp" + std::to_string(getpid());
  fs::remove_all(tmp, ec);
  if (Status s = ExportScene(scene, tmp.string()); !s.ok()) {
    fs::remove_all(tmp, ec);
    return s;
  }
  std::ostringstream manifest;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(tmp)) {
    if (!e.is_regular_file()) continue;
    uint64_t h = 0;
    if (!HashFile(e.path(), &h)) return Status::Error("scene cache: cannot read " + e.path().string());
    manifest << Hex(h) << " " << fs::relative(e.path(), tmp).string() << "\n";
  }
  {
    std::ofstream m(tmp / "manifest.txt");
    m << manifest.str();
    if (!m) return Status::Error("scene cache: cannot write " + (tmp / "manifest.txt").string());
  }
  fs::remove_all(dir, ec);  // a damaged entry
  fs::rename(tmp, dir, ec);
  if (ec) fs::remove_all(tmp, ec);  // another process stored it first
  PruneEntries(dir.parent_path(), name);
  return Status::Ok();
}

}  // namespace kgd
