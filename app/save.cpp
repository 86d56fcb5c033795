#include "app/save.hpp"

#include <filesystem>

#include "app/atomic_file.hpp"
#include "app/catalog.hpp"

namespace collide::app {

namespace fs = std::filesystem;

namespace {

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

Status saveShot(const std::string& dir, const hw::Shot& shot, const WriteOptions& options) {
  auto path = shotPath(dir, shot.id);
  if (!path) return path.error();
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return ioError(ec.value(), "creating the folder", dir);
  if (auto written = writeShot(*path, shot, options); !written) return written;
  auto catalog = Catalog::open(dir);
  if (!catalog) return catalogError(dir, *path, catalog.error());
  if (auto s = catalog->upsert(catalogRow(shot, shotFileName(shot.id))); !s)
    return catalogError(dir, *path, s.error());
  return Ok{};
}

Status saveResults(const std::string& dir, const std::string& id, const std::string& results_json) {
  auto path = shotPath(dir, id);
  if (!path) return path.error();
  if (auto stored = storeResults(*path, results_json); !stored) return stored;
  auto catalog = Catalog::open(dir);
  if (!catalog) return catalogError(dir, *path, catalog.error());
  if (auto s = catalog->updateResults(id, results_json); !s)
    return catalogError(dir, *path, s.error());
  return Ok{};
}

}  // namespace collide::app
