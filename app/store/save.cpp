#include "app/store/save.hpp"

#include <filesystem>
#include <functional>

#include "app/store/atomic_file.hpp"
#include "app/store/catalog.hpp"
#include "app/store/shot_id.hpp"

namespace collide::app {

namespace fs = std::filesystem;

namespace {

/// How many ids saveShot tries after the shot's own before giving up.
constexpr int kMaxIdAttempts = 10000;

Result<std::string> shotPath(const std::string& dir, const std::string& id) {
  // Ids are "YYYYMMDD-HHMMSS-NNNN"; refuse anything that would land outside
  // the folder or be taken for a temporary file.
  if (id.empty() || id.front() == '.' || id.find('/') != std::string::npos)
    return fail("shot id \"" + id + "\" cannot name a file in " + dir +
                ": ids are like 20260314-101500-0001");
  return (fs::path(dir) / shotFileName(id)).string();
}

Error catalogError(const std::string& dir, const std::string& path, const Error& cause) {
  return fail("saved " + path + " but could not catalog it (" + cause.message +
              "): run `collide catalog rebuild " + dir + "`");
}

}  // namespace

std::string shotFileName(const std::string& id) {
  return id + ".h5";
}

Result<std::string> saveShot(const std::string& dir, const hw::Shot& shot,
                             const WriteOptions& options) {
  if (auto path = shotPath(dir, shot.id); !path) return path.error();
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return ioError(ec.value(), "creating the folder", dir);
  // Skip the names already taken before writing (cheap); a writer that takes
  // the chosen name between this check and our rename makes us write again
  // under the next one, because the rename itself never replaces.
  hw::Shot renamed;
  const hw::Shot* to_write = &shot;
  std::string id = shot.id;
  for (int attempt = 0; attempt < kMaxIdAttempts; ++attempt) {
    if (fs::exists(fs::path(dir) / shotFileName(id), ec)) {
      id = nextShotId(id);
      continue;
    }
    if (id != shot.id) {
      if (to_write == &shot) renamed = shot;  // frames share their pixels
      renamed.id = id;
      to_write = &renamed;
    }
    const std::string path = (fs::path(dir) / shotFileName(id)).string();
    auto written = writeShotIfAbsent(path, *to_write, options);
    if (!written) return written.error();
    if (*written == WriteOutcome::NameTaken) {
      id = nextShotId(id);
      continue;
    }
    auto catalog = Catalog::open(dir);
    if (!catalog) return catalogError(dir, path, catalog.error());
    if (auto s = catalog->upsert(catalogRow(*to_write, shotFileName(id))); !s)
      return catalogError(dir, path, s.error());
    return id;
  }
  return fail("cannot save shot " + shot.id + " in " + dir + ": " + std::to_string(kMaxIdAttempts) +
              " ids after it are all taken; save into another folder (--out)");
}

namespace {

// The file's update (`store`, with the rename at its commit) and the catalog
// row's (`update_row`) under the folder's store lock: the file and its row
// always agree, whatever order two tasks storing one shot run in. The copy
// each store writes is made outside the lock.
Status storeUnderFolderLock(const std::string& dir, const std::string& path,
                            const std::function<Status(const CommitHook&)>& store,
                            const std::function<Status(Catalog&)>& update_row) {
  return store([&](const std::function<Status()>& rename) -> Status {
    auto folder_lock = FileLock::acquire(storeLockPath(dir));
    if (!folder_lock) return folder_lock.error();
    if (auto renamed = rename(); !renamed) return renamed;
    auto catalog = Catalog::open(dir);
    if (!catalog) return catalogError(dir, path, catalog.error());
    if (auto s = update_row(*catalog); !s) return catalogError(dir, path, s.error());
    return Ok{};
  });
}

}  // namespace

Status saveResults(const std::string& dir, const std::string& id, const std::string& results_json) {
  auto path = shotPath(dir, id);
  if (!path) return path.error();
  return storeUnderFolderLock(
      dir, *path, [&](const CommitHook& hook) { return storeResults(*path, results_json, hook); },
      [&](Catalog& c) { return c.updateResults(id, results_json); });
}

Status saveNote(const std::string& dir, const std::string& id, const std::string& note) {
  auto path = shotPath(dir, id);
  if (!path) return path.error();
  return storeUnderFolderLock(
      dir, *path, [&](const CommitHook& hook) { return storeNote(*path, note, hook); },
      [&](Catalog& c) { return c.updateNote(id, note); });
}

}  // namespace collide::app
