#include "app/store/catalog.hpp"

#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>

#include "app/store/atomic_file.hpp"
#include "app/store/shot_file.hpp"

namespace collide::app {

namespace fs = std::filesystem;

namespace {

// The columns, in the order every statement binds and reads them.
constexpr const char* kColumns =
    "id, file, wall_time_unix_ns, rig_name, material,"
    " wanted_speed_0_m_s, wanted_speed_1_m_s, commanded_0_kpa, commanded_1_kpa,"
    " readback_0_kpa, readback_1_kpa, status, failure_reason, frames, analysed,"
    " e, beta, f, gamma_deg, vn_m_s, vs_m_s, quality_flags, note";
constexpr int kColumnCount = 23;

constexpr const char* kCreateSchema = R"sql(
CREATE TABLE IF NOT EXISTS shots (
  id                 TEXT PRIMARY KEY NOT NULL,
  file               TEXT NOT NULL,
  wall_time_unix_ns  INTEGER NOT NULL,
  rig_name           TEXT NOT NULL,
  material           TEXT NOT NULL,
  wanted_speed_0_m_s REAL,   -- NULL: pressure set directly
  wanted_speed_1_m_s REAL,
  commanded_0_kpa    REAL,
  commanded_1_kpa    REAL,
  readback_0_kpa     REAL,
  readback_1_kpa     REAL,
  status             TEXT NOT NULL CHECK (status IN ('ok', 'failed')),
  failure_reason     TEXT NOT NULL,
  frames             INTEGER NOT NULL,
  analysed           INTEGER NOT NULL CHECK (analysed IN (0, 1)),
  e                  REAL,   -- results: NULL until analysed
  beta               REAL,
  f                  REAL,
  gamma_deg          REAL,
  vn_m_s             REAL,
  vs_m_s             REAL,
  quality_flags      TEXT,   -- comma-separated
  note               TEXT NOT NULL DEFAULT ''
);
CREATE INDEX IF NOT EXISTS shots_by_time ON shots (wall_time_unix_ns);
CREATE INDEX IF NOT EXISTS shots_by_material ON shots (material, wall_time_unix_ns);
)sql";

struct DbCloser {
  void operator()(sqlite3* db) const { sqlite3_close_v2(db); }
};
struct StmtFinalizer {
  void operator()(sqlite3_stmt* s) const { sqlite3_finalize(s); }
};
using Db = std::unique_ptr<sqlite3, DbCloser>;
using Stmt = std::unique_ptr<sqlite3_stmt, StmtFinalizer>;

/// One line for the user from the database's last error.
Error dbError(sqlite3* db, const std::string& path, const std::string& doing) {
  const int code = sqlite3_extended_errcode(db) & 0xff;
  const int sys = sqlite3_system_errno(db);
  const std::string dir = fs::path(path).parent_path().string();
  if ((code == SQLITE_IOERR || code == SQLITE_FULL || code == SQLITE_CANTOPEN) && sys != 0)
    return ioError(sys, doing, path);
  if (code == SQLITE_FULL) return ioError(ENOSPC, doing, path);
  if (code == SQLITE_NOTADB || code == SQLITE_CORRUPT)
    return fail("catalog " + path + " is corrupt (" + sqlite3_errmsg(db) +
                "): run `collide catalog rebuild " + dir + "`");
  if (code == SQLITE_BUSY || code == SQLITE_LOCKED)
    return fail("catalog " + path + " stayed locked by another program for 5 s while " + doing +
                " it: try again");
  if (code == SQLITE_READONLY)
    return fail("catalog " + path + " is read-only: check the folder's permissions");
  return fail("catalog " + path + ": " + sqlite3_errmsg(db) + " while " + doing + " it");
}

void bindOptional(sqlite3_stmt* s, int i, const std::optional<double>& v) {
  if (v)
    sqlite3_bind_double(s, i, *v);
  else
    sqlite3_bind_null(s, i);
}

/// NaN is bound as NULL by SQLite itself; spelt out for the reader.
void bindMaybeNan(sqlite3_stmt* s, int i, double v) {
  if (std::isnan(v))
    sqlite3_bind_null(s, i);
  else
    sqlite3_bind_double(s, i, v);
}

void bindText(sqlite3_stmt* s, int i, const std::string& v) {
  sqlite3_bind_text(s, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
}

/// Binds `results` to the six numeric columns starting at `first`, then the flags.
void bindResults(sqlite3_stmt* s, int first, bool analysed, const ResultsSummary& r) {
  const std::optional<double>* numbers[] = {&r.e,         &r.beta,   &r.f,
                                            &r.gamma_deg, &r.vn_m_s, &r.vs_m_s};
  for (int k = 0; k < 6; ++k) bindOptional(s, first + k, *numbers[k]);
  if (analysed)
    bindText(s, first + 6, joinFlags(r.quality_flags));
  else
    sqlite3_bind_null(s, first + 6);
}

void bindRow(sqlite3_stmt* s, const CatalogRow& r) {
  bindText(s, 1, r.id);
  bindText(s, 2, r.file);
  sqlite3_bind_int64(s, 3, r.wall_time_unix_ns);
  bindText(s, 4, r.rig_name);
  bindText(s, 5, r.material);
  for (int k = 0; k < 2; ++k) {
    bindMaybeNan(s, 6 + k, r.wanted_speed_m_s[k]);
    bindMaybeNan(s, 8 + k, r.commanded_kPa[k]);
    bindMaybeNan(s, 10 + k, r.readback_kPa[k]);
  }
  bindText(s, 12, hw::toString(r.status));
  bindText(s, 13, r.failure_reason);
  sqlite3_bind_int64(s, 14, r.frames);
  sqlite3_bind_int(s, 15, r.analysed ? 1 : 0);
  bindResults(s, 16, r.analysed, r.results);
  bindText(s, 23, r.note);
}

std::string columnText(sqlite3_stmt* s, int i) {
  const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(s, i));
  return p ? std::string(p, static_cast<std::size_t>(sqlite3_column_bytes(s, i))) : std::string();
}

double columnDoubleOrNan(sqlite3_stmt* s, int i) {
  return sqlite3_column_type(s, i) == SQLITE_NULL ? std::numeric_limits<double>::quiet_NaN()
                                                  : sqlite3_column_double(s, i);
}

std::optional<double> columnOptional(sqlite3_stmt* s, int i) {
  if (sqlite3_column_type(s, i) == SQLITE_NULL) return std::nullopt;
  return sqlite3_column_double(s, i);
}

CatalogRow readRow(sqlite3_stmt* s) {
  CatalogRow r;
  r.id = columnText(s, 0);
  r.file = columnText(s, 1);
  r.wall_time_unix_ns = sqlite3_column_int64(s, 2);
  r.rig_name = columnText(s, 3);
  r.material = columnText(s, 4);
  for (int k = 0; k < 2; ++k) {
    r.wanted_speed_m_s[k] = columnDoubleOrNan(s, 5 + k);
    r.commanded_kPa[k] = columnDoubleOrNan(s, 7 + k);
    r.readback_kPa[k] = columnDoubleOrNan(s, 9 + k);
  }
  // The CHECK constraint admits only the two spellings.
  r.status = parseShotStatus(columnText(s, 11)).value_or(hw::ShotStatus::Failed);
  r.failure_reason = columnText(s, 12);
  r.frames = sqlite3_column_int64(s, 13);
  r.analysed = sqlite3_column_int(s, 14) != 0;
  std::optional<double>* numbers[] = {&r.results.e,         &r.results.beta,   &r.results.f,
                                      &r.results.gamma_deg, &r.results.vn_m_s, &r.results.vs_m_s};
  for (int k = 0; k < 6; ++k) *numbers[k] = columnOptional(s, 15 + k);
  r.results.quality_flags = splitFlags(columnText(s, 21));
  r.note = columnText(s, 22);
  return r;
}

}  // namespace

struct Catalog::Impl {
  std::string path;
  Db db;
  Stmt upsert, update_results, update_note, query;

  Result<Stmt> prepare(const std::string& sql) {
    sqlite3_stmt* s = nullptr;
    if (sqlite3_prepare_v3(db.get(), sql.c_str(), -1, SQLITE_PREPARE_PERSISTENT, &s, nullptr) !=
        SQLITE_OK)
      return dbError(db.get(), path, "preparing a query on");
    return Stmt(s);
  }

  Status exec(const char* sql, const std::string& doing) {
    if (sqlite3_exec(db.get(), sql, nullptr, nullptr, nullptr) != SQLITE_OK)
      return dbError(db.get(), path, doing);
    return Ok{};
  }

  /// Runs a prepared statement that returns no rows, then resets it.
  Status step(sqlite3_stmt* s, const std::string& doing) {
    const int rc = sqlite3_step(s);
    Status status = Ok{};
    if (rc != SQLITE_DONE) status = dbError(db.get(), path, doing);
    sqlite3_reset(s);
    sqlite3_clear_bindings(s);
    return status;
  }

  /// Creates the schema in a new catalog, checks the version of an old one.
  Status ensureSchema(const std::string& dir) {
    Result<Stmt> version_stmt = prepare("PRAGMA user_version");
    if (!version_stmt) return version_stmt.error();
    if (sqlite3_step(version_stmt->get()) != SQLITE_ROW)
      return dbError(db.get(), path, "reading the version of");
    const int version = sqlite3_column_int(version_stmt->get(), 0);
    version_stmt->reset();
    if (version > kCatalogSchemaVersion)
      return fail("catalog " + path + " was written by a newer collide (schema " +
                  std::to_string(version) + ", this one knows up to " +
                  std::to_string(kCatalogSchemaVersion) + "): update collide, or run `collide " +
                  "catalog rebuild " + dir + "` to recreate it for this version");
    if (version == kCatalogSchemaVersion) return Ok{};
    if (auto s = exec("BEGIN IMMEDIATE", "creating"); !s) return s;
    // Version 1 (before notes): the table is there, the note column is added.
    Status created = version == 1
                         ? exec("ALTER TABLE shots ADD COLUMN note TEXT NOT NULL DEFAULT ''",
                                "updating the schema of")
                         : exec(kCreateSchema, "creating");
    if (created)
      created = exec(("PRAGMA user_version = " + std::to_string(kCatalogSchemaVersion)).c_str(),
                     "creating");
    if (created) created = exec("COMMIT", "creating");
    if (!created) sqlite3_exec(db.get(), "ROLLBACK", nullptr, nullptr, nullptr);
    return created;
  }
};

Catalog::Catalog(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Catalog::Catalog(Catalog&&) noexcept = default;
Catalog& Catalog::operator=(Catalog&&) noexcept = default;
Catalog::~Catalog() = default;

const std::string& Catalog::path() const {
  return impl_->path;
}

Result<Catalog> Catalog::open(const std::string& dir, Mode mode) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return fail("no such shot folder: " + dir);
  auto impl = std::make_unique<Impl>();
  impl->path = (fs::path(dir) / kCatalogFileName).string();
  if (mode == Mode::OpenExisting && !fs::exists(impl->path, ec))
    return fail("no catalog in " + dir + " (" + kCatalogFileName + " is missing): run `collide " +
                "catalog rebuild " + dir + "` to make one from the shot files");
  sqlite3* raw = nullptr;
  const int flags = SQLITE_OPEN_READWRITE | (mode == Mode::OpenOrCreate ? SQLITE_OPEN_CREATE : 0);
  const int rc = sqlite3_open_v2(impl->path.c_str(), &raw, flags, nullptr);
  impl->db.reset(raw);
  if (rc != SQLITE_OK) return dbError(raw, impl->path, "opening");
  sqlite3_extended_result_codes(raw, 1);
  sqlite3_busy_timeout(raw, 5000);
  // WAL: the GUI can list while a campaign inserts. synchronous=NORMAL is
  // durable enough for an index that can be rebuilt from the shot files.
  if (auto s = impl->exec("PRAGMA journal_mode = WAL; PRAGMA synchronous = NORMAL", "opening"); !s)
    return s.error();
  if (auto s = impl->ensureSchema(dir); !s) return s.error();

  const std::string placeholders = [] {
    std::string p;
    for (int i = 1; i <= kColumnCount; ++i) p += (i > 1 ? ", ?" : "?") + std::to_string(i);
    return p;
  }();
  auto upsert = impl->prepare(std::string("INSERT OR REPLACE INTO shots (") + kColumns +
                              ") VALUES (" + placeholders + ")");
  auto update_note = impl->prepare("UPDATE shots SET note = ?1 WHERE id = ?2");
  auto update = impl->prepare(
      "UPDATE shots SET analysed = ?1, e = ?2, beta = ?3, f = ?4, gamma_deg = ?5, vn_m_s = ?6,"
      " vs_m_s = ?7, quality_flags = ?8 WHERE id = ?9");
  // One statement for every combination of filters: an unset filter is bound
  // as NULL and matches everything.
  auto query = impl->prepare(std::string("SELECT ") + kColumns +
                             " FROM shots WHERE (?1 IS NULL OR material = ?1)"
                             " AND (?2 IS NULL OR status = ?2)"
                             " AND (?3 IS NULL OR wall_time_unix_ns >= ?3)"
                             " AND (?4 IS NULL OR wall_time_unix_ns < ?4)"
                             " ORDER BY wall_time_unix_ns, id");
  for (auto* r : {&upsert, &update, &update_note, &query})
    if (!*r) return r->error();
  impl->update_note = std::move(*update_note);
  impl->upsert = std::move(*upsert);
  impl->update_results = std::move(*update);
  impl->query = std::move(*query);
  return Catalog(std::move(impl));
}

Status Catalog::upsert(const CatalogRow& row) {
  bindRow(impl_->upsert.get(), row);
  return impl_->step(impl_->upsert.get(), "adding shot " + row.id + " to");
}

Status Catalog::replaceAll(const std::vector<CatalogRow>& rows) {
  if (auto s = impl_->exec("BEGIN IMMEDIATE", "rebuilding"); !s) return s;
  Status status = impl_->exec("DELETE FROM shots", "rebuilding");
  for (const auto& row : rows) {
    if (!status) break;
    status = upsert(row);
  }
  if (status) status = impl_->exec("COMMIT", "rebuilding");
  if (!status) sqlite3_exec(impl_->db.get(), "ROLLBACK", nullptr, nullptr, nullptr);
  return status;
}

Status Catalog::updateResults(const std::string& id, const std::string& results_json) {
  ResultsSummary summary;
  if (!results_json.empty()) {
    auto parsed = summarizeResults(results_json);
    if (!parsed)
      return fail("cannot record the results of shot " + id + " in " + impl_->path + ": " +
                  parsed.error().message);
    summary = std::move(*parsed);
  }
  sqlite3_stmt* s = impl_->update_results.get();
  const bool analysed = !results_json.empty();
  sqlite3_bind_int(s, 1, analysed ? 1 : 0);
  bindResults(s, 2, analysed, summary);
  bindText(s, 9, id);
  if (auto st = impl_->step(s, "recording results in"); !st) return st;
  if (sqlite3_changes(impl_->db.get()) == 0)
    return fail("no shot " + id + " in catalog " + impl_->path + ": run `collide catalog rebuild " +
                fs::path(impl_->path).parent_path().string() + "`");
  return Ok{};
}

Status Catalog::updateNote(const std::string& id, const std::string& note) {
  sqlite3_stmt* s = impl_->update_note.get();
  bindText(s, 1, note);
  bindText(s, 2, id);
  if (auto st = impl_->step(s, "recording the note in"); !st) return st;
  if (sqlite3_changes(impl_->db.get()) == 0)
    return fail("no shot " + id + " in catalog " + impl_->path + ": run `collide catalog rebuild " +
                fs::path(impl_->path).parent_path().string() + "`");
  return Ok{};
}

Result<std::vector<CatalogRow>> Catalog::query(const ShotFilter& filter) const {
  sqlite3_stmt* s = impl_->query.get();
  if (filter.material) bindText(s, 1, *filter.material);
  if (filter.status) bindText(s, 2, hw::toString(*filter.status));
  if (filter.since_unix_ns) sqlite3_bind_int64(s, 3, *filter.since_unix_ns);
  if (filter.until_unix_ns) sqlite3_bind_int64(s, 4, *filter.until_unix_ns);
  std::vector<CatalogRow> rows;
  int rc;
  while ((rc = sqlite3_step(s)) == SQLITE_ROW) rows.push_back(readRow(s));
  Result<std::vector<CatalogRow>> out = std::move(rows);
  if (rc != SQLITE_DONE) out = dbError(impl_->db.get(), impl_->path, "reading");
  sqlite3_reset(s);
  sqlite3_clear_bindings(s);
  return out;
}

CatalogRow catalogRow(const hw::Shot& shot, const std::string& file_name) {
  CatalogRow r;
  r.id = shot.id;
  r.file = file_name;
  r.wall_time_unix_ns = shot.wall_time_unix_ns;
  r.rig_name = shot.rig_name;
  r.material = shot.scene.material_name;
  for (int k = 0; k < 2; ++k) {
    r.wanted_speed_m_s[k] = shot.launchers[k].wanted_speed_m_s;
    r.commanded_kPa[k] = shot.launchers[k].commanded_kPa;
    r.readback_kPa[k] = shot.launchers[k].readback_kPa;
  }
  r.status = shot.status;
  r.failure_reason = shot.failure_reason;
  r.frames = static_cast<std::int64_t>(shot.burst.frames.size());
  r.analysed = !shot.results_json.empty();
  r.note = shot.note;
  // writeShot and storeResults refuse results that do not parse, so a stored
  // shot's summary is always available.
  if (r.analysed)
    if (auto summary = summarizeResults(shot.results_json)) r.results = std::move(*summary);
  return r;
}

Result<FolderContents> listShotFolder(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return fail("no such shot folder: " + dir);
  FolderContents out;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_regular_file(ec)) continue;
    // Hidden names are temporary files of writes (AtomicFile): in progress,
    // or left by a write that never finished.
    if (name.front() == '.' && name.find(".h5.tmp-") != std::string::npos)
      out.leftovers.push_back(name);
    else if (entry.path().extension() == ".h5" && name.front() != '.')
      out.shot_files.push_back(name);
  }
  if (ec) return ioError(ec.value(), "listing", dir);
  std::sort(out.shot_files.begin(), out.shot_files.end());
  std::sort(out.leftovers.begin(), out.leftovers.end());
  return out;
}

Result<RebuildReport> rebuildCatalog(const std::string& dir) {
  auto contents = listShotFolder(dir);
  if (!contents) return contents.error();
  const std::vector<std::string>& names = contents->shot_files;

  RebuildReport report;
  report.leftovers = contents->leftovers;
  std::vector<CatalogRow> rows;
  std::map<std::string, std::string> file_of_id;
  for (const auto& name : names) {
    auto shot = readShot((fs::path(dir) / name).string(), {.frames = false, .contained = true});
    if (!shot) {
      report.unreadable.push_back({name, shot.error().message});
      continue;
    }
    const auto [it, fresh] = file_of_id.emplace(shot->id, name);
    if (!fresh) {
      report.unreadable.push_back(
          {name, "shot id " + shot->id + " is also the id of " + it->second +
                     ", which the catalog lists: remove or rename the copy"});
      continue;
    }
    rows.push_back(catalogRow(*shot, name));
  }

  auto catalog = Catalog::open(dir);
  if (!catalog) {
    // A corrupt catalog holds nothing the shot files do not: start afresh.
    std::error_code ec;
    for (const char* suffix : {"", "-wal", "-shm"})
      fs::remove(fs::path(dir) / (std::string(kCatalogFileName) + suffix), ec);
    catalog = Catalog::open(dir);
    if (!catalog) return catalog.error();
  }
  if (auto s = catalog->replaceAll(rows); !s) return s.error();
  report.shots = rows.size();
  return report;
}

}  // namespace collide::app
