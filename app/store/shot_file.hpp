#pragma once
// One HDF5 file per shot, in the layout documented in docs/shot-format.md:
// frames as one N x H x W dataset (one frame per chunk), per-frame ids,
// timestamps and status, everything the rig did, the ground truth of a
// simulated shot, and the analysis results once there are some.
//
// Files appear under their real name only once complete (temporary name,
// fsync, rename): a crash or a full disk never leaves a half file behind.
// All functions may be called from any thread (HDF5 is built thread-safe and
// serialises its calls); two writers must not target the same path at once.
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "analysis/result.hpp"
#include "hw/shot.hpp"

namespace collide::app {

/// Format written by this version; readShot accepts this and older ones.
inline constexpr int kShotFormatVersion = 1;

struct WriteOptions {
  /// Lossless shuffle + deflate on the frames. Off by default: a burst is
  /// written while the rig waits, and uncompressed writes run at disk speed.
  bool compress = false;
  /// 1 (fast) .. 9 (small), used when compress is set. Camera frames are mostly
  /// noise around a few spheres: higher levels cost much more time for little size.
  int deflate_level = 1;
};

/// Writes `shot` to a new file `path` (conventionally "<dir>/<shot.id>.h5").
/// An existing file is never replaced: a recorded shot is lost only by the
/// user's hand. Errors (one line naming `path`): a file of that name exists,
/// folder missing or read-only, disk full ("no space left on device writing
/// shots/x.h5: free space or ..."), frames of different sizes or of a type
/// that does not match the pixel format, truth arrays of different lengths,
/// results that are not JSON. On error nothing is left under `path` (an
/// existing file is untouched) or in a temporary file.
Status writeShot(const std::string& path, const hw::Shot& shot, const WriteOptions& options = {});

/// What writeShotIfAbsent did.
enum class WriteOutcome { Written, NameTaken };

/// writeShot, except that a name already taken (checked atomically with the
/// final rename, so also against other processes) is an outcome, not an
/// error: nothing is written and the caller may choose another name.
Result<WriteOutcome> writeShotIfAbsent(const std::string& path, const hw::Shot& shot,
                                       const WriteOptions& options = {});

struct ReadOptions {
  /// Read the images. Without them every frame's id, timestamp and status are
  /// still read and Frame::image stays empty: enough for listing and
  /// cataloguing, and fast (only metadata is touched).
  bool frames = true;
  /// Read the file once in a helper process first (reader_process.hpp), so
  /// that a file corrupt in a way that crashes the HDF5 library (a damaged
  /// global heap makes libhdf5 1.10 read out of bounds) gives an error naming
  /// the file instead of ending this process (a folder scan goes on with the
  /// other files). Costs a second read (from the page cache); the helper is
  /// forked once and serves the reads that follow (a new one after a crash,
  /// and every 200 reads). On by default.
  bool contained = true;
  /// How long the contained read may take before the file is called corrupt
  /// (libhdf5 looped for ever on some damaged heaps, which the read driver now
  /// refuses first: heap_check_driver.hpp), in seconds; 0: 30 s plus
  /// the file's size at 20 MB/s (a slow disk). Fuzzing sets it short.
  double time_limit_s = 0;
};

/// Reads a shot file. Errors (one line naming `path`): no such file, not an
/// HDF5 file, an HDF5 file that is not a shot file, a newer format, a
/// truncated or corrupt file, a required dataset missing (named), frames
/// larger than any camera or than the free memory, and (with
/// `options.contained`) a file whose reading crashed the HDF5 library.
Result<hw::Shot> readShot(const std::string& path, const ReadOptions& options = {});

/// Replaces the analysis results stored in the shot file at `path` (empty
/// `results_json` removes them). The recorded data is never at risk: the file
/// is copied to a temporary name, the copy updated, then renamed over the
/// original (see the comment in shot_file.cpp for why not in place).
/// Errors: the file is not a readable shot file, the results are not JSON,
/// disk full while copying. A store killed midway leaves the file as it was
/// (and at worst its temporary copy, which the next store into `path` removes:
/// removeAbandonedTemps). Two stores into one file at once both complete, the
/// last rename winning; saveResults also serialises them with the catalog row.
Status storeResults(const std::string& path, const std::string& results_json);

/// Called by storeResults with the rename that makes the results visible:
/// it must call `rename` (e.g. under a lock) and return its status.
using CommitHook = std::function<Status(const std::function<Status()>& rename)>;
/// storeResults, the updated copy made and flushed first, then `at_commit`
/// around the rename (saveResults holds the folder's store lock there, and
/// updates the catalog row before releasing it).
Status storeResults(const std::string& path, const std::string& results_json,
                    const CommitHook& at_commit);

/// Replaces the experimenter's note stored in the shot file (empty removes
/// it), the same safe way as storeResults: a copy updated, then renamed over
/// the original (through `at_commit` when given).
Status storeNote(const std::string& path, const std::string& note,
                 const CommitHook& at_commit = {});

/// "ok" / "failed" (hw::toString's inverse); nullopt for anything else.
std::optional<hw::ShotStatus> parseShotStatus(std::string_view text);

}  // namespace collide::app
