#pragma once
// Saving a shot into a shot folder: the HDF5 file first, then its catalog row,
// so a save that fails leaves neither a file under the real name nor a row
// (a row always points at a complete file).
#include <string>

#include "analysis/result.hpp"
#include "app/store/shot_file.hpp"
#include "hw/shot.hpp"

namespace collide::app {

/// "<id>.h5": the file name of shot `id` in its folder.
std::string shotFileName(const std::string& id);

/// Writes `shot` to `dir`/<id>.h5 (creating `dir` if needed), then adds its
/// row to `dir`/catalog.sqlite, and returns the id it was saved under.
/// A shot never replaces another: when <id>.h5 exists (an earlier campaign in
/// the same second, another process saving into the same folder at once) the
/// shot takes the next free id (nextShotId) and is stored with it, file and
/// row alike. Errors: an id that cannot be a file name, the folder cannot be
/// created, any writeShot error (nothing is left behind), the catalog cannot
/// be updated (the file is then complete and the message says to run
/// `collide catalog rebuild DIR`).
Result<std::string> saveShot(const std::string& dir, const hw::Shot& shot,
                             const WriteOptions& options = {});

/// Stores the analysis results of shot `id` (in `dir`/<id>.h5, see
/// storeResults), then updates its catalog row. Same error rules as saveShot.
/// Both under the folder's store lock (storeLockPath, a file the first store
/// creates in `dir`): processes storing into one folder at once (cluster
/// tasks) take turns, so a file and its row always hold the same results.
Status saveResults(const std::string& dir, const std::string& id, const std::string& results_json);

/// Stores the experimenter's note on shot `id` in its file (storeNote) and its
/// catalog row, the same way as saveResults (empty: no note).
Status saveNote(const std::string& dir, const std::string& id, const std::string& note);

}  // namespace collide::app
