#include "app/manifest.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "app/store/catalog.hpp"

namespace collide::app {
namespace fs = std::filesystem;

Result<std::vector<ManifestEntry>> readManifest(const std::string& manifest_path) {
  std::error_code ec;
  if (fs::is_directory(manifest_path, ec))
    return fail(manifest_path + ": is a folder, not a manifest (make one with `collide manifest " +
                manifest_path + " --out LIST`)");
  std::ifstream in(manifest_path, std::ios::binary);
  if (!in)
    return fail(manifest_path + ": cannot read the manifest (no such file, or no permission)");
  const fs::path base = fs::absolute(manifest_path, ec).parent_path();
  std::vector<ManifestEntry> entries;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (!line.empty() && line.back() == '\r') line.pop_back();  // written on Windows
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    const auto last = line.find_last_not_of(" \t");
    std::string text = line.substr(first, last - first + 1);
    if (std::any_of(text.begin(), text.end(),
                    [](unsigned char c) { return c < 0x20 && c != '\t'; }))
      return fail(manifest_path + ":" + std::to_string(number) +
                  ": not a path (control characters): a manifest is a text file of shot-file "
                  "paths, one a line");
    fs::path p(text);
    if (p.is_relative()) p = base / p;
    entries.push_back({p.lexically_normal().string(), number});
  }
  if (in.bad()) return fail(manifest_path + ": error reading the manifest");
  if (entries.empty())
    return fail(manifest_path + ": the manifest lists no shot files (one path a line)");
  return entries;
}

long tasksFor(long shots, long chunk) {
  return chunk > 0 ? (shots + chunk - 1) / chunk : 0;
}

Result<std::vector<ManifestEntry>> manifestChunk(const std::vector<ManifestEntry>& entries,
                                                 const std::string& manifest_path, long index,
                                                 long chunk) {
  const long n = static_cast<long>(entries.size());
  if (chunk < 1) return fail("--chunk " + std::to_string(chunk) + ": give 1 or more shots a task");
  if (index < 0) return fail("--index " + std::to_string(index) + ": task indexes start at 0");
  const long tasks = tasksFor(n, chunk);
  if (index >= tasks)
    return fail("--index " + std::to_string(index) + " is past the end of " + manifest_path + ": " +
                std::to_string(n) + " shot" + (n == 1 ? "" : "s") + " in chunks of " +
                std::to_string(chunk) + " make " + std::to_string(tasks) + " task" +
                (tasks == 1 ? "" : "s") + " (indexes 0-" + std::to_string(tasks - 1) +
                ", sbatch --array=0-" + std::to_string(tasks - 1) + ")");
  const long begin = index * chunk;
  const long end = std::min(n, begin + chunk);
  return std::vector<ManifestEntry>(entries.begin() + begin, entries.begin() + end);
}

Result<std::vector<std::string>> listShotFiles(const std::vector<std::string>& folders) {
  if (folders.empty()) return fail("name one or more shot folders");
  std::vector<std::string> out;
  for (const auto& folder : folders) {
    auto contents = listShotFolder(folder);
    if (!contents) return contents.error();
    if (contents->shot_files.empty()) return fail(folder + ": no shot files (*.h5) in this folder");
    std::error_code ec;
    const fs::path abs = fs::absolute(folder, ec).lexically_normal();
    for (const auto& name : contents->shot_files) out.push_back((abs / name).string());
  }
  return out;
}

}  // namespace collide::app
