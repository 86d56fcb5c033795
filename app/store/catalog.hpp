#pragma once
// The catalog of a shot folder: one SQLite file (catalog.sqlite) next to the
// shot files, one row per shot, for listing and filtering without opening
// every .h5 file (the GUI's shot browser, `collide shots`). The shot files are
// the record; the catalog can always be rebuilt from them (rebuildCatalog).
//
// Threads: a Catalog object is used by one thread at a time. Several Catalog
// objects, in one process or several (GUI and a campaign), may share one file:
// it is in WAL mode (readers never block the writer) and waits up to 5 s for
// a lock.
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "analysis/result.hpp"
#include "app/report/results_summary.hpp"
#include "hw/shot.hpp"

namespace collide::app {

inline constexpr const char* kCatalogFileName = "catalog.sqlite";
/// Stored in PRAGMA user_version; a catalog from a newer collide is refused,
/// an older one is brought up to date when opened (1 -> 2: the note column).
inline constexpr int kCatalogSchemaVersion = 2;

/// One shot as the catalog lists it. Arrays are indexed like Shot::launchers
/// (launcher/sphere 0 and 1).
struct CatalogRow {
  std::string id;
  std::string file;  ///< file name inside the shot folder, e.g. "20260314-101500-0001.h5"
  std::int64_t wall_time_unix_ns = 0;
  std::string rig_name;
  std::string material;
  /// NaN where the pressure was set directly (stored as NULL).
  std::array<double, 2> wanted_speed_m_s{std::numeric_limits<double>::quiet_NaN(),
                                         std::numeric_limits<double>::quiet_NaN()};
  std::array<double, 2> commanded_kPa{0.0, 0.0};
  std::array<double, 2> readback_kPa{0.0, 0.0};
  hw::ShotStatus status = hw::ShotStatus::Ok;
  std::string failure_reason;
  std::int64_t frames = 0;
  bool analysed = false;
  ResultsSummary results;  ///< all empty (NULL) until analysed
  std::string note;        ///< the experimenter's note (Shot::note)
};

/// The catalog row of `shot`, stored as `file_name` in its folder. Results
/// come from shot.results_json (analysed when it is not empty).
CatalogRow catalogRow(const hw::Shot& shot, const std::string& file_name);

/// Conditions a listed shot must meet; unset ones do not filter.
struct ShotFilter {
  std::optional<std::string> material;
  std::optional<hw::ShotStatus> status;
  std::optional<std::int64_t> since_unix_ns;  ///< wall time >= since
  std::optional<std::int64_t> until_unix_ns;  ///< wall time < until
};

class Catalog {
 public:
  enum class Mode {
    OpenOrCreate,  ///< create catalog.sqlite if missing (the folder must exist)
    OpenExisting,  ///< error if there is no catalog.sqlite (listing must not create files)
  };
  /// Opens `dir`/catalog.sqlite. Errors: folder missing, no catalog (OpenExisting),
  /// not an SQLite file or corrupt (run `collide catalog rebuild DIR`), written
  /// by a newer collide, disk full while creating it.
  static Result<Catalog> open(const std::string& dir, Mode mode = Mode::OpenOrCreate);

  Catalog(Catalog&&) noexcept;
  Catalog& operator=(Catalog&&) noexcept;
  ~Catalog();

  const std::string& path() const;

  /// Inserts the row, or replaces the row with the same id.
  Status upsert(const CatalogRow& row);
  /// Replaces every row with `rows`, in one transaction (readers see the old
  /// catalog or the new one, never a mix).
  Status replaceAll(const std::vector<CatalogRow>& rows);
  /// Sets the results columns of shot `id` from its results JSON (empty: back
  /// to not analysed). Errors: no such shot, JSON not usable (see summarizeResults).
  Status updateResults(const std::string& id, const std::string& results_json);
  /// Sets the note of shot `id`. Errors: no such shot.
  Status updateNote(const std::string& id, const std::string& note);
  /// Matching rows, oldest first (ties by id).
  Result<std::vector<CatalogRow>> query(const ShotFilter& filter = {}) const;

 private:
  struct Impl;
  explicit Catalog(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

struct UnreadableFile {
  std::string file;     ///< file name inside the folder
  std::string message;  ///< why it was left out
};

struct RebuildReport {
  std::size_t shots = 0;  ///< rows now in the catalog
  std::vector<UnreadableFile> unreadable;
  /// Temporary files of writes that never finished (".<name>.tmp-XXXXXX",
  /// left by a power cut or a kill): not shots, safe to delete.
  std::vector<std::string> leftovers;
};

/// What a shot folder holds on disk, without reading any file.
struct FolderContents {
  std::vector<std::string> shot_files;  ///< "<id>.h5" names, sorted
  std::vector<std::string> leftovers;   ///< unfinished temporary files (see RebuildReport)
};

/// Lists `dir`. Errors: the folder cannot be listed.
Result<FolderContents> listShotFolder(const std::string& dir);

/// Recreates `dir`/catalog.sqlite from the .h5 files in `dir` alone (read
/// without frames). A file that cannot be read is reported and skipped; a
/// corrupt catalog is replaced. Errors: the folder is missing, the catalog
/// cannot be written.
Result<RebuildReport> rebuildCatalog(const std::string& dir);

}  // namespace collide::app
